"""Fixed-effects ANOVA and range analysis of an orthogonal-array experiment.

What Hou et al. 2019 report for their L27(3^13) experiment (Tables 3 and 4): every
factor a categorical term, chosen two-factor interactions (tau0 x vm for the winding
response), each with SS, df, MS, F and p; the model, error and total rows; and the
range analysis of the classical Taguchi reading (level means, range R, order of
influence) with each term's percent contribution to the total sum of squares.

Example
-------
>>> from fits.orthogonal import fit_orthogonal                  # doctest: +SKIP
>>> from fits.rsm import read_table
>>> table = read_table("datasets/published/hou2019_table3_l27.csv")
>>> fit = fit_orthogonal(table, "winding",
...                      ["rho0_mm", "tau0_deg", "vm_kmh", "omega_rad_s"],
...                      interactions=[("tau0_deg", "vm_kmh")])
>>> round(fit.anova["tau0_deg:vm_kmh"].ss, 2)
1.11
"""

import itertools
import logging
from dataclasses import dataclass

import numpy as np

from fits.rsm._stats import (AnovaRow, anova_frame, f_row, least_squares, ratio,
                             studentized_external)
from fits.rsm._table import (label_column, numeric_column, require_columns, run_labels,
                             source_of)
from fits.rsm._terms import estimable_columns
from fits._text import HtmlSummary, Report, Table, fmt_f, fmt_num, fmt_p
from fits.errors import InputError

__all__ = ["OrthogonalFit", "RangeAnalysis", "fit_orthogonal", "parse_interaction"]

log = logging.getLogger(__name__)


def parse_interaction(text):
    """``"a:b"`` -> ``("a", "b")``; InputError for anything but two different names."""
    parts = [p.strip() for p in str(text).split(":")]
    if len(parts) != 2 or not all(parts) or parts[0] == parts[1]:
        raise InputError(f"interaction {text!r}: expected two different factor columns "
                         "joined by ':', e.g. tau0_deg:vm_kmh")
    return tuple(parts)


def _level_key(label):
    """Sort levels numerically when they are numbers, else as text."""
    try:
        return (0, float(label), label)
    except ValueError:
        return (1, 0.0, label)


def _effect_codes(labels, levels):
    """Sum-to-zero (effect) coding: a - 1 columns, the last level coded -1 in each."""
    idx = np.array([levels.index(v) for v in labels])
    a = len(levels)
    X = np.zeros((len(labels), a - 1))
    for j in range(a - 1):
        X[idx == j, j] = 1.0
        X[idx == a - 1, j] = -1.0
    return X


@dataclass(frozen=True)
class RangeAnalysis:
    """Range analysis of one factor: level means, range R = max - min, rank by R (1 = largest)."""

    factor: str
    levels: tuple
    level_means: dict
    level_counts: dict
    range: float
    rank: int

    def to_dict(self):
        """JSON-ready dict."""
        return {"levels": list(self.levels), "level_means": dict(self.level_means),
                "level_counts": dict(self.level_counts), "range": self.range,
                "rank": self.rank}


