"""A run's report: report.md (text) and report.html (tables and plots) from its fit.

Plots: each view's track over frames (flagged frames marked), the fitted curve over the
measured points for each axis, and the residuals. Tables: k1..k4 with standard errors
and 95 % intervals (or why not determined), the initial state, residuals and timings.
"""

import numpy as np

from vidtrack.report import _html
from vidtrack._atomic import write_text

K_NAMES = ("k1", "k2", "k3", "k4")
AXES = ("x", "y", "z")


def _k_rows(record):
    rows = []
    for k in K_NAMES:
        c = record["coefficients"][k]
        if c["determined"]:
            ci = c["ci95"]
            rows.append((k, _html.num(c["value"], 5), _html.num(c["stderr"], 3),
                         f"{_html.num(ci[0], 5)} .. {_html.num(ci[1], 5)}" if ci else "",
                         c.get("reason", "")))
        else:
            rows.append((k, "not determined", "", "", c.get("reason", "")))
    return rows


def render_markdown(record):
    """report.md: the k table, the initial state, residuals, points and timings."""
    lines = [f"# vidtrack fit: {record['run']}", "",
             f"Model: {record['model']}, Cp = {record['cp_s_per_m']} s/m, "
             f"throws: {record['throws']}.", ""]
    if record.get("factors"):
        lines += ["Factors: " + ", ".join(f"{k} = {v}" for k, v in record["factors"].items()),
                  ""]
    lines += ["| coefficient | value | std. error | 95 % interval | note |",
              "| --- | --- | --- | --- | --- |"]
    lines += ["| " + " | ".join(r) + " |" for r in _k_rows(record)]
    lines += ["", "| initial state | value |", "| --- | --- |"]
    lines += [f"| {k} | {_html.num(v, 6)} |" for k, v in record["initial_state"].items()]
    lines += ["", "| axis | points | residual RMS (m) |", "| --- | --- | --- |"]
    lines += [f"| {a} | {record['points'][a]} | {_html.num(record['residual_rms_m'][a], 3)} |"
              for a in AXES]
    lines += ["", "Timings (s): " + ", ".join(f"{k} {v:.3g}"
                                              for k, v in record["timings_s"].items()), ""]
    for note in record.get("notes", []):
        lines.append(f"- {note}")
    return "\n".join(lines) + "\n"


def _track_plot(views):
    fig = _html.figure(10, 3.2 * max(len(views), 1))
    axs = np.atleast_1d(fig.subplots(max(len(views), 1), 1))
    for ax, (name, df) in zip(axs, views.items()):
        frame = np.asarray(df["frame"])
        bad = np.asarray(df["flags"]) != 0
        for col, colour in (("u_px", "tab:blue"), ("v_px", "tab:orange")):
            y = np.asarray(df[col])
            ax.plot(frame, y, ".", ms=2, color=colour, label=col)
            ax.plot(frame[bad], y[bad], "x", ms=4, color="red")
        ax.set_title(f"{name} view: straw centroid (red x: flagged, not fitted)")
        ax.set_xlabel("frame")
        ax.set_ylabel("pixels")
        ax.legend(fontsize=8)
    h = 3.2 * max(len(views), 1)
    # fixed margins: tight_layout draws the figure once more only to place the labels
    fig.subplots_adjust(left=0.07, right=0.99, top=1 - 0.3 / h, bottom=0.5 / h,
                        hspace=1.0 / 3.2)
    return _html.few_ticks(fig)


def fit_curves(world, fit):
    """What the fit plot needs of the fit: the fitted positions on a fine time grid
    (``tt``, ``pred``) and at the measured times (``pred_at``), as plain arrays."""
    t = np.asarray(world["t_s"])
    tt = np.linspace(np.nanmin(t), np.nanmax(t), 400)
    return {"tt": tt, "pred": fit.predict(tt), "pred_at": fit.predict(t)}


