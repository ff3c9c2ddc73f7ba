"""Self-contained HTML reports: one page style, escaped text, tables, inline PNG plots."""

import base64
import functools
import gc
import html
from datetime import datetime, timezone


CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,sans-serif;margin:2em auto;max-width:1100px;
color:#222;line-height:1.4}
h1{font-size:1.6em}h2{border-bottom:2px solid #ccc;padding-bottom:.2em;margin-top:2em}
table{border-collapse:collapse;margin:.6em 0 1.2em 0;font-size:.9em}
th,td{border:1px solid #ccc;padding:.2em .6em;text-align:right}
th{background:#f0f0f0}td.l,th.l{text-align:left}
tr.flag td{background:#fff1e0}tr.sig td{font-weight:600}
.note{color:#8a4b00}.muted{color:#666}img{max-width:100%;display:block;margin:.5em 0}
code{background:#f4f4f4;padding:0 .2em}
"""


def esc(x):
    """HTML-escaped text of ``x``."""
    return html.escape(str(x))


def num(x, sig=6):
    """A number with ``sig`` significant digits; '' for None, 'n/a' if not finite."""
    from fits._text import fmt_num

    return fmt_num(x, sig=sig, nonfinite="n/a")


def table(headers, rows, *, left=1, classes=None):
    """An HTML table; the first ``left`` columns are left-aligned; cells are raw HTML."""
    out = ["<table><tr>"]
    out += [f'<th class="l">{esc(h)}</th>' if i < left else f"<th>{esc(h)}</th>"
            for i, h in enumerate(headers)]
    out.append("</tr>")
    for k, r in enumerate(rows):
        cls = f' class="{classes[k]}"' if classes and classes[k] else ""
        out.append(f"<tr{cls}>")
        out += [f'<td class="l">{c}</td>' if i < left else f"<td>{c}</td>"
                for i, c in enumerate(r)]
        out.append("</tr>")
    out.append("</table>")
    return "".join(out)


#: A title's height on its axes (axes coordinates): given, matplotlib places it there
#: without measuring the axes' tick labels at every draw to find a place above them
#: (5 to 10 % of drawing a small plot). The plots here have nothing above their axes
#: (no top ticks or labels), so the title goes where it went before.
TITLE_Y = 1.0
#: zlib level and row filter of the inline PNGs (plots and footage): each row stored as
#: its difference from the row above ("up"; libpng's default tries five filters on every
#: row): run42's six images (three plots, two trajectories, the contact sheet) take
#: 24 ms and 482 kB, where level 3 with libpng's filters for five of them and OpenCV's
#: defaults for the sheet took 45 ms and 523 kB.
PNG_COMPRESS_LEVEL = 2


def without_gc(fn):
    """``fn`` run with Python's cyclic garbage collector paused (enabled again after, if
    it was).

    Drawing a page makes many small matplotlib objects (and the first time imports
    matplotlib, some 70 000 objects), and a collection they set off looks at every object
    of the process, the pipeline's too: run42's report stage spent 40 to 55 ms in them of
    its first two calls, 20 ms paused. What the page leaves unreachable is collected by
    the next collection after.

    Parameters
    ----------
    fn : callable

    Returns
    -------
    callable
        ``fn``, with the collector paused while it runs.
    """
    @functools.wraps(fn)
    def paused(*args, **kwargs):
        was = gc.isenabled()
        gc.disable()
        try:
            return fn(*args, **kwargs)
        finally:
            if was:
                gc.enable()

    return paused


def figure(w, h):
    """A matplotlib Figure on the Agg canvas (no pyplot state, no display)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(w, h))
    FigureCanvasAgg(fig)
    return fig


def few_ticks(fig, nbins=4):
    """At most ``nbins`` intervals between major ticks on every axis of ``fig``, and no
    tick made that is not drawn.

    Ticks are most of what drawing a small plot costs (each is three lines and two
    labels, made at the first draw): 4 intervals instead of matplotlib's 5 to 9 draws a
    six-panel figure about 30 % faster. matplotlib's locators also give a tick beyond
    each end of the axis, made, placed and labelled but not drawn (40 of run42's 103).
    """
    import numpy as np
    from matplotlib.ticker import MaxNLocator

    class ShownTicks(MaxNLocator):
        """MaxNLocator's ticks within the axis's view (all of them where fewer than two
        are: the labels' format is chosen from the ticks given)."""

        def __call__(self):
            locs = np.asarray(super().__call__())
            lo, hi = sorted(self.axis.get_view_interval())
            slack = 1e-10 * (hi - lo)      # as matplotlib decides which ticks to draw
            shown = locs[(locs >= lo - slack) & (locs <= hi + slack)]
            return shown if shown.size >= 2 else locs

    for ax in fig.axes:
        ax.xaxis.set_major_locator(ShownTicks(nbins))
        ax.yaxis.set_major_locator(ShownTicks(nbins))
    return fig


def png_bytes(fig, *, dpi=90):
    """The figure as PNG bytes, drawn once at ``dpi`` on the Agg canvas.

    Encoded by OpenCV, an opaque figure (every plot here) as 8-bit RGB: the pixels of
    ``savefig``'s RGBA without its alpha plane (all 255), at about the same size in a
    little over half the encoding time; a figure with transparent pixels as RGBA.
    """
    import cv2
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    own = fig.get_dpi()
    fig.set_dpi(dpi)
    try:
        # no bbox_inches="tight" (it draws twice): the figures place their axes
        canvas.draw()
        rgba = np.asarray(canvas.buffer_rgba())
        opaque = bool((rgba[..., 3] == 255).all())
        image = cv2.cvtColor(rgba, cv2.COLOR_RGBA2BGR if opaque else cv2.COLOR_RGBA2BGRA)
    finally:
        fig.set_dpi(own)
    return encode_png(image)


def encode_png(image):
    """An image as PNG bytes, at :data:`PNG_COMPRESS_LEVEL` with the "up" row filter.

    Parameters
    ----------
    image : numpy.ndarray
        8-bit grey, BGR or BGRA, as OpenCV holds it.

    Returns
    -------
    bytes
        The PNG file's bytes (lossless: decoded, the same pixels).
    """
    import cv2

    ok, data = cv2.imencode(".png", image, [cv2.IMWRITE_PNG_COMPRESSION, PNG_COMPRESS_LEVEL,
                                            cv2.IMWRITE_PNG_FILTER, cv2.IMWRITE_PNG_FILTER_UP])
    if not ok:                                   # pragma: no cover (OpenCV's own failure)
        raise RuntimeError("OpenCV could not encode the image as PNG")
    return data.tobytes()


def img(data, *, alt="plot"):
    """PNG bytes as an inline ``<img>``.

    Parameters
    ----------
    data : bytes
        A PNG file's bytes (:func:`encode_png`).
    alt : str
        The image's alternative text (escaped here).

    Returns
    -------
    str
        ``<img alt="..." src="data:image/png;base64,...">``.
    """
    text = base64.b64encode(data).decode("ascii")
    return f'<img alt="{esc(alt)}" src="data:image/png;base64,{text}">'


def png(fig, *, alt="plot"):
    """The figure as an inline ``<img>`` (base64 PNG)."""
    return img(png_bytes(fig), alt=alt)


def page(title, body_parts, *, subtitle=""):
    """A whole HTML page with the common style."""
    from vidtrack import __version__

    when = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    head = (f'<!DOCTYPE html><html><head><meta charset="utf-8"><title>{esc(title)}'
            f"</title><style>{CSS}</style></head><body><h1>{esc(title)}</h1>"
            f'<p class="muted">vidtrack {esc(__version__)}, {when}'
            f"{'; ' + subtitle if subtitle else ''}</p>")
    return head + "".join(body_parts) + "</body></html>\n"
