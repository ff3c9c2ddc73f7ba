"""Least-squares fit of a world track to the throw model, axis by axis.

Each axis is its own ODE (``fits.throw``), so each is fitted on its own:

- x: x0, vx0, k3;
- y: y0, vy0, k1, k2 (the apex is where the fitted ascent ends);
- z: z0, vz0, k4, with the machine speed v1 given (z is relative to the machine).

Bounded nonlinear least squares (``scipy.optimize.least_squares``, trust region
reflective) in scaled variables, from several robust starting values (polynomial fits
of the track). Standard errors and 95 % intervals come from the Jacobian at the solution
under an error model fitted to the residuals: white noise plus an exponentially
correlated part, by REML (:mod:`fits.errmodel`; tracking errors persist over many
frames); a residual bootstrap is an option. What the track cannot determine is
reported as not determined with the reason, never as a number:
no descent in view (k2), no ascent (k1), no top view (k4), too few points, cp = 0 (k3
and k4 have no effect), an interval that includes 0.
"""

import logging
import math
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize, special

from fits._text import Report, Table, fmt_num, fmt_pm
from fits.errmodel import ErrorModel, fit_error_model
from fits.errors import ConvergenceError, InputError
from fits.throw import G_STANDARD, MODELS, flight_drag, flight_y

__all__ = ["Coefficient", "AxisFit", "ThrowFit", "fit_throw", "compare_models",
           "coefficient_rows", "MIN_POINTS"]

log = logging.getLogger(__name__)

#: Fewest points an axis (or a flight phase, for k1 and k2) needs to be fitted.
MIN_POINTS = 6
_K_BOUNDS = (1e-4, 1e5)
#: The axis whose fit gives each coefficient.
K_AXIS = {"k1": "y", "k2": "y", "k3": "x", "k4": "z"}
_MODEL_NAMES = {"quadratic": "quadratic drag (Chen 2018)", "linear": "linear drag (Liao 2021)",
                "free": "drag-free (Hou 2019)"}


@dataclass(frozen=True)
class Coefficient:
    """One fitted coefficient: value, standard error and 95 % interval, or why not."""

    value: float | None
    stderr: float | None
    ci95: tuple | None
    determined: bool
    reason: str | None = None

    @classmethod
    def undetermined(cls, reason):
        return cls(None, None, None, False, reason)

    def to_dict(self):
        out = {"value": self.value, "stderr": self.stderr,
               "ci95": list(self.ci95) if self.ci95 is not None else None,
               "determined": self.determined}
        if self.reason:
            out["reason"] = self.reason
        return out


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
class ThrowFit:
    """The throw model fitted to a world track."""

    model: str
    cp_s_per_m: float
    g_m_s2: float
    v1_m_s: float
    coefficients: dict
    initial_state: dict
    axes: dict = field(default_factory=dict)

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

    def _repr_html_(self):
        """The :meth:`summary` as HTML tables (what a Jupyter notebook shows)."""
        return self._report().html()

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


# ---------------------------------------------------------------- the solver

@dataclass(frozen=True)
class _Problem:
    axis: str
    names: tuple
    fun: object          # fun(t, params) -> positions
    lower: np.ndarray
    upper: np.ndarray


def _solve(problem, t, obs, starts):
    """Best of several bounded least-squares runs; raises ConvergenceError if none works."""
    best = None
    for p0 in starts:
        p0 = np.clip(np.asarray(p0, float), problem.lower * (1 + 1e-9) + 1e-300,
                     problem.upper * (1 - 1e-9))
        scale = np.maximum(np.abs(p0), 1e-3)

        def resid(q, scale=scale):
            return problem.fun(t, q * scale) - obs

        try:
            # a trial step may overflow: its residual is then not finite, which the
            # solver and the checks below handle; no warning for it
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                res = optimize.least_squares(
                    resid, p0 / scale, method="trf",
                    bounds=(problem.lower / scale, problem.upper / scale), x_scale="jac",
                    xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=2000)
        except (ValueError, FloatingPointError):
            continue
        if not np.isfinite(res.cost):
            continue
        if best is None or res.cost < best[0].cost:
            best = (res, scale)
    if best is None or best[0].status <= 0:
        msg = best[0].message if best is not None else "no starting value gave a finite residual"
        raise ConvergenceError(
            f"the {problem.axis} fit did not converge ({msg}); {len(t)} points over "
            f"t = {t.min():.4g}..{t.max():.4g} s, position range "
            f"{np.ptp(obs):.4g} m")
    return best


