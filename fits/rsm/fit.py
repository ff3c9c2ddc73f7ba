"""Response-surface analysis of a central composite (or any quantitative) design.

What Design-Expert does for Chen et al. 2018, Tables 1-3 and eqs. 20-23, in the open:
coding of factors (Table 1: coded = (natural - centre) / step), the full second-order
model, backward elimination at a chosen alpha (hierarchy kept by default), the ANOVA
with regression, residual, lack of fit (distinct design points), pure error
(replicates) and total, R^2, adjusted and predicted R^2, adequate precision, condition
numbers, coefficients in coded and natural units, and the canonical analysis. This
module fits; the result it returns, :class:`~fits.rsm.results.RsmFit`, with its tables,
JSON and summaries, is ``fits.rsm.results``.

The natural-unit coefficients are the exact binomial expansion of the coded
polynomial, never a refit in natural units: for the full quadratic model of Table 2 the
natural-unit design matrix has a condition number of 1.8e7
(``RsmFit.condition_number_natural``), the coded one 3.0.

Example
-------
>>> from fits.rsm import Factor, fit_rsm, read_table            # doctest: +SKIP
>>> table = read_table("datasets/published/chen2018_table2_ccd.csv")
>>> factors = [Factor.parse("A=n_rpm:550:100"), Factor.parse("B=blade_angle_deg:0:5"),
...            Factor.parse("C=speed_kmh:7.2:1.8")]
>>> fit = fit_rsm(table, "k1", factors)
>>> fit.terms
('A', 'B', 'C', 'A:B', 'A^2')
"""

import logging
import math
import numbers
import re
import warnings
from dataclasses import dataclass

import numpy as np

from fits.rsm._stats import (AnovaRow, canonical_analysis, f_row, least_squares, pure_error,
                             ratio, replicate_groups, studentized_external, term_pvalues)
from fits.rsm._table import numeric_column, require_columns, run_labels, source_of
from fits.rsm._terms import (INTERCEPT, estimable_columns, model_matrix,
                             natural_expansion, parse_term, protected_by_hierarchy,
                             second_order_terms, sorted_terms, term_name)
from fits.rsm.results import EliminationStep, RsmFit, TermTest
from fits.errors import InputError

__all__ = ["AliasedTermWarning", "Factor", "code_factors", "default_factors", "fit_rsm"]

_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_.]*$")

log = logging.getLogger(__name__)


class AliasedTermWarning(UserWarning):
    """A model term cannot be estimated from the design and was left out."""


@dataclass(frozen=True)
class Factor:
    """A quantitative factor and its coding: ``coded = (natural - centre) / step``.

    Parameters
    ----------
    letter : str
        Coded name used in term names (``A``).
    name : str
        Natural name, the table's column in natural units (``n_rpm``).
    centre, step : float
        Natural value at coded 0, and natural change per coded unit (step != 0).
    """

    letter: str
    name: str
    centre: float = 0.0
    step: float = 1.0

    def __post_init__(self):
        for what, v in (("letter", self.letter), ("name", self.name)):
            if not isinstance(v, str) or not _NAME_RE.match(v):
                raise InputError(f"factor {what} must be a name of letters, digits and "
                                 f"'_' (no ':' or '^'), got {v!r}")
        for what, v in (("centre", self.centre), ("step", self.step)):
            if not isinstance(v, numbers.Real) or not math.isfinite(v):
                raise InputError(f"factor {self.letter}: {what} must be a finite number, "
                                 f"got {v!r}")
        if self.step == 0:
            raise InputError(f"factor {self.letter}={self.name}: step must not be 0")
        object.__setattr__(self, "centre", float(self.centre))
        object.__setattr__(self, "step", float(self.step))

    @classmethod
    def parse(cls, text):
        """A factor from ``LETTER=NAME:CENTRE:STEP``, e.g. ``A=n_rpm:550:100``."""
        letter, eq, rest = str(text).partition("=")
        parts = rest.split(":")
        if not eq or len(parts) != 3:
            raise InputError(f"factor {text!r}: expected LETTER=NAME:CENTRE:STEP, "
                             "e.g. A=n_rpm:550:100")
        name, centre, step = (p.strip() for p in parts)
        try:
            c, s = float(centre), float(step)
        except ValueError:
            raise InputError(f"factor {text!r}: centre and step must be numbers, got "
                             f"{centre!r} and {step!r}") from None
        return cls(letter.strip(), name, c, s)

    def code(self, natural):
        """Coded value(s) of natural value(s)."""
        return (np.asarray(natural, dtype=float) - self.centre) / self.step

    def decode(self, coded):
        """Natural value(s) of coded value(s)."""
        return np.asarray(coded, dtype=float) * self.step + self.centre

    def to_dict(self):
        """``{"name": ..., "centre": ..., "step": ...}`` (the letter is the key outside)."""
        return {"name": self.name, "centre": self.centre, "step": self.step}


