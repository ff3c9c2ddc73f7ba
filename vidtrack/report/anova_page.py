"""The ANOVA report: one self-contained HTML file with the tables and the plots.

For a response-surface fit (:class:`fits.rsm.RsmFit`): the ANOVA (regression, residual,
lack of fit, pure error, total), the term tests, the coefficients in coded and natural
units, the fit statistics, one-factor (main-effects) plots, a contour and a surface plot
for every significant two-factor interaction, and residual diagnostics. For an
orthogonal-array fit (:class:`fits.orthogonal.OrthogonalFit`): the ANOVA, the range
analysis, main-effects plots of the level means like Hou et al. 2019, Fig. 10, an
interaction plot per interaction, and residual diagnostics. A comparison with a
published table (:class:`fits.compare.Comparison`) is shown beside each response.

Plots are drawn with matplotlib's Agg canvas (no display, no global pyplot state) and
embedded as base64 PNG; the file is written atomically.
"""

import numpy as np

from vidtrack.report import _html
from vidtrack._atomic import write_text

__all__ = ["render_anova_report", "write_anova_report"]

_esc = _html.esc
_num = _html.num
_table = _html.table
_png = _html.png
_figure = _html.figure


def _p(p):
    if p is None:
        return ""
    return "&lt;0.0001" if p < 1e-4 else f"{p:.4f}"


# ---------------------------------------------------------------- plots

def _residual_plots(fit, title):
    """Normal probability plot, residuals vs predicted and vs run, predicted vs actual."""
    import scipy.special

    fig = _figure(9.5, 7.0)
    axs = fig.subplots(2, 2)
    r = np.asarray(fit.studentized, dtype=float)
    ok = np.isfinite(r)
    label = "externally studentized residual"
    if not ok.any():
        r = np.asarray(fit.residuals, dtype=float)
        ok = np.isfinite(r)
        label = "residual"
    rs = np.sort(r[ok])
    n = rs.size
    q = scipy.special.ndtri((np.arange(1, n + 1) - 0.375) / (n + 0.25))
    ax = axs[0, 0]
    ax.plot(rs, q, "o", ms=4)
    if n > 1 and np.ptp(rs) > 0:
        slope, icept = np.polyfit(rs, q, 1)
        xx = np.array([rs[0], rs[-1]])
        ax.plot(xx, slope * xx + icept, "-", color="0.5", lw=1)
    ax.set_xlabel(label)
    ax.set_ylabel("normal quantile")
    ax.set_title("Normal plot of residuals")
    ax = axs[0, 1]
    ax.plot(fit.fitted[ok], r[ok], "o", ms=4)
    ax.axhline(0, color="0.5", lw=1)
    ax.set_xlabel("predicted")
    ax.set_ylabel(label)
    ax.set_title("Residuals vs predicted")
    ax = axs[1, 0]
    idx = np.arange(1, len(r) + 1)
    ax.plot(idx[ok], r[ok], "o-", ms=4, lw=0.6)
    ax.axhline(0, color="0.5", lw=1)
    ax.set_xlabel("run (table order)")
    ax.set_ylabel(label)
    ax.set_title("Residuals vs run")
    ax = axs[1, 1]
    ax.plot(fit.observed, fit.fitted, "o", ms=4)
    lo = float(min(np.min(fit.observed), np.min(fit.fitted)))
    hi = float(max(np.max(fit.observed), np.max(fit.fitted)))
    ax.plot([lo, hi], [lo, hi], "-", color="0.5", lw=1)
    ax.set_xlabel(f"actual {fit.response}")
    ax.set_ylabel(f"predicted {fit.response}")
    ax.set_title("Predicted vs actual")
    fig.suptitle(title)
    fig.tight_layout()
    return _png(fig)


