"""A run's report: report.md (text) and report.html (tables and plots) from its fit.

Plots: each view's track over frames (flagged frames marked), the fitted curve over the
measured points for each axis, and the residuals, in the world (mm) and in each view's
pixels. Tables: k1..k4 with standard errors and 95 % intervals (or why not determined),
the initial state, residuals (in metres per axis, in pixels per view) and timings.
"""

import numpy as np

from vidtrack.report import _html
from vidtrack._atomic import write_text

K_NAMES = ("k1", "k2", "k3", "k4")
AXES = ("x", "y", "z")


def _k_rows(record):
    # the same rows as ThrowFit.summary() (one formatting of the k table)
    from fits.lsq_results import coefficient_rows

    return coefficient_rows({k: record["coefficients"][k] for k in K_NAMES})


#: The calibration table's columns (report.md and report.html).
_CAL_HEAD = ("coefficient", "std. error (fit)", "std. error (scale)", "std. error (total)",
             "95 % interval (fit and scale)", "dk/d(ln s) per view")


def _calibration(record):
    """(rows, sentences) of the scales' part of k's error, or ([], []) without it."""
    from fits.lsq_results import CALIBRATION_NOTE, calibration_rows

    rows = calibration_rows({k: record["coefficients"][k] for k in K_NAMES})
    if not rows:
        return [], []
    views = (record.get("calibration") or {}).get("views", {})
    said = [f"{v}: scale uncertain by {100 * d['scale_rel_uncertainty']:.3g} % ({d['from']})"
            if d.get("scale_rel_uncertainty") is not None else
            f"{v}: scale taken as exact ({d['from']})" for v, d in views.items()]
    return rows, [CALIBRATION_NOTE + " The std. error and 95 % interval of the table above "
                  "are the fit's part only."] + said


#: The pixel residual table's columns (report.md and report.html).
_PX_HEAD = ("view", "points", "residual RMS u (px)", "residual RMS v (px)",
            "RMS distance (px)")


def _px_rows(px_residuals):
    """One row per view of :func:`vidtrack.report.trajectory.pixel_residuals`."""
    return [(name, r.points, _html.num(r.rms_u_px, 3), _html.num(r.rms_v_px, 3),
             _html.num(r.rms_px, 3)) for name, r in (px_residuals or {}).items()]


def render_markdown(record, *, px_residuals=None):
    """report.md: the k table, the initial state, residuals, points and timings.

    ``px_residuals``: each view's residuals in pixels
    (:func:`vidtrack.report.trajectory.pixel_residuals`), a table of their RMS under the
    world residuals'.
    """
    lines = [f"# vidtrack fit: {record['run']}", "",
             f"Model: {record['model']}, Cp = {record['cp_s_per_m']} s/m, "
             f"throws: {record['throws']}.", ""]
    if record.get("factors"):
        lines += ["Factors: " + ", ".join(f"{k} = {v}" for k, v in record["factors"].items()),
                  ""]
    lines += ["| coefficient | value | std. error | 95 % interval | note |",
              "| --- | --- | --- | --- | --- |"]
    lines += ["| " + " | ".join(r) + " |" for r in _k_rows(record)]
    cal_rows, cal_text = _calibration(record)
    if cal_rows:
        lines += ["", "Calibration (the views' scales):", ""]
        lines += ["| " + " | ".join(_CAL_HEAD) + " |", "|" + " --- |" * len(_CAL_HEAD)]
        lines += ["| " + " | ".join(r) + " |" for r in cal_rows]
        lines += [""] + [f"- {t}" for t in cal_text]
    lines += ["", "| initial state | value |", "| --- | --- |"]
    lines += [f"| {k} | {_html.num(v, 6)} |" for k, v in record["initial_state"].items()]
    lines += ["", "| axis | points | residual RMS (m) |", "| --- | --- | --- |"]
    lines += [f"| {a} | {record['points'][a]} | {_html.num(record['residual_rms_m'][a], 3)} |"
              for a in AXES]
    if px_residuals:
        lines += ["", "| " + " | ".join(_PX_HEAD) + " |", "|" + " --- |" * len(_PX_HEAD)]
        lines += ["| " + " | ".join(map(str, r)) + " |" for r in _px_rows(px_residuals)]
    lines += ["", "Timings (s): " + ", ".join(f"{k} {v:.3g}"
                                              for k, v in record["timings_s"].items()), ""]
    summary = record.get("world") or {}
    if "rotation" in summary:
        lines += [f"Calibrated cameras: median reprojection error "
                  f"{summary['median_reprojection_px']:.3g} px; {summary['flagged']} of "
                  f"{summary['rows']} frames flagged; throw frame X from "
                  f"{summary['forward_from']}.", ""]
    if (attitude := _attitude_text(summary)) is not None:
        lines += [f"Attitude: {attitude}", ""]
    for note in record.get("notes", []):
        lines.append(f"- {note}")
    if "views" in record:
        lines += ["", "The trajectory over a full frame of each view, the residuals in "
                  "pixels over time and the contact sheet (crops of the footage round the "
                  "straw, with the measured point, the fitted path and the flags) are in "
                  "report.html; "
                  "`vidtrack overlay RUN` draws the same on every frame."]
    return "\n".join(lines) + "\n"


