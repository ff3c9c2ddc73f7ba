"""vidtrack.report._html's inline plots against matplotlib's own PNG of the same figure."""

import io

import cv2
import numpy as np
import pytest

from vidtrack.report import _html


def _savefig_rgba(fig, dpi):
    """The figure as matplotlib's savefig writes it, decoded (RGBA)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    rgba = cv2.imdecode(np.frombuffer(buf.getvalue(), np.uint8), cv2.IMREAD_UNCHANGED)
    return cv2.cvtColor(rgba, cv2.COLOR_BGRA2RGBA)


def _plot(transparent=False):
    fig = _html.figure(4, 3)
    ax = fig.subplots()
    ax.plot(np.linspace(0, 1, 50), np.linspace(0, 1, 50) ** 2, ".", ms=2, label="measured")
    ax.set_title("y(t)", y=_html.TITLE_Y)
    ax.legend()
    if transparent:
        fig.patch.set_alpha(0.0)
    return _html.few_ticks(fig)


@pytest.mark.parametrize("dpi", [90, 72])
def test_an_opaque_plot_is_savefigs_pixels_as_rgb(dpi):
    data = _html.png_bytes(_plot(), dpi=dpi)
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    reference = _savefig_rgba(_plot(), dpi)
    assert image.ndim == 3 and image.shape[2] == 3            # RGB: no alpha plane
    assert (reference[..., 3] == 255).all()
    assert np.array_equal(cv2.cvtColor(image, cv2.COLOR_BGR2RGB), reference[..., :3])


def test_a_transparent_plot_keeps_its_alpha_and_the_figure_its_dpi():
    fig = _plot(transparent=True)
    dpi = fig.get_dpi()
    data = _html.png_bytes(fig, dpi=90)
    assert fig.get_dpi() == dpi
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    reference = _savefig_rgba(_plot(transparent=True), 90)
    assert image.shape[2] == 4 and (reference[..., 3] < 255).any()
    assert np.array_equal(cv2.cvtColor(image, cv2.COLOR_BGRA2RGBA), reference)


def test_few_ticks_makes_only_the_drawn_ticks_and_the_same_pixels():
    from matplotlib.ticker import MaxNLocator

    plain = _plot()
    for ax in plain.axes:
        ax.xaxis.set_major_locator(MaxNLocator(4))
        ax.yaxis.set_major_locator(MaxNLocator(4))
    fig = _plot()
    assert _html.png_bytes(fig) == _html.png_bytes(plain)
    for axis in (fig.axes[0].xaxis, fig.axes[0].yaxis):
        lo, hi = sorted(axis.get_view_interval())
        locs = axis.get_majorticklocs()
        assert len(locs) >= 2 and ((locs >= lo) & (locs <= hi)).all()
        assert len(axis.majorTicks) == len(locs)
    assert sum(len(a.majorTicks) for a in (plain.axes[0].xaxis, plain.axes[0].yaxis)) > \
        sum(len(a.majorTicks) for a in (fig.axes[0].xaxis, fig.axes[0].yaxis))


@pytest.mark.parametrize("enabled", [True, False])
def test_without_gc_pauses_the_collector_and_restores_it(enabled):
    import gc

    seen = []

    @_html.without_gc
    def draw(fail=False):
        seen.append(gc.isenabled())
        if fail:
            raise ValueError("drawing failed")
        return "page"

    was = gc.isenabled()
    try:
        (gc.enable if enabled else gc.disable)()
        assert draw() == "page"
        with pytest.raises(ValueError):
            draw(fail=True)
        assert seen == [False, False] and gc.isenabled() == enabled
    finally:
        (gc.enable if was else gc.disable)()