def _rsm_main_effects(fit):
    k = len(fit.factors)
    fig = _figure(3.2 * k, 3.0)
    axs = np.atleast_1d(fig.subplots(1, k))
    pts = np.asarray(fit.coded_points)
    for i, (f, ax) in enumerate(zip(fit.factors, axs)):
        lo, hi = float(pts[:, i].min()), float(pts[:, i].max())
        xc = np.linspace(lo, hi, 81)
        coded = np.zeros((xc.size, k))
        coded[:, i] = xc
        yhat, half = fit.confidence_band(coded)
        xn = f.decode(xc)
        ax.plot(xn, yhat, "-", color="C0")
        ax.fill_between(xn, yhat - half, yhat + half, color="C0", alpha=0.15, lw=0)
        others = np.delete(np.arange(k), i)
        on_axis = np.all(np.abs(pts[:, others]) < 1e-9, axis=1) if others.size else \
            np.ones(len(pts), bool)
        ax.plot(f.decode(pts[on_axis, i]), fit.observed[on_axis], "o", ms=4, color="C1")
        ax.set_xlabel(f.name)
        ax.set_title(f"{f.letter}: {f.name}", fontsize=10)
        if i == 0:
            ax.set_ylabel(fit.response)
    fig.suptitle(f"{fit.response}: one-factor effects (others at centre; band: 95 % CI "
                 "of the mean; points: runs on that axis)", fontsize=10)
    fig.tight_layout()
    return _png(fig)


def _rsm_interaction(fit, term):
    letters = [f.letter for f in fit.factors]
    a, b = term.split(":")
    i, j = letters.index(a), letters.index(b)
    pts = np.asarray(fit.coded_points)
    k = len(fit.factors)
    xi = np.linspace(pts[:, i].min(), pts[:, i].max(), 41)
    xj = np.linspace(pts[:, j].min(), pts[:, j].max(), 41)
    gi, gj = np.meshgrid(xi, xj)
    coded = np.zeros((gi.size, k))
    coded[:, i] = gi.ravel()
    coded[:, j] = gj.ravel()
    z = fit.predict_coded(coded).reshape(gi.shape)
    fa, fb = fit.factors[i], fit.factors[j]
    ni, nj = fa.decode(gi), fb.decode(gj)
    fig = _figure(10.0, 4.2)
    ax = fig.add_subplot(1, 2, 1)
    cs = ax.contourf(ni, nj, z, levels=12, cmap="viridis")
    ax.contour(ni, nj, z, levels=12, colors="k", linewidths=0.4)
    fig.colorbar(cs, ax=ax, label=fit.response)
    ax.plot(fa.decode(pts[:, i]), fb.decode(pts[:, j]), "wo", ms=4, mec="k")
    ax.set_xlabel(fa.name)
    ax.set_ylabel(fb.name)
    ax.set_title(f"{fit.response}: contour of {term}", fontsize=10)
    ax3 = fig.add_subplot(1, 2, 2, projection="3d")
    ax3.plot_surface(ni, nj, z, cmap="viridis", linewidth=0, antialiased=True)
    ax3.set_xlabel(fa.name)
    ax3.set_ylabel(fb.name)
    ax3.set_zlabel(fit.response)
    ax3.set_title(f"{fit.response}: surface of {term}", fontsize=10)
    fig.suptitle("other factors at their centre", fontsize=9)
    fig.subplots_adjust(left=0.1, right=0.96, bottom=0.12, top=0.86, wspace=0.3)
    return _png(fig)


def _ortho_main_effects(fit):
    k = len(fit.factors)
    fig = _figure(3.0 * k, 3.0)
    axs = np.atleast_1d(fig.subplots(1, k, sharey=True))
    grand = float(np.mean(fit.observed))
    for ax, name in zip(axs, fit.factors):
        ra = fit.range_analysis[name]
        x = np.arange(len(ra.levels))
        ax.plot(x, [ra.level_means[lv] for lv in ra.levels], "o-", color="C0")
        ax.axhline(grand, ls="--", color="0.5", lw=1)
        ax.set_xticks(x)
        ax.set_xticklabels(ra.levels)
        ax.set_xlabel(name)
        ax.set_title(f"R = {ra.range:.4g}", fontsize=9)
    axs[0].set_ylabel(f"mean {fit.response}")
    fig.suptitle(f"{fit.response}: level means (dashed: grand mean)", fontsize=10)
    fig.tight_layout()
    return _png(fig)


def _ortho_interaction(fit, a, b):
    la, lb = np.array(fit.factor_labels[a]), np.array(fit.factor_labels[b])
    fig = _figure(5.0, 3.4)
    ax = fig.add_subplot(1, 1, 1)
    x = np.arange(len(fit.levels[a]))
    for lvb in fit.levels[b]:
        means = [float(np.mean(fit.observed[(la == lva) & (lb == lvb)]))
                 if np.any((la == lva) & (lb == lvb)) else np.nan for lva in fit.levels[a]]
        ax.plot(x, means, "o-", label=f"{b} = {lvb}")
    ax.set_xticks(x)
    ax.set_xticklabels(fit.levels[a])
    ax.set_xlabel(a)
    ax.set_ylabel(f"mean {fit.response}")
    ax.legend(fontsize=8)
    ax.set_title(f"{fit.response}: interaction {a} x {b}", fontsize=10)
    fig.tight_layout()
    return _png(fig)


