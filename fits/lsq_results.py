"""The result of a throw fit: :class:`ThrowFit`, its axes and coefficients, as tables and text.

:func:`fits.lsq.fit_throw` returns a :class:`ThrowFit`: k1..k4 as :class:`Coefficient`
(value, standard error and 95 % interval, or why not determined), the initial state and
one :class:`AxisFit` per axis (parameters, covariance, residuals, the error model). Here
too are their accessors (pandas tables, confidence intervals at any level, the fitted
curves), the text and HTML summaries, the dicts of fit.json, and
:func:`coefficient_rows`, the one formatting of the k table that the run report shares.
"""

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import special

from fits._text import HtmlSummary, Report, Table, fmt_num, fmt_pm
from fits.errmodel import ErrorModel
from fits.errors import InputError
from fits.throw import flight_drag, flight_y

__all__ = ["Coefficient", "AxisFit", "ThrowFit", "coefficient_rows", "calibration_rows",
           "CALIBRATION_NOTE"]

#: The normal quantile of a 95 % interval, for the calibration's (systematic) part.
_Z95 = float(special.ndtri(0.975))
#: The axis whose fit gives each coefficient.
K_AXIS = {"k1": "y", "k2": "y", "k3": "x", "k4": "z"}
_MODEL_NAMES = {"quadratic": "quadratic drag (Chen 2018)", "linear": "linear drag (Liao 2021)",
                "free": "drag-free (Hou 2019)"}


def with_total(c):
    """A coefficient's fit.json fields as docs/fit-outputs.md describes them: where the
    calibration's part is known, ``stderr`` and ``ci95`` are of fit and calibration
    together (``stderr_total``, ``ci95_total``), ``stderr_fit`` and ``ci95_fit`` the
    fit's own; ``c`` is changed and returned."""
    if c.get("stderr_total") is not None:
        c["ci95_fit"] = c["ci95"]
        c["stderr"] = c["stderr_total"]
        c["ci95"] = c["ci95_total"]
    return c


@dataclass(frozen=True)
class Coefficient:
    """One fitted coefficient: value, standard error and 95 % interval, or why not.

    ``stderr`` and ``ci95`` are the fit's own part (the scatter of the points; in
    :meth:`to_dict`, fit.json's fields, they become the total where the calibration's
    part is known, :func:`with_total`). When the calibration's part is known (:meth:`ThrowFit.with_calibration`), ``stderr_calibration``
    is the standard error that the views' scales carry into the coefficient (a
    systematic part, shared by every throw converted with the same scales), and
    ``scale_sensitivity`` gives per view dk / d(ln s): the change of k per relative change
    of that view's scale. :attr:`stderr_total` and :attr:`ci95_total` combine the two.
    """

    value: float | None
    stderr: float | None
    ci95: tuple | None
    determined: bool
    reason: str | None = None
    stderr_calibration: float | None = None
    scale_sensitivity: dict | None = None

    @classmethod
    def undetermined(cls, reason):
        return cls(None, None, None, False, reason)

    @property
    def stderr_total(self):
        """sqrt(stderr^2 + stderr_calibration^2), or None without the calibration's part."""
        if not self.determined or self.stderr is None or self.stderr_calibration is None:
            return None
        return math.hypot(self.stderr, self.stderr_calibration)

    @property
    def ci95_total(self):
        """The 95 % interval of fit and calibration together, or None without the latter.

        Each side of the fit's interval (t-quantile or bootstrap percentile) and 1.96
        calibration standard errors, added in quadrature:
        ``value -+ sqrt(half_side^2 + (1.96 stderr_calibration)^2)``.
        """
        if self.stderr_total is None or self.ci95 is None:
            return None
        cal = _Z95 * self.stderr_calibration
        lo, hi = self.ci95
        return (self.value - math.hypot(self.value - lo, cal),
                self.value + math.hypot(hi - self.value, cal))

    def to_dict(self):
        out = {"value": self.value, "stderr": self.stderr,
               "ci95": list(self.ci95) if self.ci95 is not None else None,
               "determined": self.determined}
        if self.reason:
            out["reason"] = self.reason
        if self.stderr_total is not None:
            out["stderr_fit"] = self.stderr
            out["stderr_calibration"] = self.stderr_calibration
            out["stderr_total"] = self.stderr_total
            out["ci95_total"] = list(self.ci95_total)
        if self.scale_sensitivity is not None:
            out["scale_sensitivity"] = dict(self.scale_sensitivity)
        return with_total(out)


