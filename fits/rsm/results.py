"""The result of a response-surface analysis: :class:`RsmFit` and its presentation.

``fit_rsm`` (``fits.rsm.fit``) returns an :class:`RsmFit`: the model's terms and
coefficients (coded and natural units), the ANOVA, the term tests (:class:`TermTest`)
and elimination steps (:class:`EliminationStep`), the fit statistics and the canonical
analysis; with the tables as pandas objects (``anova_table``, ``coef_table``, ...),
predictions and confidence bands, the JSON object of ``vidtrack anova --json``
(``to_dict``) and the text and HTML summaries.
"""

from dataclasses import dataclass, field

import numpy as np

from fits.rsm._stats import CanonicalAnalysis, anova_frame
from fits.rsm._terms import INTERCEPT, model_matrix
from fits._text import HtmlSummary, Report, Table, fmt_f, fmt_num, fmt_p
from fits.errors import InputError

__all__ = ["EliminationStep", "RsmFit", "TermTest"]

#: The ANOVA rows in printed order and their names in the printed table.
ANOVA_ROWS = {"regression": "Regression", "residual": "Residual",
              "lack_of_fit": "Lack of fit", "pure_error": "Pure error", "total": "Total"}


@dataclass(frozen=True)
class TermTest:
    """A model term's coefficient (coded units) and its partial F test."""

    term: str
    coefficient: float
    stderr: float
    ss: float
    f: float | None
    p: float | None

    def to_dict(self):
        """JSON-ready dict."""
        return {"term": self.term, "coefficient": self.coefficient, "stderr": self.stderr,
                "ss": self.ss, "df": 1, "f": self.f, "p": self.p}


@dataclass(frozen=True)
class EliminationStep:
    """One backward-elimination step: the term dropped and its p-value when dropped."""

    term: str
    p: float

    def to_dict(self):
        """JSON-ready dict."""
        return {"term": self.term, "p": self.p}