def _attitude_text(summary):
    """One sentence on the straw's attitude (fit.json's ``world.attitude``), or None
    where the world track has none."""
    att = summary.get("attitude")
    if not att:
        return None
    text = (f"The straw's axis was measured on {att['rows_measured']} of {att['rows']} rows "
            "(world.csv axis_x, axis_y, axis_z; NaN where fewer than two views see it as "
            "a line)")
    if att["spin_rad_s_median"] is None:
        return text + "; its turn rate was not measured."
    lo, hi = att["spin_rad_s_quartiles"]
    return (text + f"; it turns at {att['spin_rad_s_median']:.4g} rad/s (median; quartiles "
            f"{lo:.4g} to {hi:.4g} rad/s; world.csv spin_rad_s): the tumbling the model "
            "lumps into k.")


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
        ax.set_title(f"{name} view: straw centroid (red x: flagged, not fitted)",
                     y=_html.TITLE_Y)
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
        top.set_title(f"{axis}(t)", y=_html.TITLE_Y)
        top.set_ylabel(f"{axis} (m)")
        bottom.set_ylabel("residual (mm)")
        bottom.set_xlabel("t (s)")
        top.legend(fontsize=8)
    fig.subplots_adjust(left=0.07, right=0.99, top=0.95, bottom=0.08, wspace=0.32,
                        hspace=0.12)
    return _html.few_ticks(fig)


def _px_residual_plot(px_residuals):
    """Each view's residuals in pixels (u and v) against the fit's time, one panel a
    view, their RMS in the title."""
    n = max(len(px_residuals), 1)
    h = 2.4 * n
    fig = _html.figure(10, h)
    # one time axis (the fit's t): tick labels only under the last panel
    axs = np.atleast_1d(fig.subplots(n, 1, sharex=True))
    for ax, (name, r) in zip(axs, px_residuals.items()):
        ax.plot(r.t_s, r.du_px, ".", ms=2, color="tab:blue", label="u")
        ax.plot(r.t_s, r.dv_px, ".", ms=2, color="tab:orange", label="v")
        ax.axhline(0, color="k", lw=0.8)
        # the colours named in the title: a legend costs a sixth of drawing the plot
        ax.set_title(f"{name} view: measured - fitted, u (blue) RMS "
                     f"{_html.num(r.rms_u_px, 3)} px, v (orange) RMS "
                     f"{_html.num(r.rms_v_px, 3)} px, {r.points} unflagged points",
                     y=_html.TITLE_Y)
        ax.set_ylabel("residual (px)")
    axs[-1].set_xlabel("t (s)")
    for ax in axs[:-1]:
        ax.tick_params(labelbottom=False)
    fig.subplots_adjust(left=0.08, right=0.99, top=1 - 0.3 / h, bottom=0.5 / h,
                        hspace=0.5 / 2.4)
    return _html.few_ticks(fig)


def _calibrated_rows(summary, world):
    """One row per view: frames triangulated, median reprojection error, clock."""
    rows = []
    for col in [c for c in world if str(c).startswith("reprojection_px_")]:
        name = col.removeprefix("reprojection_px_")
        err = np.asarray(world[col], dtype=float)
        seen = np.isfinite(err)
        med = float(np.median(err[seen])) if seen.any() else float("nan")
        rows.append((name, int(seen.sum()), _html.num(med, 3),
                     _html.num(1000 * summary["offsets_s"].get(name, 0.0), 4),
                     summary["sync"].get(name, "")))
    return rows


def _calibrated_plot(world):
    """Reprojection error per view over the frames, and the track seen from the side
    (x-y) and from above (x-z), flagged frames marked."""
    frame = np.asarray(world["frame"])
    bad = np.asarray(world["flags"]) != 0
    fig = _html.figure(12, 3.6)
    ax_err, ax_side, ax_plan = fig.subplots(1, 3)
    for col in [c for c in world if str(c).startswith("reprojection_px_")]:
        ax_err.plot(frame, np.asarray(world[col]), ".", ms=3,
                    label=str(col).removeprefix("reprojection_px_"))
    ax_err.set_title("reprojection error per view", y=_html.TITLE_Y)
    ax_err.set_xlabel("frame")
    ax_err.set_ylabel("px")
    ax_err.legend(fontsize=8)
    # world: a DataFrame, or its columns as a dict (drawn in the worker process)
    raw = (np.column_stack([np.asarray(world[c], dtype=float) for c in ("X_m", "Y_m", "Z_m")])
           if "X_m" in world else None)
    for ax, (a, b) in ((ax_side, ("x_m", "y_m")), (ax_plan, ("x_m", "z_m"))):
        u, v = np.asarray(world[a]), np.asarray(world[b])
        ax.plot(u, v, ".", ms=3)
        ax.set_xlabel(a.replace("_m", " (m)"))
        ax.set_ylabel(b.replace("_m", " (m)"))
        ax.set_aspect("equal", adjustable="datalim")
    if raw is not None and bad.any():
        ax_err.plot(frame[bad], np.zeros(int(bad.sum())), "x", color="red", ms=5)
    ax_side.set_title("throw frame, side (x, y)", y=_html.TITLE_Y)
    ax_plan.set_title("from above (x, z)", y=_html.TITLE_Y)
    fig.subplots_adjust(left=0.06, right=0.99, top=0.9, bottom=0.15, wspace=0.35)
    return _html.few_ticks(fig)