@dataclass(frozen=True)
class AxisFit:
    """The fit of one axis: parameters, their covariance and the residuals."""

    axis: str
    names: tuple
    values: np.ndarray
    stderr: np.ndarray
    covariance: np.ndarray
    correlation: np.ndarray
    residual_rms_m: float
    n_points: int
    dof: int
    condition_number: float
    nfev: int
    rss: float
    ci95: np.ndarray
    autocorrelation: float = 0.0
    error_model: ErrorModel | None = None
    notes: tuple = ()

    def value(self, name):
        return float(self.values[self.names.index(name)])

    def __repr__(self):
        params = ", ".join(f"{n}={fmt_pm(float(v), float(s))}"
                           for n, v, s in zip(self.names, self.values, self.stderr))
        return (f"AxisFit(axis={self.axis!r}, {params}, n={self.n_points}, "
                f"rms={1000 * self.residual_rms_m:.3g} mm)")

    def to_dict(self):
        return {"axis": self.axis, "parameters": dict(zip(self.names, self.values.tolist())),
                "stderr": dict(zip(self.names, self.stderr.tolist())),
                "correlation": self.correlation.tolist(), "residual_rms_m": self.residual_rms_m,
                "points": self.n_points, "condition_number": self.condition_number,
                "residual_autocorrelation": self.autocorrelation,
                "error_model": self.error_model.to_dict() if self.error_model else None,
                "nfev": self.nfev, "notes": list(self.notes)}