# ---------------------------------------------------------------- sections

def _anova_rows(fit, order, labels):
    rows, cls = [], []
    for key in order:
        r = fit.anova.get(key)
        if r is None:
            continue
        rows.append([_esc(labels.get(key, key)), _num(r.ss), str(r.df), _num(r.ms),
                     "" if r.f is None else f"{r.f:.4g}", _p(r.p)])
        cls.append("sig" if r.p is not None and r.p <= fit.alpha else "")
    return _table(["Source", "SS", "df", "MS", "F", "p"], rows, classes=cls)


def _comparison_html(comparisons, response):
    parts = []
    for comp in comparisons:
        rows = comp.rows_for(response)
        if not rows:
            continue
        body = [[_esc(r.source), _esc(r.quantity), _esc(r.printed), _num(r.computed),
                 _num(r.difference, 3), _esc(r.status), f'<span class="note">{_esc(r.note)}</span>']
                for r in rows]
        cls = ["flag" if r.status != "match" else "" for r in rows]
        flagged = sum(r.status != "match" for r in rows)
        parts.append(f"<h3>Compared with <code>{_esc(comp.source)}</code></h3>"
                     f"<p>{len(rows)} printed numbers, {flagged} flagged.</p>"
                     + _table(["Source", "Qty", "Published", "Computed", "Difference",
                               "Status", "Note"], body, left=2, classes=cls))
    return "".join(parts)


def _rsm_section(fit, comparisons):
    h = [f"<h2>{_esc(fit.response)}: response surface</h2>"]
    how = ("full model" if fit.selection == "full" else
           f"backward elimination at alpha {fit.alpha:g}, hierarchy "
           f"{'kept' if fit.hierarchy else 'not kept'}")
    h.append(f"<p>Model: {_esc(', '.join(fit.terms) or 'intercept only')} ({_esc(how)}).")
    if fit.steps:
        h.append(" Eliminated in order: " + _esc(", ".join(
            f"{s.term} (p = {s.p:.4f})" for s in fit.steps)) + ".")
    h.append("</p>")
    labels = {"regression": "Regression", "residual": "Residual",
              "lack_of_fit": "Lack of fit", "pure_error": "Pure error", "total": "Total"}
    h.append(_anova_rows(fit, list(labels), labels))
    rows = [[_esc(t.term), _num(t.coefficient), _num(t.stderr), _num(t.ss),
             "" if t.f is None else f"{t.f:.4g}", _p(t.p)] for t in fit.term_tests]
    rows.insert(0, ["Intercept", _num(fit.coefficients_coded["Intercept"]),
                    _num(fit.stderr_coded["Intercept"]), "", "", ""])
    h.append("<h3>Coefficients (coded units) and partial F tests</h3>")
    h.append(_table(["Term", "Coefficient", "Std error", "SS", "F", "p"], rows))
    se_nat = np.sqrt(np.maximum(np.diag(fit.covariance_natural), 0.0))
    rows = [[_esc(k), _num(v, 7), _num(s, 4)]
            for (k, v), s in zip(fit.coefficients_natural.items(), se_nat)]
    h.append("<h3>Coefficients in natural units (exact expansion of the coded model)</h3>")
    h.append(_table(["Term", "Coefficient", "Std error"], rows))
    h.append(f"<p><code>{_esc(fit.equation_natural())}</code></p>")
    stats = [["R²", _num(fit.r2, 4)], ["Adjusted R²", _num(fit.adj_r2, 4)],
             ["Predicted R²", _num(fit.pred_r2, 4) or "n/a"],
             ["Adequate precision", _num(fit.adeq_precision, 4) or "n/a"],
             ["Std. dev.", _num(fit.std_dev, 4)], ["Mean", _num(fit.mean, 4)],
             ["C.V. %", _num(fit.cv_pct, 4) or "n/a"], ["PRESS", _num(fit.press, 4) or "n/a"],
             ["Condition number (coded)", _num(fit.condition_number, 4)],
             ["Condition number (natural units)", _num(fit.condition_number_natural, 4)]]
    h.append(_table(["Statistic", "Value"], stats))
    c = fit.canonical
    if c.available:
        pt = ", ".join(f"{k} = {v:.5g}" for k, v in c.stationary_point_natural.items())
        eig = ", ".join(f"{v:.4g}" for v in c.eigenvalues)
        where = "inside" if c.within_design else "outside"
        h.append(f"<p>Canonical analysis: a {_esc(c.nature)} at {_esc(pt)} (predicted "
                 f"{c.response_at_stationary:.5g}; {where} the design); eigenvalues "
                 f"{_esc(eig)}.</p>")
    else:
        h.append(f"<p>Canonical analysis: {_esc(c.reason)}.</p>")
    h += [f'<p class="note">Note: {_esc(n)}</p>' for n in fit.notes]
    h.append(_comparison_html(comparisons, fit.response))
    h.append("<h3>Effects</h3>")
    h.append(_rsm_main_effects(fit))
    for t in fit.term_tests:
        if ":" in t.term and t.p is not None and t.p <= fit.alpha:
            h.append(_rsm_interaction(fit, t.term))
    h.append("<h3>Residual diagnostics</h3>")
    h.append(_residual_plots(fit, f"{fit.response}: residual diagnostics"))
    return "".join(h)