@_html.without_gc                 # also drawn alone, by the process that tracked a view
def tracks_image(views):
    """The tracks-over-frames plot as an inline ``<img>`` (``views``: {view: rows})."""
    return _html.png(_track_plot(views), alt="tracks")


#: Where the contact sheet goes in a page drawn without it (:func:`with_contact_sheet`).
CONTACT_SHEET_SLOT = "<!-- vidtrack:contact-sheet -->"


def with_contact_sheet(html, section):
    """report.html with the contact-sheet ``section`` in its place (a page drawn by
    :func:`render_html` without one, e.g. in the worker process)."""
    if CONTACT_SHEET_SLOT in html:
        return html.replace(CONTACT_SHEET_SLOT, section, 1)
    return html.replace("</body>", section + "</body>", 1)


@_html.without_gc
def render_html(record, *, fit=None, world=None, views=None, tracks_img=None, curves=None,
                contact_sheet=None, px_residuals=None):
    """report.html: the tables of report.md and the plots, self-contained.

    ``tracks_img``: the tracks plot already drawn (:func:`tracks_image`), else it is
    drawn from ``views``; ``curves``: :func:`fit_curves`, else computed from ``fit``;
    ``contact_sheet``: the sections drawn on the footage (:func:`vidtrack.report.
    trajectory.footage_html`: the trajectory over a full frame, the contact sheet; without
    it, a slot :func:`with_contact_sheet` fills); ``px_residuals``: each view's residuals
    in pixels (:func:`vidtrack.report.trajectory.pixel_residuals`), their table and plot.
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
    cal_rows, cal_text = _calibration(record)
    if cal_rows:
        parts.append("<h3>Calibration: the views' scales</h3>")
        parts.append(_html.table(_CAL_HEAD, [tuple(_html.esc(c) for c in r)
                                             for r in cal_rows], left=1))
        parts += [f"<p>{_html.esc(t)}</p>" for t in cal_text]
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
    if px_residuals:
        parts += ["<h2>Residuals in pixels</h2>",
                  "<p>Each view's unflagged measured points minus the fitted path put into "
                  "the view's pixels at the same frame (u: column, v: row).</p>",
                  _html.table(_PX_HEAD, [tuple(_html.esc(c) for c in r)
                                         for r in _px_rows(px_residuals)]),
                  _html.png(_px_residual_plot(px_residuals), alt="residuals in pixels")]
    summary = record.get("world") or {}
    if "rotation" in summary and world is not None and "frame" in world:
        parts.append("<h2>Calibrated cameras</h2>")
        med = _html.num(summary["median_reprojection_px"], 3)
        limit = _html.num(summary["flag_threshold_px"], 3)
        parts.append(f"<p>Median reprojection error {med} px over the views; "
                     f"{summary['flagged']} of {summary['rows']} frames flagged (an error "
                     f"beyond {limit} px) and not fitted. The throw's frame: Y up, X from "
                     f"{_html.esc(summary['forward_from'])}.</p>")
        parts.append(_html.table(("view", "frames", "median reprojection (px)",
                                  "clock offset (ms)", "how"),
                                 [tuple(_html.esc(c) for c in r)
                                  for r in _calibrated_rows(summary, world)]))
        parts.append(_html.table(("throw frame axis", "in the calibration's frame"),
                                 [(a, _html.esc(", ".join(f"{v:.4f}" for v in row)))
                                  for a, row in zip("XYZ", summary["rotation"])]))
        parts.append(_html.png(_calibrated_plot(world), alt="calibrated cameras"))
    if (attitude := _attitude_text(summary)) is not None:
        parts += ["<h2>Attitude</h2>", f"<p>{_html.esc(attitude)}</p>"]
    if tracks_img is None and views:
        tracks_img = tracks_image(views)
    if tracks_img:
        parts += ["<h2>Tracks over frames</h2>", tracks_img]
    if "views" in record:
        parts.append(contact_sheet if contact_sheet is not None else CONTACT_SHEET_SLOT)
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