@dataclass(frozen=True, eq=False)
class OrthogonalFit(HtmlSummary):
    """Fixed-effects ANOVA of one response of an orthogonal (or any factorial) design.

    ``anova`` is keyed by the factor column names, interactions ``a:b``, and ``model``,
    ``error`` and ``total``. Term SS are partial (type III with sum-to-zero coding):
    for an orthogonal array they equal the classical between-level sums of squares.
    """

    response: str
    factors: tuple
    interactions: tuple
    alpha: float
    anova: dict
    range_analysis: dict
    order_of_influence: tuple
    order_by_range: tuple
    percent_contribution: dict
    r2: float
    adj_r2: float | None
    notes: tuple
    runs: tuple
    levels: dict
    factor_labels: dict
    observed: np.ndarray
    fitted: np.ndarray
    residuals: np.ndarray
    leverage: np.ndarray
    studentized: np.ndarray

    def __repr__(self):
        return (f"OrthogonalFit(response={self.response!r}, factors={len(self.factors)}, "
                f"interactions={len(self.interactions)}, r2={self.r2:.4g}, "
                f"n={len(self.observed)})")

    @property
    def term_names(self):
        """Factor and interaction names in table order."""
        return tuple(self.factors) + tuple(f"{a}:{b}" for a, b in self.interactions)

    def _anova_label(self, key):
        return key.capitalize() if key in ("model", "error", "total") else key

    @property
    def anova_table(self):
        """The ANOVA as a DataFrame, rows named and ordered as :meth:`summary` prints them.

        Returns
        -------
        pandas.DataFrame
            Index ``source``: the factor columns, the interactions ``a:b``, ``Model``,
            ``Error``, ``Total``; columns ``ss``, ``df``, ``ms``, ``f``, ``p`` in full
            precision (NaN where the printed table is blank) and ``ss_pct``, the percent
            contribution to the total sum of squares.
        """
        out = anova_frame(self.anova, {k: self._anova_label(k) for k in self.anova})
        pct = {self._anova_label(k): v for k, v in self.percent_contribution.items()}
        out["ss_pct"] = [pct.get(name, float("nan")) for name in out.index]
        return out

    @property
    def range_table(self):
        """The range analysis: one row per factor, ranked by the range R.

        Returns
        -------
        pandas.DataFrame
            Index ``factor`` in rank order; columns ``rank``, ``range`` (max - min of
            the level means, response units), ``ss_pct`` and ``levels`` (how many).
            The level means themselves are :attr:`level_means`.
        """
        import pandas as pd

        rows = [{"factor": n, "rank": self.range_analysis[n].rank,
                 "range": self.range_analysis[n].range,
                 "ss_pct": self.percent_contribution.get(n, float("nan")),
                 "levels": len(self.range_analysis[n].levels)} for n in self.order_by_range]
        return pd.DataFrame(rows).set_index("factor")

    @property
    def level_means(self):
        """Mean response at each level of each factor (the range analysis' means).

        Returns
        -------
        pandas.DataFrame
            MultiIndex ``(factor, level)`` in table order; columns ``mean`` (response
            units) and ``runs`` (runs at that level).
        """
        import pandas as pd

        rows = [{"factor": f, "level": lv, "mean": ra.level_means[lv],
                 "runs": ra.level_counts[lv]}
                for f in self.factors for ra in [self.range_analysis[f]] for lv in ra.levels]
        return pd.DataFrame(rows).set_index(["factor", "level"])

    def to_dict(self):
        """The JSON object of ``vidtrack anova --design orthogonal --json``."""
        anova = {k: (v.to_dict() if v is not None else None) for k, v in self.anova.items()}
        return {
            "response": self.response,
            "design": "orthogonal",
            "alpha": self.alpha,
            "factors": list(self.factors),
            "interactions": [f"{a}:{b}" for a, b in self.interactions],
            "anova": anova,
            "r2": self.r2,
            "adj_r2": self.adj_r2,
            "range_analysis": {k: v.to_dict() for k, v in self.range_analysis.items()},
            "order_of_influence": list(self.order_of_influence),
            "order_by_range": list(self.order_by_range),
            "percent_contribution": dict(self.percent_contribution),
            "n_runs": int(len(self.observed)),
            "notes": list(self.notes),
        }

    def summary(self):
        """A readable text report, like statsmodels' ``summary()``.

        What ``vidtrack anova --design orthogonal`` prints for a response: the ANOVA with
        significance marks (``*`` p <= alpha, ``**`` p < 0.01) and percent contribution,
        the range analysis ranked by R, the order of influence, R² and the notes.

        Returns
        -------
        str
        """
        return self._report().text()

    def _report(self):
        lines = [f"Response {self.response}: fixed-effects ANOVA, factors categorical"
                 + (", interactions " + ", ".join(f"{a}:{b}" for a, b in self.interactions)
                    if self.interactions else "")]
        rows = []
        for key, r in self.anova.items():
            if r is None:
                continue
            mark = ""
            if r.p is not None:
                mark = "**" if r.p < 0.01 else ("*" if r.p <= self.alpha else "")
            label = (self._anova_label(key) if key in ("model", "error", "total")
                     else "  " + key)
            pct = self.percent_contribution.get(key)
            rows.append([label, fmt_num(r.ss), r.df, fmt_num(r.ms), fmt_f(r.f), fmt_p(r.p),
                         mark, "" if pct is None else f"{pct:.2f}"])
        lines += ["", Table(["Source", "SS", "df", "MS", "F", "p", "", "% of SS"],
                            rows, align="lrrrrrlr")]
        rrows = []
        for name in self.order_by_range:
            ra = self.range_analysis[name]
            means = "  ".join(f"{lv}: {fmt_num(ra.level_means[lv], sig=4)}" for lv in ra.levels)
            rrows.append([ra.rank, name, means, fmt_num(ra.range, sig=4)])
        lines += ["", "Range analysis (ranked by range R):",
                  Table(["Rank", "Factor", "Level means", "R"], rrows, align="rllr"),
                  "Order of influence (by the ANOVA, as Hou 2019 states it): "
                  + " > ".join(self.order_of_influence)]
        lines += [f"R2 {fmt_num(self.r2, sig=4)}   adj R2 {fmt_num(self.adj_r2, sig=4) or 'n/a'}"]
        lines += [f"Note: {n}" for n in self.notes]
        return Report(lines)