@dataclass(frozen=True, eq=False)
class RsmFit(HtmlSummary):
    """The response-surface analysis of one response (see :func:`fit_rsm`).

    ``anova`` has the rows ``regression``, ``residual``, ``lack_of_fit``,
    ``pure_error`` and ``total`` (lack of fit and pure error are None when the design
    has no replicated points; lack of fit alone is None when the model uses every
    distinct point). Coefficient dicts are keyed by term name: coded
    ``Intercept, A, A:B, A^2``; natural ``Intercept, n_rpm, n_rpm:blade_angle_deg,
    n_rpm^2``. ``covariance_natural`` is ``T C T'`` with ``T`` the exact expansion map
    and ``C`` the coded covariance.
    """

    response: str
    factors: tuple
    alpha: float
    selection: str                  # "backward" or "full"
    hierarchy: bool
    terms: tuple                    # coded names, no intercept
    coefficients_coded: dict
    stderr_coded: dict
    coefficients_natural: dict
    covariance_coded: np.ndarray
    covariance_natural: np.ndarray
    anova: dict
    term_tests: tuple
    r2: float
    adj_r2: float
    pred_r2: float | None
    press: float | None
    adeq_precision: float | None
    std_dev: float | None
    mean: float
    cv_pct: float | None
    condition_number: float
    condition_number_natural: float
    design_range_natural: dict
    steps: tuple
    aliased_terms: tuple
    canonical: CanonicalAnalysis
    notes: tuple
    runs: tuple
    coded_points: np.ndarray
    observed: np.ndarray
    fitted: np.ndarray
    residuals: np.ndarray
    leverage: np.ndarray
    studentized: np.ndarray
    _exponents: tuple = field(repr=False, default=())

    def __repr__(self):
        return (f"RsmFit(response={self.response!r}, terms={len(self.terms)}, "
                f"r2={self.r2:.4g}, adj_r2={self.adj_r2:.4g}, n={len(self.observed)})")

    @property
    def residual_ms(self):
        """The residual mean square (None with zero residual degrees of freedom)."""
        return self.anova["residual"].ms

    # ------------------------------------------------------------ tables (pandas)

    @property
    def anova_table(self):
        """The ANOVA as a DataFrame, rows named and ordered as :meth:`summary` prints them.

        Returns
        -------
        pandas.DataFrame
            Index ``source``: ``Regression``, ``Residual``, ``Lack of fit``, ``Pure
            error``, ``Total`` (a row the design cannot give is left out, as printed);
            columns ``ss``, ``df``, ``ms``, ``f``, ``p`` in full precision (NaN where the
            printed table is blank).
        """
        return anova_frame(self.anova, ANOVA_ROWS)

    @property
    def params(self):
        """Coefficients in coded units as a Series (``Intercept``, ``A``, ``A:B``, ...)."""
        import pandas as pd

        s = pd.Series(self.coefficients_coded, name="coefficient", dtype=float)
        s.index.name = "term"
        return s

    @property
    def bse(self):
        """Standard errors of the coded coefficients as a Series."""
        import pandas as pd

        s = pd.Series(self.stderr_coded, name="stderr", dtype=float)
        s.index.name = "term"
        return s

    @property
    def pvalues(self):
        """Partial-F p-values of the coded terms as a Series (NaN for the intercept)."""
        import pandas as pd

        p = {t.term: (np.nan if t.p is None else t.p) for t in self.term_tests}
        s = pd.Series({n: p.get(n, np.nan) for n in self.coefficients_coded}, name="p",
                      dtype=float)
        s.index.name = "term"
        return s

    def _t_quantile(self, alpha):
        import scipy.special

        if not isinstance(alpha, (int, float)) or not 0.0 < alpha < 1.0:
            raise InputError(f"alpha must be between 0 and 1, got {alpha!r}")
        df = self.anova["residual"].df
        return float(scipy.special.stdtrit(df, 1.0 - alpha / 2.0)) if df > 0 else np.nan

    def conf_int(self, alpha=0.05, *, natural=False):
        """Confidence intervals of the coefficients: ``b ± t(1 - alpha/2, df_res) se``.

        Parameters
        ----------
        alpha : float, default 0.05
            1 - the confidence level.
        natural : bool, keyword-only
            The natural-unit coefficients (from the expanded covariance) instead of the
            coded ones.

        Returns
        -------
        pandas.DataFrame
            Indexed by term; columns ``lower`` and ``upper``.
        """
        import pandas as pd

        t = self._t_quantile(alpha)
        if natural:
            names = list(self.coefficients_natural)
            b = np.array([self.coefficients_natural[n] for n in names])
            se = np.sqrt(np.maximum(np.diag(self.covariance_natural), 0.0))
        else:
            names = list(self.coefficients_coded)
            b = np.array([self.coefficients_coded[n] for n in names])
            se = np.array([self.stderr_coded[n] for n in names])
        out = pd.DataFrame({"lower": b - t * se, "upper": b + t * se}, index=names)
        out.index.name = "term"
        return out

    @property
    def coef_table(self):
        """The coded coefficients with their tests, as the summary's term table.

        Returns
        -------
        pandas.DataFrame
            Index ``term`` (``Intercept``, then the model terms in coded names); columns
            ``coefficient``, ``stderr``, ``ci95_low``, ``ci95_high``, ``ss``, ``f``, ``p``
            (the partial F test of each term, 1 degree of freedom; NaN for the
            intercept).
        """
        import pandas as pd

        ci = self.conf_int()
        tests = {t.term: t for t in self.term_tests}
        rows = []
        for name, b in self.coefficients_coded.items():
            t = tests.get(name)
            rows.append({"term": name, "coefficient": b, "stderr": self.stderr_coded[name],
                         "ci95_low": ci.loc[name, "lower"], "ci95_high": ci.loc[name, "upper"],
                         "ss": t.ss if t else np.nan,
                         "f": np.nan if t is None or t.f is None else t.f,
                         "p": np.nan if t is None or t.p is None else t.p})
        return pd.DataFrame(rows).set_index("term")

    @property
    def coef_table_natural(self):
        """The coefficients in natural units (exact expansion of the coded model).

        Returns
        -------
        pandas.DataFrame
            Index ``term`` in natural names (``Intercept``, ``n_rpm``,
            ``n_rpm:blade_angle_deg``, ``n_rpm^2``: each coefficient is in response
            units per product of its factors' units); columns ``coefficient``,
            ``stderr``, ``ci95_low``, ``ci95_high``.
        """
        import pandas as pd

        ci = self.conf_int(natural=True)
        se = np.sqrt(np.maximum(np.diag(self.covariance_natural), 0.0))
        out = pd.DataFrame({"coefficient": list(self.coefficients_natural.values()),
                            "stderr": se, "ci95_low": ci["lower"].to_numpy(),
                            "ci95_high": ci["upper"].to_numpy()},
                           index=list(self.coefficients_natural))
        out.index.name = "term"
        return out

    @property
    def natural_terms(self):
        """Natural term names in ``coefficients_natural`` order."""
        return tuple(self.coefficients_natural)

    def term_p(self, term):
        """p-value of a coded term of the final model (None for the intercept)."""
        for t in self.term_tests:
            if t.term == term:
                return t.p
        return None

    def predict_coded(self, coded):
        """Predicted response at coded points ``coded`` of shape (m, k)."""
        coded = np.atleast_2d(np.asarray(coded, dtype=float))
        X = model_matrix(coded, self._exponents[1:])
        b = np.array([self.coefficients_coded[n] for n in self.coefficients_coded])
        return X @ b

    def confidence_band(self, coded, *, level=0.95):
        """Predicted mean at coded points and the half-width of its confidence interval.

        Returns ``(yhat, half)``: ``half = t(level, df_res) sqrt(x' C x)`` with ``C`` the
        coded covariance (NaN without residual degrees of freedom).
        """
        import scipy.special

        coded = np.atleast_2d(np.asarray(coded, dtype=float))
        X = model_matrix(coded, self._exponents[1:])
        var = np.einsum("ij,jk,ik->i", X, self.covariance_coded, X)
        df = self.anova["residual"].df
        t = scipy.special.stdtrit(df, 0.5 + level / 2.0) if df > 0 else np.nan
        return self.predict_coded(coded), t * np.sqrt(np.maximum(var, 0.0))

    def predict(self, natural):
        """Predicted response at natural settings: a mapping of factor name to value(s)."""
        missing = [f.name for f in self.factors if f.name not in natural]
        if missing:
            raise InputError(f"predict: no value for factor {missing[0]!r}")
        coded = np.column_stack([np.atleast_1d(f.code(natural[f.name]))
                                 for f in self.factors])
        return self.predict_coded(coded)

    def to_dict(self):
        """The JSON object of ``vidtrack anova --json`` (docs/analysis.md: the fixed keys,
        then more)."""
        anova = {k: (v.to_dict() if v is not None else None) for k, v in self.anova.items()}
        return {
            "response": self.response,
            "design": "ccd",
            "alpha": self.alpha,
            "terms": list(self.terms),
            "coefficients_coded": dict(self.coefficients_coded),
            "coefficients_natural": dict(self.coefficients_natural),
            "anova": anova,
            "r2": self.r2,
            "adj_r2": self.adj_r2,
            "pred_r2": self.pred_r2,
            "adeq_precision": self.adeq_precision,
            "condition_number": self.condition_number,
            "condition_number_natural": self.condition_number_natural,
            "factors": {f.letter: f.to_dict() for f in self.factors},
            "design_range_natural": {k: list(v) for k, v in self.design_range_natural.items()},
            "covariance_natural": {"terms": list(self.coefficients_natural),
                                   "matrix": self.covariance_natural.tolist()},
            "residual_ms": self.residual_ms,
            "stderr_coded": dict(self.stderr_coded),
            "term_tests": [t.to_dict() for t in self.term_tests],
            "selection": self.selection,
            "hierarchy": self.hierarchy,
            "elimination_steps": [s.to_dict() for s in self.steps],
            "aliased_terms": list(self.aliased_terms),
            "press": self.press,
            "std_dev": self.std_dev,
            "mean": self.mean,
            "cv_pct": self.cv_pct,
            "n_runs": int(len(self.observed)),
            "canonical": self.canonical.to_dict(),
            "notes": list(self.notes),
        }

    def equation_natural(self, *, sig=4):
        """The fitted model in natural units as text (like Chen 2018, eqs. 20-23)."""
        parts = []
        for name, c in self.coefficients_natural.items():
            num = f"{abs(c):.{sig}g}"
            term = num if name == INTERCEPT else f"{num}*{name.replace(':', '*')}"
            if not parts:
                parts.append(f"-{term}" if c < 0 else term)
            else:
                parts.append(f"{'-' if c < 0 else '+'} {term}")
        return f"{self.response} = " + " ".join(parts)

    def summary(self):
        """A readable text report, like statsmodels' ``summary()``.

        What ``vidtrack anova`` prints for a response: the selection (elimination steps,
        aliased terms), the ANOVA (regression, residual, lack of fit, pure error, total)
        with F and p, the coded coefficients with their standard errors and partial F
        tests, R², adjusted and predicted R², adequate precision, the condition numbers,
        the model in natural units, the canonical analysis and the notes.

        Returns
        -------
        str
        """
        return self._report().text()

    def _report(self):
        how = ("full model (no elimination)" if self.selection == "full" else
               f"backward elimination at alpha {self.alpha:g}, hierarchy "
               f"{'kept' if self.hierarchy else 'not kept'}")
        lines = [f"Response {self.response}: response-surface analysis, {how}",
                 "Model terms: " + (", ".join(self.terms) or "(intercept only)")]
        if self.steps:
            lines.append("Eliminated: " + ", ".join(f"{s.term} (p={fmt_p(s.p)})"
                                                    for s in self.steps))
        if self.aliased_terms:
            lines.append("Aliased (not estimable, left out): " + ", ".join(self.aliased_terms))
        rows = []
        for key, label in ANOVA_ROWS.items():
            r = self.anova.get(key)
            if r is None:
                continue
            indent = "  " if key in ("lack_of_fit", "pure_error") else ""
            rows.append([indent + label, fmt_num(r.ss), r.df, fmt_num(r.ms), fmt_f(r.f),
                         fmt_p(r.p)])
        lines += ["", Table(["Source", "SS", "df", "MS", "F", "p"], rows)]
        trows = [[INTERCEPT, fmt_num(self.coefficients_coded[INTERCEPT]),
                  fmt_num(self.stderr_coded[INTERCEPT]), "", "", ""]]
        for t in self.term_tests:
            trows.append([t.term, fmt_num(t.coefficient), fmt_num(t.stderr), fmt_num(t.ss),
                          fmt_f(t.f), fmt_p(t.p)])
        lines += ["", Table(["Term (coded)", "Coefficient", "Std err", "SS", "F", "p"],
                            trows)]
        lines += ["", f"R2 {fmt_num(self.r2, sig=4)}   adj R2 {fmt_num(self.adj_r2, sig=4)}   "
                      f"pred R2 {fmt_num(self.pred_r2, sig=4) or 'n/a'}   "
                      f"adeq precision {fmt_num(self.adeq_precision, sig=4) or 'n/a'}",
                  f"std dev {fmt_num(self.std_dev, sig=4)}   mean {fmt_num(self.mean, sig=4)}   "
                  f"C.V. {fmt_num(self.cv_pct, sig=4) or 'n/a'} %   PRESS "
                  f"{fmt_num(self.press, sig=4) or 'n/a'}",
                  f"condition number: coded {fmt_num(self.condition_number, sig=4)}, natural "
                  f"units {fmt_num(self.condition_number_natural, sig=4)}",
                  "", "Natural units: " + self.equation_natural()]
        c = self.canonical
        if c.available:
            pt = ", ".join(f"{k}={fmt_num(v, sig=5)}" for k, v in
                           c.stationary_point_natural.items())
            lines.append(f"Canonical analysis: {c.nature} at {pt} (predicted "
                         f"{fmt_num(c.response_at_stationary, sig=5)}, "
                         f"{'inside' if c.within_design else 'outside'} the design); "
                         "eigenvalues " + ", ".join(fmt_num(v, sig=4) for v in c.eigenvalues))
        else:
            lines.append(f"Canonical analysis: {c.reason}"
                         + (("; eigenvalues " + ", ".join(fmt_num(v, sig=4)
                                                          for v in c.eigenvalues))
                            if c.eigenvalues else ""))
        lines += [f"Note: {n}" for n in self.notes]
        return Report(lines)