def _ortho_section(fit, comparisons):
    h = [f"<h2>{_esc(fit.response)}: orthogonal-array ANOVA</h2>"]
    h.append(f"<p>Factors (categorical): {_esc(', '.join(fit.factors))}"
             + (f"; interactions: {_esc(', '.join(f'{a}:{b}' for a, b in fit.interactions))}"
                if fit.interactions else "") + ".</p>")
    order = list(fit.term_names) + ["model", "error", "total"]
    labels = {"model": "Model", "error": "Error", "total": "Total"}
    h.append(_anova_rows(fit, order, labels))
    rows = []
    for name in fit.order_by_range:
        ra = fit.range_analysis[name]
        rows.append([_esc(name), _esc("; ".join(f"{lv}: {ra.level_means[lv]:.4g}"
                                                 for lv in ra.levels)),
                     _num(ra.range, 4), str(ra.rank),
                     f"{fit.percent_contribution[name]:.2f}"])
    h.append("<h3>Range analysis</h3>")
    h.append(_table(["Factor", "Level means", "Range R", "Rank by R", "% of SS"], rows,
                    left=2))
    h.append(f"<p>Order of influence (by the ANOVA): "
             f"{_esc(' > '.join(fit.order_of_influence))}. R² = {fit.r2:.4g}, adjusted R² = "
             f"{_num(fit.adj_r2, 4) or 'n/a'}.</p>")
    h += [f'<p class="note">Note: {_esc(n)}</p>' for n in fit.notes]
    h.append(_comparison_html(comparisons, fit.response))
    h.append("<h3>Main effects</h3>")
    h.append(_ortho_main_effects(fit))
    for a, b in fit.interactions:
        h.append(_ortho_interaction(fit, a, b))
    h.append("<h3>Residual diagnostics</h3>")
    h.append(_residual_plots(fit, f"{fit.response}: residual diagnostics"))
    return "".join(h)


def render_anova_report(fits, *, comparisons=(), title=None, source=None):
    """The report as an HTML string (self-contained: images are inline PNG).

    Parameters
    ----------
    fits : sequence of fits.rsm.RsmFit or fits.orthogonal.OrthogonalFit
    comparisons : sequence of fits.compare.Comparison, optional
    title : str, optional
    source : str, optional
        The analysed table's name, shown in the header.
    """
    fits = list(fits)
    title = title or "ANOVA report" + (f": {source}" if source else "")
    subtitle = ((f"table <code>{_esc(source)}</code>; " if source else "")
                + f"responses: {_esc(', '.join(f.response for f in fits))}.")
    parts = []
    for comp in comparisons:
        parts += [f'<p class="note">{_esc(comp.source)}: {_esc(n)}</p>' for n in comp.notes]
    for fit in fits:
        if hasattr(fit, "coefficients_natural"):
            parts.append(_rsm_section(fit, comparisons))
        else:
            parts.append(_ortho_section(fit, comparisons))
    return _html.page(title, parts, subtitle=subtitle)


def write_anova_report(path, fits, *, comparisons=(), title=None, source=None):
    """Render the report and write it to ``path`` atomically (whole or not at all).

    Returns the path written.
    """
    text = render_anova_report(fits, comparisons=comparisons, title=title, source=source)
    write_text(path, text)
    return path