def _jacobian(fun, t, p, scale):
    """Central-difference Jacobian in scaled variables (columns: d pos / d (p/scale))."""
    q = p / scale
    cols = []
    for j in range(p.size):
        h = 1e-6 * max(abs(q[j]), 1.0)
        up, dn = q.copy(), q.copy()
        up[j] += h
        dn[j] -= h
        cols.append((fun(t, up * scale) - fun(t, dn * scale)) / (2 * h))
    return np.column_stack(cols)


def _lag1_autocorrelation(t, r):
    """Lag-1 autocorrelation of the residuals in time order, clipped to [0, 0.95]."""
    r = r[np.argsort(t, kind="stable")]
    den = float(r @ r)
    if r.size < 3 or den == 0:
        return 0.0
    return float(np.clip((r[:-1] @ r[1:]) / den, 0.0, 0.95))


def _statistics(problem, t, obs, res, scale):
    """Covariance under the fitted error model; errors, intervals, conditioning.

    Tracking errors are not white: the covariance is the least-squares sandwich under
    white plus exponentially correlated errors fitted by REML (:mod:`fits.errmodel`),
    so the intervals stay honest on real footage. The lag-1 autocorrelation of the
    residuals is kept as a diagnostic.
    """
    p = res.x * scale
    r = problem.fun(t, p) - obs
    n, k = obs.size, p.size
    dof = n - k
    rss = float(r @ r)
    jac = _jacobian(problem.fun, t, p, scale)
    s = np.linalg.svd(jac, compute_uv=False)
    cond = float(s[0] / s[-1]) if s[-1] > 0 else np.inf
    if dof > 0 and s[-1] > s[0] * 1e-13:
        cov_q, err_model = fit_error_model(t, jac, r)
    else:
        cov_q, err_model = np.full((k, k), np.inf), None
    cov = cov_q * np.outer(scale, scale)
    se = np.sqrt(np.abs(np.diag(cov)))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(se, se)
    tq = special.stdtrit(dof, 0.975) if dof > 0 else np.inf
    ci = np.column_stack([p - tq * se, p + tq * se])
    return AxisFit(axis=problem.axis, names=problem.names, values=p, stderr=se,
                   covariance=cov, correlation=corr,
                   residual_rms_m=float(np.sqrt(rss / n)), n_points=n, dof=dof,
                   condition_number=cond, nfev=int(res.nfev), rss=rss, ci95=ci,
                   autocorrelation=_lag1_autocorrelation(t, r), error_model=err_model)