def _check_factors(factors):
    factors = tuple(factors)
    if not factors:
        raise InputError("no factors given: a response-surface model needs at least one")
    for f in factors:
        if not isinstance(f, Factor):
            raise InputError(f"factors must be fits.rsm.Factor, got {type(f).__name__}")
    for attr in ("letter", "name"):
        seen = [getattr(f, attr) for f in factors]
        dupes = sorted({s for s in seen if seen.count(s) > 1})
        if dupes:
            raise InputError(f"factor {attr} {dupes[0]!r} is given twice")
    letters = {f.letter for f in factors}
    for f in factors:
        if f.name in letters and f.name != f.letter:
            raise InputError(f"factor name {f.name!r} is also the letter of another factor")
    return factors


def code_factors(table, factors):
    """Coded factor values of every run, shape (n, k).

    Each factor is read from its natural column (``factor.name``) and coded; if the
    table has only the coded column (``factor.letter``) that is used as is. If both are
    there they must agree (to 1e-6 coded units).

    Raises
    ------
    InputError
        A factor column is missing, a value is not a number, or the two columns disagree.
    """
    factors = _check_factors(factors)
    cols = []
    for f in factors:
        has_nat = f.name in table.columns
        has_code = f.letter in table.columns and f.letter != f.name
        if not has_nat and not has_code:
            require_columns(table, [f.name], what=f"column for factor {f.letter}")
        if has_nat:
            coded = f.code(numeric_column(table, f.name))
            if has_code:
                given = numeric_column(table, f.letter)
                bad = np.flatnonzero(np.abs(given - coded) > 1e-6)
                if bad.size:
                    i = int(bad[0])
                    raise InputError(
                        f"{source_of(table)}: row {i + 1}, column {f.letter!r} is "
                        f"{given[i]:g} but ({f.name} - {f.centre:g}) / {f.step:g} = "
                        f"{coded[i]:g}: the coded and natural columns disagree")
        else:
            coded = numeric_column(table, f.letter)
        cols.append(coded)
    return np.column_stack(cols)


def _resolve_terms(terms, factors):
    letters = [f.letter for f in factors]
    if terms is None:
        return second_order_terms(len(factors))
    exps = []
    for t in terms:
        e = parse_term(t, letters) if isinstance(t, str) else tuple(int(v) for v in t)
        if len(e) != len(factors) or any(v < 0 for v in e):
            raise InputError(f"term {t!r} does not fit the {len(factors)} factors")
        if sum(e) > 0:
            exps.append(e)
    if not exps:
        raise InputError("the model has no terms besides the intercept")
    return sorted_terms(exps)


def _select(coded, y, terms, *, alpha, eliminate, hierarchy, letters):
    """Backward elimination: drop the least significant removable term while p > alpha."""
    terms = list(terms)
    steps = []
    while eliminate and terms:
        X = model_matrix(coded, terms)
        p = term_pvalues(least_squares(X, y))[1:]
        candidates = [(pv, i) for i, pv in enumerate(p)
                      if not (hierarchy and protected_by_hierarchy(terms[i], terms))]
        if not candidates:
            break
        pv, i = max(candidates, key=lambda c: (c[0], c[1]))
        if not pv > alpha:
            break
        steps.append(EliminationStep(term=term_name(terms[i], letters), p=float(pv)))
        log.debug("eliminated %s (p = %.4g > alpha %g)", steps[-1].term, pv, alpha)
        del terms[i]
    return terms, tuple(steps)


