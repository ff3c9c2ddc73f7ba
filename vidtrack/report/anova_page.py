"""The ANOVA report: one self-contained HTML file with the tables and the plots.

For a response-surface fit (:class:`fits.rsm.RsmFit`): the ANOVA (regression, residual,
lack of fit, pure error, total), the term tests, the coefficients in coded and natural
units, the fit statistics, one-factor (main-effects) plots, a contour and a surface plot
for every significant two-factor interaction, and residual diagnostics. For an
orthogonal-array fit (:class:`fits.orthogonal.OrthogonalFit`): the ANOVA, the range
analysis, main-effects plots of the level means like Hou et al. 2019, Fig. 10, an
interaction plot per interaction, and residual diagnostics. A comparison with a
published table (:class:`fits.compare.Comparison`) is shown beside each response.

An experiment's report (``vidtrack report``) opens with its runs (:class:`RunTable`): a
table like Chen et al. 2018, Table 2, of each run's settings and k's, the run's name a
link to its own report.html, and the frames flagged of those tracked per view.

Numbers are printed as the papers print them: three significant figures (the
coefficients in natural units four, as eqs. 20-23 give them), F ratios with two
decimals, p-values with four (``<0.0001`` below); anova.json and coefficients.csv keep
full precision.

Plots are drawn with matplotlib's Agg canvas (no display, no global pyplot state) and
embedded as base64 PNG; the file is written atomically.
"""

import textwrap
from dataclasses import dataclass

import numpy as np

from fits._text import fmt_f
from vidtrack.report import _html
from vidtrack._atomic import write_text

__all__ = ["render_anova_report", "write_anova_report", "RunTable", "SIG", "SIG_NATURAL"]

#: Significant figures of the numbers printed in the report's tables.
SIG = 3
#: Significant figures of the coefficients in natural units (Chen 2018, eqs. 20-23).
SIG_NATURAL = 4
_esc = _html.esc


def _num(x, sig=SIG):
    return _html.num(x, sig)


def _f(f):
    return "" if f is None else fmt_f(f)


@dataclass(frozen=True)
class RunTable:
    """An experiment's runs for its report: Chen 2018 Table 2 with links and flags.

    Attributes
    ----------
    table : pandas.DataFrame
        The coefficient table (:func:`vidtrack.experiment.coefficient_table`): ``run``,
        the coded factors, the factors in natural units, the responses.
    coded, natural, responses : tuple of str
        The column names of the coded factors (``A``), the natural ones (``n_rpm``) and
        the responses (``k1``), in the order shown.
    links : tuple of str or None
        Per row, the run's report.html relative to the experiment's report (None: the
        run has none; its name is shown without a link).
    flags : tuple of str
        Per row, the frames flagged of those tracked, per view (``front 44/372``).
    """

    table: object
    coded: tuple
    natural: tuple
    responses: tuple
    links: tuple
    flags: tuple


def _runs_section(runs):
    t = runs.table
    heads = (["Run"] + list(runs.coded) + list(runs.natural) + list(runs.responses)
             + ["Throws", "Flagged / tracked frames"])
    rows = []
    for i, (_, r) in enumerate(t.iterrows()):
        name = _esc(r["run"])
        link = runs.links[i]
        cell = f'<a href="{_esc(link)}">{name}</a>' if link else name
        row = [cell] + [_num(r[c]) for c in runs.coded] + [_num(r[c]) for c in runs.natural]
        row += [_num(r[k]) if np.isfinite(r[k]) else "n/d" for k in runs.responses]
        row += [_num(r["throws"]) if "throws" in t else "", _esc(runs.flags[i])]
        rows.append(row)
    return ("<h2>Runs</h2><p>Each run's settings (coded and natural) and its "
            "coefficients (the mean over its throws; n/d: not determined), as Chen et al. "
            "2018, Table 2; a run's name links to its own report. Flagged / tracked: per "
            "view, the frames not used in the fit (flagged or lost) of the frames tracked."
            "</p>" + _html.table(heads, rows, left=1))
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


def _suptitle(fig, text, fontsize=10):
    """A figure title wrapped to the figure's width (never clipped at its sides)."""
    chars = max(20, int(fig.get_figwidth() * 72 / (0.55 * fontsize)))
    return fig.suptitle(textwrap.fill(text, chars), fontsize=fontsize)


def _rsm_main_effects(fit):
    return _png(_rsm_main_effects_figure(fit))