def _bootstrap(problem, t, obs, fit, n_boot, rng):
    """Residual bootstrap: standard errors and percentile intervals of the parameters."""
    fitted = problem.fun(t, fit.values)
    resid = obs - fitted
    resid = resid - resid.mean()
    draws = []
    for _ in range(n_boot):
        sample = fitted + rng.choice(resid, size=resid.size, replace=True)
        try:
            res, scale = _solve(problem, t, sample, [fit.values])
        except ConvergenceError:
            continue
        draws.append(res.x * scale)
    draws = np.asarray(draws)
    if len(draws) < max(10, n_boot // 2):
        return fit
    se = draws.std(axis=0, ddof=1)
    ci = np.percentile(draws, [2.5, 97.5], axis=0).T
    return AxisFit(**{**fit.__dict__, "stderr": se, "ci95": ci,
                      "notes": fit.notes + (f"bootstrap: {len(draws)} resamples",)})


# ---------------------------------------------------------------- starting values

def _poly2(t, obs):
    c = np.polynomial.polynomial.polyfit(t, obs, 2)
    return c[0], c[1], 2 * c[2]          # position, velocity, acceleration at t = 0


def _drag_k_start(accel, v0, cp, g, model):
    if cp == 0 or v0 == 0:
        return 1.0
    denom = g * (cp * cp * v0 * abs(v0) if model == "quadratic" else cp * v0)
    k = -accel / denom
    return float(np.clip(k, 1e-2, 1e3)) if np.isfinite(k) and k > 0 else 1.0


# ---------------------------------------------------------------- the axes

def _fit_drag_axis(axis, t, obs, cp, g, model, frame_speed, n_boot, rng):
    kname, vname, pname = ("k3", "vx0", "x0") if axis == "x" else ("k4", "vz0", "z0")
    p_pos, slope, accel = _poly2(t, obs)
    v0 = slope + frame_speed
    has_drag = model != "free" and cp > 0
    if has_drag:
        names = (pname, vname, kname)

        def fun(tt, p):
            return flight_drag(tt, p[0], p[1], p[2], cp, g=g, model=model,
                               frame_speed=frame_speed)[0]
        k0 = _drag_k_start(accel, v0, cp, g, model)
        starts = [(p_pos, v0, k0 * f) for f in (1.0, 0.2, 5.0)]
        lower = np.array([-np.inf, -np.inf, _K_BOUNDS[0]])
        upper = np.array([np.inf, np.inf, _K_BOUNDS[1]])
    else:
        names = (pname, vname)

        def fun(tt, p):
            return p[0] + (p[1] - frame_speed) * tt
        starts = [(p_pos, v0)]
        lower, upper = np.full(2, -np.inf), np.full(2, np.inf)
    problem = _Problem(axis, names, fun, lower, upper)
    res, scale = _solve(problem, t, obs, starts)
    fit = _statistics(problem, t, obs, res, scale)
    if n_boot:
        fit = _bootstrap(problem, t, obs, fit, n_boot, rng)
    return fit


def _fit_y(t, obs, cp, g, model, n_boot, rng):
    y_start, v_start, accel = _poly2(t, obs)
    k_start = float(np.clip(-accel / g, 0.05, 50.0)) if accel < 0 else 1.0

    def full(tt, p):
        return flight_y(tt, p[0], p[1], p[2], p[3], cp, g=g, model=model)[0]

    starts = [(y_start, v_start, k_start * a, k_start * b)
              for a in (1.0, 0.5, 2.0) for b in (1.0, 0.5, 2.0)]
    inf = np.inf
    problem = _Problem("y", ("y0", "vy0", "k1", "k2"), full,
                       np.array([-inf, -inf, _K_BOUNDS[0], _K_BOUNDS[0]]),
                       np.array([inf, inf, _K_BOUNDS[1], _K_BOUNDS[1]]))
    res, scale = _solve(problem, t, obs, starts)
    p = res.x * scale
    notes = []
    apex_t = _apex_time(p[1], p[2], cp, g, model)
    n_up = int(np.sum(t <= apex_t)) if apex_t is not None else 0
    n_down = t.size - n_up
    if n_down < MIN_POINTS:
        # no descent in view: k2 has (almost) no effect; fit the ascent law alone
        def ascent(tt, q):
            return flight_y(tt, q[0], q[1], q[2], q[2], cp, g=g, model=model)[0]
        problem = _Problem("y", ("y0", "vy0", "k1"), ascent, problem.lower[:3],
                           problem.upper[:3])
        res, scale = _solve(problem, t, obs, [p[:3], (y_start, v_start, k_start)])
        notes.append(f"k2: no descent observed ({n_down} points after the apex at "
                     f"t = {apex_t:.4g} s; at least {MIN_POINTS} needed)")
    elif p[1] <= 0 or n_up < MIN_POINTS:
        # no ascent in view: the descent law from the first point
        def descent(tt, q):
            return flight_y(tt, q[0], q[1], q[2], q[2], cp, g=g, model=model)[0]
        problem = _Problem("y", ("y0", "vy0", "k2"), descent,
                           problem.lower[[0, 1, 3]], np.array([inf, 0.0, _K_BOUNDS[1]]))
        res, scale = _solve(problem, t, obs, [(y_start, min(v_start, -1e-3), k_start)])
        why = ("thrown downward" if p[1] <= 0 else
               f"{n_up} points before the apex; at least {MIN_POINTS} needed")
        notes.append(f"k1: no ascent observed ({why})")
    fit = _statistics(problem, t, obs, res, scale)
    if n_boot:
        fit = _bootstrap(problem, t, obs, fit, n_boot, rng)
    return AxisFit(**{**fit.__dict__, "notes": fit.notes + tuple(notes)})


def _apex_time(vy0, k1, cp, g, model):
    if vy0 <= 0:
        return None
    a = k1 * g
    p = cp * vy0 if model != "free" else 0.0
    if p == 0:
        return vy0 / a
    if model == "linear":
        return np.log1p(p) / (a * cp)
    return np.arctan(p) / (a * cp)


# ---------------------------------------------------------------- public

def _coefficient(fit, name):
    i = fit.names.index(name)
    value, se = float(fit.values[i]), float(fit.stderr[i])
    lo, hi = (float(v) for v in fit.ci95[i])
    if not np.isfinite(se):
        return Coefficient.undetermined(f"{name} is not identifiable from this track "
                                        f"(singular Jacobian, condition number "
                                        f"{fit.condition_number:.3g})")
    if lo <= 0:
        return Coefficient.undetermined(
            f"the track does not resolve {name}: estimate {value:.4g} ± {se:.2g}, "
            f"95 % interval includes 0")
    return Coefficient(value, se, (lo, hi), True)


def _clean(t, obs):
    ok = np.isfinite(t) & np.isfinite(obs)
    return t[ok], obs[ok]


def fit_throw(world, cp, *, g=G_STANDARD, v1=0.0, model="quadratic", bootstrap=0,
              rng=None):
    """Fit the throw model to a world track, axis by axis.

    Parameters
    ----------
    world : pandas.DataFrame or mapping
        Columns ``t_s`` (s after release), ``x_m``, ``y_m``, ``z_m`` (m); NaN where a
        coordinate was not measured (a view the scene does not have, a flagged frame).
    cp : float
        Drag parameter Cp, s/m (>= 0), from the straw's mass, area and drag coefficient.
    g : float, keyword-only
        Gravity, m/s^2.
    v1 : float, keyword-only
        Machine speed, m/s (z is relative to the machine).
    model : {"quadratic", "linear", "free"}, keyword-only
    bootstrap : int, keyword-only
        Number of residual-bootstrap resamples for the errors (0: from the Jacobian).
    rng : numpy.random.Generator, keyword-only
        Random generator for the bootstrap.

    Returns
    -------
    ThrowFit

    Raises
    ------
    fits.errors.InputError
        Missing columns, cp < 0, an unknown model, or no axis with enough points.
    fits.errors.ConvergenceError
        An axis fit did not converge (the message carries the diagnostics).
    """
    if model not in MODELS:
        raise InputError(f"model must be one of {', '.join(MODELS)}, got {model!r}")
    if cp is None or not np.isfinite(cp) or cp < 0:
        raise InputError(f"cp must be a finite number >= 0 s/m, got {cp}")
    for col in ("t_s", "x_m", "y_m", "z_m"):
        if col not in world:
            raise InputError(f"world track: column {col!r} missing")
    t_all = np.asarray(world["t_s"], dtype=float)
    rng = np.random.default_rng() if rng is None else rng
    why_no_drag = ("model 'free' has no drag, so k3 and k4 have no effect" if model == "free"
                   else "Cp = 0 s/m: no drag, so k3 and k4 have no effect")
    axes, coeffs, state = {}, {}, {}
    for axis, col in (("x", "x_m"), ("y", "y_m"), ("z", "z_m")):
        t, obs = _clean(t_all, np.asarray(world[col], dtype=float))
        kname = {"x": ("k3",), "y": ("k1", "k2"), "z": ("k4",)}[axis]
        if t.size < MIN_POINTS:
            axes[axis] = None
            why = ("no top view" if axis == "z" and t.size == 0 else
                   "no front view" if axis == "y" and t.size == 0 else
                   f"too few points on {axis} ({t.size}; at least {MIN_POINTS} needed)")
            for k in kname:
                coeffs[k] = Coefficient.undetermined(why)
            continue
        if axis == "y":
            fit = _fit_y(t, obs, cp, g, model, bootstrap, rng)
        else:
            fit = _fit_drag_axis(axis, t, obs, cp, g, model, v1 if axis == "z" else 0.0,
                                 bootstrap, rng)
        axes[axis] = fit
        log.debug("%s: %d points, parameters %s, residual RMS %.3g mm, %d evaluations",
                  axis, fit.n_points, ", ".join(fit.names), 1000 * fit.residual_rms_m,
                  fit.nfev)
        for k in kname:
            if k in fit.names:
                coeffs[k] = _coefficient(fit, k)
            elif axis != "y":
                coeffs[k] = Coefficient.undetermined(why_no_drag)
            else:
                note = next(n for n in fit.notes if n.startswith(k))
                coeffs[k] = Coefficient.undetermined(note.split(": ", 1)[1])
        for name in fit.names:
            if not name.startswith("k"):
                state[name] = fit.value(name)
    if all(f is None for f in axes.values()):
        raise InputError(f"world track: no axis has {MIN_POINTS} or more measured points")
    for k in ("k1", "k2", "k3", "k4"):
        if not coeffs[k].determined:
            log.info("%s not determined: %s", k, coeffs[k].reason)
    initial = {name: state.get(name) for name in
               ("x0", "y0", "z0", "vx0", "vy0", "vz0")}
    initial = {f"{k}_m" if not k.startswith("v") else f"{k}_m_s": v
               for k, v in initial.items()}
    return ThrowFit(model=model, cp_s_per_m=float(cp), g_m_s2=float(g), v1_m_s=float(v1),
                    coefficients={k: coeffs[k] for k in ("k1", "k2", "k3", "k4")},
                    initial_state=initial, axes=axes)


def compare_models(world, cp, *, g=G_STANDARD, v1=0.0, models=MODELS):
    """Fit several models to the same track and rank them by AIC (lower is better).

    Returns a list of ``(model, aic, ThrowFit)`` sorted by AIC; a model whose fit does
    not converge is left out.
    """
    out = []
    for model in models:
        try:
            fit = fit_throw(world, cp, g=g, v1=v1, model=model)
        except ConvergenceError:
            continue
        out.append((model, fit.aic(), fit))
    return sorted(out, key=lambda row: row[1])