@dataclass(frozen=True)
class ThrowFit(HtmlSummary):
    """The throw model fitted to a world track."""

    model: str
    cp_s_per_m: float
    g_m_s2: float
    v1_m_s: float
    coefficients: dict
    initial_state: dict
    axes: dict = field(default_factory=dict)

    def with_calibration(self, parts):
        """This fit with the calibration's part of each coefficient's error.

        Parameters
        ----------
        parts : dict of str to (float or None, dict)
            Per coefficient name: ``(stderr_calibration, scale_sensitivity)``, the
            standard error the views' scales carry into it and {view: dk / d(ln s)}.
            Coefficients not named, or not determined, are kept as they are.

        Returns
        -------
        ThrowFit
        """
        from dataclasses import replace

        coeffs = {}
        for k, c in self.coefficients.items():
            if c.determined and k in parts:
                sd, sens = parts[k]
                c = replace(c, stderr_calibration=None if sd is None else float(sd),
                            scale_sensitivity=dict(sens) if sens is not None else None)
            coeffs[k] = c
        return replace(self, coefficients=coeffs)

    def __repr__(self):
        ks = ", ".join(f"{k}={fmt_pm(c.value, c.stderr)}" for k, c in self.coefficients.items())
        pts = "/".join(str(self.points.get(a, 0)) for a in "xyz")
        return f"ThrowFit(model={self.model!r}, {ks}, points x/y/z={pts})"

    @property
    def residual_rms_m(self):
        return {a: (f.residual_rms_m if f else None) for a, f in self.axes.items()}

    @property
    def points(self):
        return {a: (f.n_points if f else 0) for a, f in self.axes.items()}

    def aic(self):
        """Akaike information criterion of the Gaussian fit, summed over the axes."""
        total = 0.0
        for f in self.axes.values():
            if f is not None and f.n_points > 0:
                n, p = f.n_points, len(f.names)
                total += n * np.log(max(f.rss, 1e-300) / n) + 2 * p
        return float(total)

    def predict(self, t):
        """Fitted x, y, z (m) at times ``t`` (s): NaN for an axis that was not fitted."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.full((t.size, 3), np.nan)
        for i, axis in enumerate("xyz"):
            f = self.axes.get(axis)
            if f is not None:
                out[:, i] = _axis_model(axis, f.names, f.values, self, t)
        return out

    # ------------------------------------------------------------ tables (pandas)

    @property
    def params(self):
        """The coefficients k1..k4 as a Series (NaN where not determined).

        Returns
        -------
        pandas.Series
            Indexed ``k1`` .. ``k4``, named ``value``; like statsmodels' ``params``.
        """
        import pandas as pd

        s = pd.Series({k: c.value if c.determined else np.nan
                       for k, c in self.coefficients.items()}, name="value", dtype=float)
        s.index.name = "coefficient"
        return s

    @property
    def bse(self):
        """Standard errors of k1..k4 as a Series (NaN where not determined).

        Returns
        -------
        pandas.Series
            Indexed ``k1`` .. ``k4``, named ``stderr``; like statsmodels' ``bse``.
        """
        import pandas as pd

        s = pd.Series({k: c.stderr if c.determined else np.nan
                       for k, c in self.coefficients.items()}, name="stderr", dtype=float)
        s.index.name = "coefficient"
        return s

    def conf_int(self, alpha=0.05):
        """Confidence intervals of k1..k4 (NaN where not determined).

        Parameters
        ----------
        alpha : float, default 0.05
            1 - the confidence level. The stored 95 % intervals are returned for 0.05;
            another level is computed as ``value ± t(1 - alpha/2, dof) stderr`` from the
            axis fit's degrees of freedom, which needs errors from the Jacobian (a
            bootstrap keeps only its 95 % percentile interval).

        Returns
        -------
        pandas.DataFrame
            Indexed ``k1`` .. ``k4``, columns ``lower`` and ``upper``.

        Raises
        ------
        fits.errors.InputError
            ``alpha`` not in (0, 1), or a level other than 95 % of a bootstrap fit.
        """
        import pandas as pd

        if not isinstance(alpha, (int, float)) or not 0.0 < alpha < 1.0:
            raise InputError(f"alpha must be between 0 and 1, got {alpha!r}")
        rows = {}
        for k, c in self.coefficients.items():
            if not c.determined:
                rows[k] = (np.nan, np.nan)
            elif math.isclose(alpha, 0.05):
                rows[k] = tuple(c.ci95)
            else:
                f = self.axes[K_AXIS[k]]
                if any(n.startswith("bootstrap") for n in f.notes):
                    raise InputError(f"{k}: the errors come from a bootstrap, which keeps "
                                     "only its 95 % interval (alpha=0.05)")
                tq = float(special.stdtrit(f.dof, 1.0 - alpha / 2.0))
                rows[k] = (c.value - tq * c.stderr, c.value + tq * c.stderr)
        out = pd.DataFrame.from_dict(rows, orient="index", columns=["lower", "upper"])
        out.index.name = "coefficient"
        return out

    @property
    def coef_table(self):
        """k1..k4 with their errors, 95 % intervals and why not determined.

        Returns
        -------
        pandas.DataFrame
            Indexed ``k1`` .. ``k4``; columns ``value``, ``stderr``, ``ci95_low``,
            ``ci95_high`` (NaN where not determined), ``determined`` (bool), ``axis``
            (the axis fit that gives it) and ``reason`` ('' when determined).
        """
        import pandas as pd

        rows = []
        for k, c in self.coefficients.items():
            lo, hi = c.ci95 if c.determined else (np.nan, np.nan)
            rows.append({"coefficient": k,
                         "value": c.value if c.determined else np.nan,
                         "stderr": c.stderr if c.determined else np.nan,
                         "ci95_low": lo, "ci95_high": hi, "determined": c.determined,
                         "axis": K_AXIS[k], "reason": c.reason or ""})
        return pd.DataFrame(rows).set_index("coefficient")

    @property
    def axes_table(self):
        """One row per axis: points, parameters, residuals and conditioning.

        Returns
        -------
        pandas.DataFrame
            Indexed ``x``, ``y``, ``z``; columns ``points``, ``parameters`` (their
            names), ``residual_rms_m``, ``rss_m2``, ``dof``, ``condition_number``,
            ``autocorrelation_lag1``, ``nfev`` (NaN for an axis that was not fitted).
        """
        import pandas as pd

        rows = []
        for a in "xyz":
            f = self.axes.get(a)
            if f is None:
                rows.append({"axis": a, "points": self.points.get(a, 0), "parameters": "",
                             "residual_rms_m": np.nan, "rss_m2": np.nan, "dof": np.nan,
                             "condition_number": np.nan, "autocorrelation_lag1": np.nan,
                             "nfev": np.nan})
            else:
                rows.append({"axis": a, "points": f.n_points, "parameters": ", ".join(f.names),
                             "residual_rms_m": f.residual_rms_m, "rss_m2": f.rss,
                             "dof": f.dof, "condition_number": f.condition_number,
                             "autocorrelation_lag1": f.autocorrelation, "nfev": f.nfev})
        return pd.DataFrame(rows).set_index("axis")

    # ------------------------------------------------------------ summaries

    def _report(self):
        pts = self.points
        head = (f"Throw fit: {_MODEL_NAMES.get(self.model, self.model)}, "
                f"Cp = {self.cp_s_per_m:g} s/m, g = {self.g_m_s2:g} m/s^2, "
                f"v1 = {self.v1_m_s:g} m/s")
        boot = any(n.startswith("bootstrap") for f in self.axes.values() if f
                   for n in f.notes)
        errors = ("Errors: residual bootstrap (percentile intervals)" if boot else
                  "Errors: from the Jacobian under the error model fitted to the residuals "
                  "(white + correlated, REML)")
        rows = []
        for a in "xyz":
            f = self.axes.get(a)
            if f is None:
                rows.append([a, pts.get(a, 0), "(not fitted)", "", "", ""])
            else:
                rows.append([a, f.n_points, ", ".join(f.names),
                             f"{1000 * f.residual_rms_m:.3g}", f"{f.condition_number:.3g}",
                             f"{f.autocorrelation:.2f}"])
        state = ", ".join(f"{k.split('_')[0]} {v:.5g} {'m/s' if k.endswith('_m_s') else 'm'}"
                          for k, v in self.initial_state.items() if v is not None)
        parts = [head, f"Points: x {pts.get('x', 0)}, y {pts.get('y', 0)}, "
                       f"z {pts.get('z', 0)}; AIC {self.aic():.6g}", errors, "",
                 Table(["Coefficient", "Value", "Std err", "95 % interval", "Note"],
                       coefficient_rows(self.coefficients), align="lrrrl"),
                 "",
                 Table(["Axis", "Points", "Parameters", "Residual RMS (mm)",
                        "Condition number", "Lag-1 autocorrelation"], rows, align="lrlrrr"),
                 "", "Initial state: " + (state or "(none)")]
        cal = calibration_rows(self.coefficients)
        if cal:
            parts += ["", CALIBRATION_NOTE,
                      Table(["Coefficient", "Std err (fit)", "Std err (scale)",
                             "Std err (total)", "95 % interval (total)",
                             "dk/d(ln s) per view"], cal, align="lrrrrl")]
        parts += [f"Note: {a}: {n}" for a, f in self.axes.items() if f for n in f.notes]
        return Report(parts)

    def summary(self):
        """A readable text report of the fit, like statsmodels' ``summary()``.

        The model, Cp, g and v1; the points per axis and the AIC; how the errors were
        computed; k1..k4 with standard error and 95 % interval, or why not determined;
        per axis the parameters fitted, the residual RMS (mm), the condition number and
        the lag-1 autocorrelation of the residuals; the initial state; the axes' notes.

        Returns
        -------
        str
        """
        return self._report().text()

    def to_dict(self):
        return {"model": self.model, "cp_s_per_m": self.cp_s_per_m,
                "coefficients": {k: c.to_dict() for k, c in self.coefficients.items()},
                "initial_state": self.initial_state,
                "residual_rms_m": self.residual_rms_m, "points": self.points,
                "condition_number": {a: (f.condition_number if f else None)
                                     for a, f in self.axes.items()},
                "residual_autocorrelation": {a: (f.autocorrelation if f else None)
                                             for a, f in self.axes.items()},
                "error_model": {a: (f.error_model.to_dict() if f and f.error_model else None)
                                for a, f in self.axes.items()},
                "aic": self.aic()}


def _num(x, sig):
    """``sig`` significant digits; '' for None, 'n/a' when not finite."""
    return fmt_num(x, sig=sig, nonfinite="n/a")


def coefficient_rows(coefficients):
    """The k table's rows as text: name, value, std. error, 95 % interval, note.

    The one formatting of the coefficients, shared by :meth:`ThrowFit.summary` and the
    run report (report.md, report.html).

    Parameters
    ----------
    coefficients : mapping of str to Coefficient or its ``to_dict()``
        ``ThrowFit.coefficients``, or the ``coefficients`` of a fit.json record.

    Returns
    -------
    list of tuple of str
        ``(name, value, stderr, "lo .. hi", note)``: 5, 3 and 5 significant digits;
        ``(name, "not determined", "", "", reason)`` for one that is not determined.
    """
    rows = []
    for k, c in coefficients.items():
        c = c.to_dict() if isinstance(c, Coefficient) else c
        if c["determined"]:
            ci = c["ci95"]
            rows.append((k, _num(c["value"], 5), _num(c["stderr"], 3),
                         f"{_num(ci[0], 5)} .. {_num(ci[1], 5)}" if ci else "",
                         c.get("reason") or ""))
        else:
            rows.append((k, "not determined", "", "", c.get("reason") or ""))
    return rows


#: What the calibration's part of a coefficient's error is, said beside its table.
CALIBRATION_NOTE = ("The scale's part is systematic: each view's scale converts every point "
                    "of that view, in every throw of the run, so averaging throws does not "
                    "reduce it; the fit's part is the scatter of the points.")


def calibration_rows(coefficients):
    """The calibration's part of each determined k as text, or [] when there is none.

    Parameters
    ----------
    coefficients : mapping of str to Coefficient or its ``to_dict()``

    Returns
    -------
    list of tuple of str
        ``(name, stderr fit, stderr scale, stderr total, "lo .. hi" total,
        "front -1.6, top 0.46")``, for the coefficients that carry a calibration part.
    """
    rows = []
    for k, c in coefficients.items():
        c = c.to_dict() if isinstance(c, Coefficient) else c
        if not c.get("determined") or c.get("stderr_calibration") is None:
            continue
        ci = c.get("ci95_total")
        sens = c.get("scale_sensitivity") or {}
        rows.append((k, _num(c.get("stderr_fit", c["stderr"]), 3),
                     _num(c["stderr_calibration"], 3),
                     _num(c["stderr_total"], 3),
                     f"{_num(ci[0], 5)} .. {_num(ci[1], 5)}" if ci else "",
                     ", ".join(f"{v} {_num(d, 3)}" for v, d in sens.items())))
    return rows


# ---------------------------------------------------------------- axis models

def _axis_model(axis, names, values, fit, t):
    p = dict(zip(names, values))
    if axis == "y":
        k1 = p.get("k1", p.get("k2", 1.0))
        k2 = p.get("k2", k1)
        return flight_y(t, p["y0"], p["vy0"], k1, k2, fit.cp_s_per_m, g=fit.g_m_s2,
                        model=fit.model)[0]
    kname, v, x0 = ("k3", "vx0", "x0") if axis == "x" else ("k4", "vz0", "z0")
    frame = 0.0 if axis == "x" else fit.v1_m_s
    return flight_drag(t, p[x0], p[v], p.get(kname, 1.0), fit.cp_s_per_m, g=fit.g_m_s2,
                       model=fit.model, frame_speed=frame)[0]