def _rsm_main_effects_figure(fit):
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
    _suptitle(fig, f"{fit.response}: one-factor effects (others at centre; band: 95 % CI "
              "of the mean; points: runs on that axis)")
    fig.tight_layout()
    return fig


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
        ax.set_title(f"R = {_num(ra.range)}", fontsize=9)
    axs[0].set_ylabel(f"mean {fit.response}")
    _suptitle(fig, f"{fit.response}: level means (dashed: grand mean)")
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
                     _f(r.f), _p(r.p)])
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
             _f(t.f), _p(t.p)] for t in fit.term_tests]
    rows.insert(0, ["Intercept", _num(fit.coefficients_coded["Intercept"]),
                    _num(fit.stderr_coded["Intercept"]), "", "", ""])
    h.append("<h3>Coefficients (coded units) and partial F tests</h3>")
    h.append(_table(["Term", "Coefficient", "Std error", "SS", "F", "p"], rows))
    se_nat = np.sqrt(np.maximum(np.diag(fit.covariance_natural), 0.0))
    rows = [[_esc(k), _num(v, SIG_NATURAL), _num(s)]
            for (k, v), s in zip(fit.coefficients_natural.items(), se_nat)]
    h.append("<h3>Coefficients in natural units (exact expansion of the coded model)</h3>")
    h.append(_table(["Term", "Coefficient", "Std error"], rows))
    h.append(f"<p><code>{_esc(fit.equation_natural())}</code></p>")
    stats = [["R²", _num(fit.r2)], ["Adjusted R²", _num(fit.adj_r2)],
             ["Predicted R²", _num(fit.pred_r2) or "n/a"],
             ["Adequate precision", _num(fit.adeq_precision) or "n/a"],
             ["Std. dev.", _num(fit.std_dev)], ["Mean", _num(fit.mean)],
             ["C.V. %", _num(fit.cv_pct) or "n/a"], ["PRESS", _num(fit.press) or "n/a"],
             ["Condition number (coded)", _num(fit.condition_number)],
             ["Condition number (natural units)", _num(fit.condition_number_natural)]]
    h.append(_table(["Statistic", "Value"], stats))
    c = fit.canonical
    if c.available:
        pt = ", ".join(f"{k} = {_num(v)}" for k, v in c.stationary_point_natural.items())
        eig = ", ".join(_num(v) for v in c.eigenvalues)
        where = "inside" if c.within_design else "outside"
        h.append(f"<p>Canonical analysis: a {_esc(c.nature)} at {_esc(pt)} (predicted "
                 f"{_num(c.response_at_stationary)}; {where} the design); eigenvalues "
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
        rows.append([_esc(name), _esc("; ".join(f"{lv}: {_num(ra.level_means[lv])}"
                                                 for lv in ra.levels)),
                     _num(ra.range), str(ra.rank),
                     f"{fit.percent_contribution[name]:.2f}"])
    h.append("<h3>Range analysis</h3>")
    h.append(_table(["Factor", "Level means", "Range R", "Rank by R", "% of SS"], rows,
                    left=2))
    h.append(f"<p>Order of influence (by the ANOVA): "
             f"{_esc(' > '.join(fit.order_of_influence))}. R² = {_num(fit.r2)}, adjusted R² = "
             f"{_num(fit.adj_r2) or 'n/a'}.</p>")
    h += [f'<p class="note">Note: {_esc(n)}</p>' for n in fit.notes]
    h.append(_comparison_html(comparisons, fit.response))
    h.append("<h3>Main effects</h3>")
    h.append(_ortho_main_effects(fit))
    for a, b in fit.interactions:
        h.append(_ortho_interaction(fit, a, b))
    h.append("<h3>Residual diagnostics</h3>")
    h.append(_residual_plots(fit, f"{fit.response}: residual diagnostics"))
    return "".join(h)


def render_anova_report(fits, *, comparisons=(), title=None, source=None, runs=None):
    """The report as an HTML string (self-contained: images are inline PNG).

    Parameters
    ----------
    fits : sequence of fits.rsm.RsmFit or fits.orthogonal.OrthogonalFit
    comparisons : sequence of fits.compare.Comparison, optional
    title : str, optional
    source : str, optional
        The analysed table's name, shown in the header.
    runs : RunTable, optional
        An experiment's runs, shown first (``vidtrack report``).
    """
    fits = list(fits)
    title = title or "ANOVA report" + (f": {source}" if source else "")
    subtitle = ((f"table <code>{_esc(source)}</code>; " if source else "")
                + f"responses: {_esc(', '.join(f.response for f in fits))}.")
    parts = [] if runs is None else [_runs_section(runs)]
    for comp in comparisons:
        parts += [f'<p class="note">{_esc(comp.source)}: {_esc(n)}</p>' for n in comp.notes]
    for fit in fits:
        if hasattr(fit, "coefficients_natural"):
            parts.append(_rsm_section(fit, comparisons))
        else:
            parts.append(_ortho_section(fit, comparisons))
    return _html.page(title, parts, subtitle=subtitle)


def write_anova_report(path, fits, *, comparisons=(), title=None, source=None, runs=None):
    """Render the report (:func:`render_anova_report`) and write it to ``path``
    atomically (whole or not at all).

    Returns the path written.
    """
    text = render_anova_report(fits, comparisons=comparisons, title=title, source=source,
                               runs=runs)
    write_text(path, text)
    return path