def _fit_plot(world, curves):
    """``world``: the world track's columns (a DataFrame or a dict of arrays)."""
    t = np.asarray(world["t_s"])
    tt, pred, pred_at = curves["tt"], curves["pred"], curves["pred_at"]
    fig = _html.figure(12, 6.4)
    axs = fig.subplots(2, 3, sharex=True)
    for i, axis in enumerate(AXES):
        obs = np.asarray(world[f"{axis}_m"])
        ok = np.isfinite(obs)
        top, bottom = axs[0, i], axs[1, i]
        if not ok.any():
            top.text(0.5, 0.5, f"{axis} not measured", ha="center", transform=top.transAxes)
            continue
        top.plot(t[ok], obs[ok], ".", ms=2, label="measured")
        if np.isfinite(pred[:, i]).any():
            top.plot(tt, pred[:, i], "-", lw=1.2, color="k", label="fitted")
            bottom.plot(t[ok], 1000 * (obs[ok] - pred_at[ok, i]), ".", ms=2)
        bottom.axhline(0, color="k", lw=0.8)
        top.set_title(f"{axis}(t)")
        top.set_ylabel(f"{axis} (m)")
        bottom.set_ylabel("residual (mm)")
        bottom.set_xlabel("t (s)")
        top.legend(fontsize=8)
    fig.subplots_adjust(left=0.07, right=0.99, top=0.95, bottom=0.08, wspace=0.32,
                        hspace=0.12)
    return _html.few_ticks(fig)


def tracks_image(views):
    """The tracks-over-frames plot as an inline ``<img>`` (``views``: {view: rows})."""
    return _html.png(_track_plot(views), alt="tracks")


def render_html(record, *, fit=None, world=None, views=None, tracks_img=None, curves=None):
    """report.html: the tables of report.md and the plots, self-contained.

    ``tracks_img``: the tracks plot already drawn (:func:`tracks_image`), else it is
    drawn from ``views``; ``curves``: :func:`fit_curves`, else computed from ``fit``.
    """
    parts = [f"<p>Model <b>{_html.esc(record['model'])}</b>, Cp = "
             f"{_html.num(record['cp_s_per_m'])} s/m, throws: {record['throws']}.</p>"]
    if record.get("factors"):
        parts.append("<p>Factors: " + ", ".join(
            f"{_html.esc(k)} = {_html.esc(v)}" for k, v in record["factors"].items()) + "</p>")
    parts.append("<h2>Coefficients</h2>")
    rows = [tuple(_html.esc(c) for c in r) for r in _k_rows(record)]
    parts.append(_html.table(("coefficient", "value", "std. error", "95 % interval", "note"),
                             rows, left=1))
    parts.append("<h2>Initial state and residuals</h2>")
    parts.append(_html.table(("quantity", "value"),
                             [(_html.esc(k), _html.num(v)) for k, v in
                              record["initial_state"].items()]))
    parts.append(_html.table(("axis", "points", "residual RMS (m)"),
                             [(a, record["points"][a], _html.num(record["residual_rms_m"][a], 3))
                              for a in AXES]))
    if curves is None and fit is not None and world is not None:
        curves = fit_curves(world, fit)
    if curves is not None and world is not None:
        parts += ["<h2>Fitted curves over the measured points</h2>",
                  _html.png(_fit_plot(world, curves), alt="fit")]
    if tracks_img is None and views:
        tracks_img = tracks_image(views)
    if tracks_img:
        parts += ["<h2>Tracks over frames</h2>", tracks_img]
    for note in record.get("notes", []):
        parts.append(f'<p class="note">{_html.esc(note)}</p>')
    parts.append("<p class=\"muted\">Timings (s): " + ", ".join(
        f"{_html.esc(k)} {v:.3g}" for k, v in record["timings_s"].items()) + "</p>")
    return _html.page(f"vidtrack fit: {record['run']}", parts)


def write_run_report(out_dir, record, *, fit=None, world=None, views=None, html=None):
    """Write report.md and report.html into ``out_dir`` (each atomically).

    ``html``: report.html's text when it was already drawn (by :func:`render_html` in
    another process).
    """
    write_text(out_dir / "report.md", render_markdown(record))
    if html is None:
        html = render_html(record, fit=fit, world=world, views=views)
    write_text(out_dir / "report.html", html)