def fit_orthogonal(table, response, factors, *, interactions=(), alpha=0.05):
    """Fixed-effects ANOVA with categorical factors and chosen interactions.

    Parameters
    ----------
    table : pandas.DataFrame
        One row per run; factor columns (any values: each distinct value is a level)
        and the numeric response column.
    response : str
        The response column.
    factors : sequence of str
        The factor columns, each treated as categorical.
    interactions : sequence of (str, str) or "a:b" strings
        Two-factor interactions to add (each must be between listed factors).
    alpha : float
        Significance level for the marks in the summary (``*`` p <= alpha, ``**``
        p < 0.01), in (0, 1).

    Returns
    -------
    OrthogonalFit

    Raises
    ------
    InputError
        Missing or non-numeric columns, a factor with one level, an interaction of an
        unknown factor, a term the design cannot separate from others (aliased), no
        runs left for the error, a constant response.

    Notes
    -----
    Hou et al. 2019, Table 4 (Design-Expert 6): term SS are the partial (type III) sums
    of squares with sum-to-zero coding, equal to the classical level-mean SS
    ``n_l sum (mean_l - mean)^2`` for a balanced array; F = MS / MS_error. Range
    analysis: mean response at each level, R = max - min, rank 1 for the largest R (ties
    keep the column order). The order of influence is the one the paper states, from
    the ANOVA: by mean square (F, for equal df), ties broken by R, then column order;
    ``order_by_range`` is the classical range ranking (they differ for Hou's vibration
    response, where R of tau0 and omega are 55.2 and 55.7 but their SS 17972 and 13967).
    Percent contribution: ``100 SS_term / SS_total``.
    """
    if not isinstance(alpha, (int, float)) or not 0.0 < alpha < 1.0:
        raise InputError(f"alpha must be between 0 and 1, got {alpha!r}")
    factors = tuple(factors)
    if not factors:
        raise InputError("no factors given: list the factor columns (--categorical)")
    dupes = sorted({f for f in factors if factors.count(f) > 1})
    if dupes:
        raise InputError(f"factor {dupes[0]!r} is given twice")
    if response in factors:
        raise InputError(f"response {response!r} is also a factor")
    pairs = []
    for it in interactions:
        a, b = parse_interaction(it) if isinstance(it, str) else tuple(it)
        for x in (a, b):
            if x not in factors:
                raise InputError(f"interaction {a}:{b}: {x!r} is not one of the factors "
                                 f"({', '.join(factors)})")
        if (a, b) in pairs or (b, a) in pairs:
            raise InputError(f"interaction {a}:{b} is given twice")
        pairs.append((a, b))
    require_columns(table, list(factors), what="factor column")
    require_columns(table, [response], what="response column")
    y = numeric_column(table, response)
    n = len(y)
    sst = float(np.sum((y - y.mean()) ** 2))
    if sst <= 1e-28 * max(1.0, float(np.max(np.abs(y))) ** 2):
        raise InputError(f"{source_of(table)}: response {response!r} is constant "
                         f"({y[0]:g} in every run): there is nothing to analyse")
    labels = {f: label_column(table, f) for f in factors}
    levels = {}
    for f in factors:
        levels[f] = sorted(set(labels[f]), key=_level_key)
        if len(levels[f]) < 2:
            raise InputError(f"{source_of(table)}: factor {f!r} has a single level "
                             f"({levels[f][0]}): it cannot have an effect")
    blocks = {f: _effect_codes(labels[f], levels[f]) for f in factors}
    for a, b in pairs:
        blocks[f"{a}:{b}"] = np.column_stack([blocks[a][:, i] * blocks[b][:, j]
                                              for i, j in itertools.product(
                                                  range(blocks[a].shape[1]),
                                                  range(blocks[b].shape[1]))])
    names = list(blocks)
    X = np.column_stack([np.ones(n)] + [blocks[k] for k in names])
    col_owner = ["Intercept"] + [k for k in names for _ in range(blocks[k].shape[1])]
    n_terms = X.shape[1]
    if n <= n_terms:
        raise InputError(f"{source_of(table)}: fewer runs than terms: {n} runs for "
                         f"{n_terms} model parameters (intercept, {', '.join(names)}); "
                         "nothing is left to estimate the error")
    keep, aliased = estimable_columns(X, col_owner)
    if len(keep) < n_terms:
        bad = [col_owner[j] for j in range(n_terms) if j not in keep]
        raise InputError(f"{source_of(table)}: term {bad[0]!r} cannot be separated from "
                         "the other terms in this design (its columns are aliased): leave "
                         "it out")
    full = least_squares(X, y)
    mse = full.mse
    notes = []
    anova = {}
    start = 1
    for k in names:
        width = blocks[k].shape[1]
        cols = [c for c in range(n_terms) if not start <= c < start + width]
        reduced = least_squares(X[:, cols], y)
        anova[k] = f_row(max(reduced.sse - full.sse, 0.0), width, mse, full.df_resid)
        start += width
    ssm = float(np.sum((full.fitted - y.mean()) ** 2))
    anova["model"] = f_row(ssm, n_terms - 1, mse, full.df_resid)
    anova["error"] = AnovaRow(ss=full.sse, df=full.df_resid, ms=mse)
    anova["total"] = AnovaRow(ss=sst, df=n - 1)
    if mse is not None and mse <= 1e-28 * sst:
        notes.append("the model fits every run exactly: error mean square is zero, F and "
                     "p are not defined")
    term_ss = sum(anova[k].ss for k in names)
    if abs(term_ss - ssm) > 1e-9 * sst:
        notes.append(f"the design is not orthogonal for these terms: the term sums of "
                     f"squares (partial, type III) add up to {term_ss:.6g}, not to the "
                     f"model's {ssm:.6g}")

    # range analysis of the factors
    ranges = {}
    for f in factors:
        lab = np.array(labels[f])
        means = {lv: float(y[lab == lv].mean()) for lv in levels[f]}
        counts = {lv: int(np.sum(lab == lv)) for lv in levels[f]}
        ranges[f] = (means, counts, max(means.values()) - min(means.values()))
    by_range = sorted(factors, key=lambda f: (-ranges[f][2], factors.index(f)))
    order = sorted(factors, key=lambda f: (-(anova[f].ms or 0.0), -ranges[f][2],
                                           factors.index(f)))
    range_analysis = {f: RangeAnalysis(factor=f, levels=tuple(levels[f]),
                                       level_means=ranges[f][0], level_counts=ranges[f][1],
                                       range=float(ranges[f][2]), rank=by_range.index(f) + 1)
                      for f in factors}
    if any(len(set(r[1].values())) > 1 for r in ranges.values()):
        notes.append("levels are not equally replicated: range analysis compares means of "
                     "unequal numbers of runs")
    pct = {k: 100.0 * anova[k].ss / sst for k in names}
    pct["error"] = 100.0 * full.sse / sst
    for note in notes:
        log.info("%s: %s", response, note)
    r2 = ssm / sst
    adj = ratio(full.sse, full.df_resid)
    adj_r2 = 1.0 - adj / (sst / (n - 1)) if adj is not None else None
    return OrthogonalFit(
        response=response, factors=factors, interactions=tuple(pairs), alpha=float(alpha),
        anova=anova, range_analysis=range_analysis, order_of_influence=tuple(order),
        order_by_range=tuple(by_range),
        percent_contribution=pct, r2=float(r2), adj_r2=adj_r2, notes=tuple(notes),
        runs=tuple(run_labels(table)), levels={f: tuple(levels[f]) for f in factors},
        factor_labels={f: tuple(labels[f]) for f in factors}, observed=y,
        fitted=full.fitted, residuals=full.residuals, leverage=full.leverage,
        studentized=studentized_external(full.residuals, full.leverage, mse, full.df_resid))