def fit_rsm(table, response, factors, *, terms=None, alpha=0.05, eliminate=True,
            hierarchy=True, on_aliased="drop"):
    """Response-surface regression of one response with its full ANOVA.

    Parameters
    ----------
    table : pandas.DataFrame
        One row per run; factor columns in natural units (``factor.name``) or coded
        (``factor.letter``); the response column. Values may be numbers or text
        (as :func:`read_table` gives them).
    response : str
        The response column (``"k1"``).
    factors : sequence of Factor
        The factors in order A, B, C, ...
    terms : sequence of str, optional
        Candidate terms in coded names (``"A"``, ``"A:B"``, ``"A^2"``); default the full
        second-order model.
    alpha : float
        Significance level of the backward elimination (alpha-out), in (0, 1).
    eliminate : bool
        False keeps every candidate term (``--full``).
    hierarchy : bool
        Keep a term while a higher-order term containing it stays (A stays with A:B or
        A^2), as Design-Expert does by default.
    on_aliased : {"drop", "error"}
        A candidate term the design cannot separate from earlier terms: leave it out
        with an :class:`AliasedTermWarning` (and a note), or raise InputError.

    Returns
    -------
    RsmFit

    Raises
    ------
    InputError
        Missing or non-numeric columns, a constant response, fewer runs than terms,
        an aliased term with ``on_aliased="error"``, a bad option.

    Notes
    -----
    Elimination (Design-Expert's backward method): fit, take the removable term with
    the largest partial-F p-value; if it exceeds ``alpha`` drop it and refit; repeat.
    Lack of fit uses the distinct design points (15 in Chen 2018 Table 2) and pure
    error the replicates (the 18 centre runs): ``SS_lof = SS_res - SS_pe``,
    ``df_lof = m - p``. Predicted R^2 = 1 - PRESS / SS_total with PRESS the sum of
    squared leave-one-out residuals ``e_i / (1 - h_ii)``; adequate precision =
    (max yhat - min yhat) / sqrt(p MS_res / n). Condition numbers are the ratio of the
    largest to the smallest singular value of the model matrix (coded and natural).
    Natural coefficients: exact binomial expansion of the coded polynomial (Chen 2018,
    Table 1 coding), see :func:`fits.rsm._terms.natural_expansion`.
    """
    if not isinstance(alpha, (int, float)) or not 0.0 < alpha < 1.0:
        raise InputError(f"alpha must be between 0 and 1, got {alpha!r}")
    if on_aliased not in ("drop", "error"):
        raise InputError(f"on_aliased must be 'drop' or 'error', got {on_aliased!r}")
    factors = _check_factors(factors)
    if response in {f.name for f in factors} | {f.letter for f in factors}:
        raise InputError(f"response {response!r} is also a factor")
    require_columns(table, [response], what="response column")
    coded = code_factors(table, factors)
    y = numeric_column(table, response)
    n = len(y)
    letters = [f.letter for f in factors]
    sst = float(np.sum((y - y.mean()) ** 2))
    if sst <= 1e-28 * max(1.0, float(np.max(np.abs(y))) ** 2):
        raise InputError(f"{source_of(table)}: response {response!r} is constant "
                         f"({y[0]:g} in every run): there is nothing to analyse")
    candidates = _resolve_terms(terms, factors)
    names = [INTERCEPT] + [term_name(t, letters) for t in candidates]
    keep, aliased = estimable_columns(model_matrix(coded, candidates), names)
    n_est = len(keep)
    if n_est == 1:
        raise InputError(f"{source_of(table)}: none of the model terms can be estimated: "
                         f"the factor columns ({', '.join(f.name for f in factors)}) do not "
                         "vary over the runs")
    if n <= n_est:
        raise InputError(
            f"{source_of(table)}: fewer runs than terms: {n} runs for a model of "
            f"{len(names)} terms ({', '.join(names)}); a fit with a residual needs "
            f"more runs than estimable terms ({n_est})")
    notes = []
    if aliased:
        desc = "; ".join(
            f"{a} = " + (" + ".join(f"{c:.4g}*{o}" for o, c in combo) if combo else "0")
            for a, combo in aliased.items())
        msg = (f"response {response!r}: term(s) {', '.join(aliased)} cannot be estimated "
               f"from this design (aliased: {desc})")
        if on_aliased == "error":
            raise InputError(msg)
        warnings.warn(msg + "; left out of the model", AliasedTermWarning, stacklevel=2)
        notes.append(msg + "; left out of the model")
        candidates = [candidates[j - 1] for j in keep[1:]]

    final, steps = _select(coded, y, candidates, alpha=alpha, eliminate=eliminate,
                           hierarchy=hierarchy, letters=letters)
    exps = [(0,) * len(factors)] + list(final)
    X = model_matrix(coded, final)
    fit = least_squares(X, y)
    p = X.shape[1]
    term_names = [term_name(t, letters) for t in exps]

    # ANOVA: regression, residual, lack of fit / pure error, total
    ssr = float(np.sum((fit.fitted - y.mean()) ** 2)) if p > 1 else 0.0
    mse = fit.mse
    anova = {"regression": f_row(ssr, p - 1, mse, fit.df_resid)}
    if p == 1:
        anova["regression"] = AnovaRow(ss=ssr, df=0)
        notes.append(f"no term is significant at alpha {alpha:g}: the model is the mean "
                     "alone")
    anova["residual"] = AnovaRow(ss=fit.sse, df=fit.df_resid, ms=mse)
    groups, m = replicate_groups(coded)
    ss_pe, df_pe = pure_error(y, groups)
    if df_pe == 0:
        anova["lack_of_fit"] = None
        anova["pure_error"] = None
        notes.append("no replicated design points: there is no pure error, so lack of "
                     "fit cannot be tested (row left out)")
    else:
        ms_pe = ratio(ss_pe, df_pe)
        df_lof = m - p
        ss_lof = max(fit.sse - ss_pe, 0.0)
        if df_lof <= 0:
            anova["lack_of_fit"] = None
            notes.append(f"the model has as many terms as distinct design points ({m}): "
                         "lack of fit cannot be tested (row left out)")
        else:
            anova["lack_of_fit"] = f_row(ss_lof, df_lof, ms_pe, df_pe)
        anova["pure_error"] = AnovaRow(ss=ss_pe, df=df_pe, ms=ms_pe)
        if ms_pe is not None and ms_pe <= 0.0:
            notes.append("the replicates agree exactly: pure error is zero and F for lack "
                         "of fit is not defined")
    anova["total"] = AnovaRow(ss=sst, df=n - 1)
    if mse is not None and mse <= 1e-28 * sst:
        notes.append("the model fits every run exactly: residual mean square is zero, F "
                     "and p are not defined")

    # term tests, fit statistics
    pvals = term_pvalues(fit)
    se = np.sqrt(np.maximum(np.diag(fit.cov), 0.0))
    tests = []
    for j in range(1, p):
        ss_j = float(fit.params[j] ** 2 / fit.xtx_inv[j, j])
        f_j = ratio(ss_j, mse)
        tests.append(TermTest(term=term_names[j], coefficient=float(fit.params[j]),
                              stderr=float(se[j]), ss=ss_j, f=f_j,
                              p=float(pvals[j]) if f_j is not None else None))
    r2 = ssr / sst
    adj_r2 = 1.0 - (fit.sse / fit.df_resid) / (sst / (n - 1))
    if np.any(fit.leverage >= 1.0 - 1e-10):
        press = None
        pred_r2 = None
        notes.append("a run has leverage 1: PRESS and predicted R2 are not defined")
    else:
        press = float(np.sum((fit.residuals / (1.0 - fit.leverage)) ** 2))
        pred_r2 = 1.0 - press / sst
    avg_var = ratio(p * (mse or 0.0), n)
    spread = float(np.max(fit.fitted) - np.min(fit.fitted))
    adeq = ratio(spread, math.sqrt(avg_var)) if avg_var else None
    std_dev = math.sqrt(mse) if mse is not None else None
    mean = float(y.mean())
    cv = 100.0 * std_dev / abs(mean) if std_dev is not None and mean != 0.0 else None

    # natural units: exact expansion, covariance by the same linear map
    centres = [f.centre for f in factors]
    steps_ = [f.step for f in factors]
    nat_exps, T = natural_expansion(exps, centres, steps_)
    names_nat = [term_name(t, [f.name for f in factors]) for t in nat_exps]
    beta_nat = T @ fit.params
    cov_nat = T @ fit.cov @ T.T
    natural = np.column_stack([f.decode(coded[:, i]) for i, f in enumerate(factors)])
    cond_nat = float(np.linalg.cond(model_matrix(natural, nat_exps[1:])))
    extent = np.max(np.abs(coded), axis=0)
    canon = canonical_analysis(exps, fit.params, factors, extent)

    log.debug("%s: model terms %s; R2 %.4g", response, ", ".join(term_names[1:]), r2)
    for note in notes:
        log.info("%s: %s", response, note)
    return RsmFit(
        response=response, factors=factors, alpha=float(alpha),
        selection="backward" if eliminate else "full", hierarchy=bool(hierarchy),
        terms=tuple(term_names[1:]),
        coefficients_coded={nm: float(b) for nm, b in zip(term_names, fit.params)},
        stderr_coded={nm: float(s) for nm, s in zip(term_names, se)},
        coefficients_natural={nm: float(b) for nm, b in zip(names_nat, beta_nat)},
        covariance_coded=fit.cov, covariance_natural=cov_nat, anova=anova,
        term_tests=tuple(tests), r2=float(r2), adj_r2=float(adj_r2), pred_r2=pred_r2,
        press=press, adeq_precision=adeq, std_dev=std_dev, mean=mean, cv_pct=cv,
        condition_number=float(np.linalg.cond(X)), condition_number_natural=cond_nat,
        design_range_natural={f.name: (float(natural[:, i].min()), float(natural[:, i].max()))
                              for i, f in enumerate(factors)},
        steps=steps, aliased_terms=tuple(aliased), canonical=canon, notes=tuple(notes),
        runs=tuple(run_labels(table)), coded_points=coded, observed=y,
        fitted=fit.fitted, residuals=fit.residuals, leverage=fit.leverage,
        studentized=studentized_external(fit.residuals, fit.leverage, mse, fit.df_resid),
        _exponents=tuple(exps))


def default_factors(table):
    """Factors from coded columns ``A``, ``B``, ``C``, ... when no coding is given.

    Every single-capital-letter column is taken as a coded factor with centre 0 and
    step 1 (natural units = coded units, named by the letter); they must run from ``A``
    without a gap.

    Raises
    ------
    InputError
        The table has no column ``A``, or a letter is missing (``A`` and ``C`` but no
        ``B``).
    """
    letters = sorted(c for c in table.columns if len(c) == 1 and "A" <= c <= "Z")
    if not letters:
        raise InputError(f"{source_of(table)}: no factors: give --factor LETTER=COLUMN:"
                         "CENTRE:STEP for each factor (the table has no coded columns A, "
                         "B, ...)")
    for i, letter in enumerate(letters):
        expected = chr(ord("A") + i)
        if letter != expected:
            raise InputError(f"{source_of(table)}: no column for factor {expected} (coded "
                             f"columns found: {', '.join(letters)}); give --factor for "
                             "each factor")
    return [Factor(letter, letter, 0.0, 1.0) for letter in letters]
