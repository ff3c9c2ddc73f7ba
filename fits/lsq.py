"""Least-squares fit of a world track to the throw model, axis by axis.

Each axis is its own ODE (``fits.throw``), so each is fitted on its own:

- x: x0, vx0, k3;
- y: y0, vy0, k1, k2 (the apex is where the fitted ascent ends);
- z: z0, vz0, k4, with the machine speed v1 given (z is relative to the machine).

Bounded nonlinear least squares (``scipy.optimize.least_squares``, trust region
reflective) in scaled variables, from several robust starting values (polynomial fits
of the track), with the closed form's own derivatives as the Jacobian
(:mod:`fits.throw.jacobian`), and finished by Gauss-Newton steps to the minimum itself,
so the answer does not depend on the start (a refit of a nearby track, ``near=``, then
needs one start). Standard errors and 95 % intervals come from the Jacobian
at the solution under an error model fitted to the residuals: white noise plus an
exponentially correlated part, by REML (:mod:`fits.errmodel`; tracking errors persist
over many frames); a residual bootstrap is an option. What the track cannot determine is
reported as not determined with the reason, never as a number:
no descent in view (k2), no ascent (k1), no top view (k4), too few points, cp = 0 (k3
and k4 have no effect), an interval that includes 0.

This module fits. What it returns, :class:`ThrowFit` with its :class:`AxisFit` and
:class:`Coefficient` and their tables and summaries, is defined in ``fits.lsq_results``
and importable from here too.
"""

import logging
from dataclasses import dataclass

import numpy as np
from scipy import optimize, special

from fits.errmodel import fit_error_model
from fits.errors import ConvergenceError, InputError
from fits.lsq_results import AxisFit, Coefficient, ThrowFit, coefficient_rows
from fits.throw import G_STANDARD, MODELS, flight_drag, flight_y
from fits.throw.jacobian import flight_drag_jacobian, flight_y_jacobian

__all__ = ["Coefficient", "AxisFit", "ThrowFit", "fit_throw", "compare_models",
           "coefficient_rows", "MIN_POINTS"]

log = logging.getLogger(__name__)

#: Fewest points an axis (or a flight phase, for k1 and k2) needs to be fitted.
MIN_POINTS = 6
_K_BOUNDS = (1e-4, 1e5)
#: Most Gauss-Newton steps that finish a fit (:func:`_polish`); one or two are used.
_POLISH_STEPS = 8
#: A polishing step may raise the cost by this much (relative): its rounding.
_COST_ROUNDING = 1e-12


# ---------------------------------------------------------------- the solver

@dataclass(frozen=True)
class _Problem:
    axis: str
    names: tuple
    fun: object          # fun(t, params) -> positions
    jac: object          # jac(t, params) -> (n, len(params)) d positions / d params
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

        def jac(q, scale=scale):
            return problem.jac(t, q * scale) * scale

        try:
            # a trial step may overflow: its residual is then not finite, which the
            # solver and the checks below handle; no warning for it
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                res = optimize.least_squares(
                    resid, p0 / scale, jac=jac, method="trf",
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
    _polish(problem, t, obs, *best)
    return best


def _polish(problem, t, obs, res, scale):
    """Gauss-Newton steps from the solver's answer ``res`` (changed in place: ``x``,
    ``fun``, ``cost``, and ``jac_at_x`` the scaled Jacobian there) to the least-squares
    minimum itself, where the residuals are orthogonal to the Jacobian.

    The solver stops where its tolerances say; on a flat valley the cost there is the
    minimum's to rounding while the estimates are up to a few 1e-6 (relative) apart from
    one start to another. Gauss-Newton converges from there in a step or two; a step is
    taken while it makes the residuals more nearly orthogonal to the Jacobian's columns
    (:func:`_gradient`) without raising the cost beyond rounding, and within the bounds.
    The answer then depends neither on the start nor on where the solver stopped.
    """
    q, r = res.x, res.fun
    lower, upper = problem.lower / scale, problem.upper / scale
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        jac = problem.jac(t, q * scale) * scale
        grad = _gradient(jac, r)
        for _ in range(_POLISH_STEPS):
            trial = q + np.linalg.lstsq(jac, -r, rcond=None)[0]
            if not np.all((trial > lower) & (trial < upper)):
                break
            r_trial = problem.fun(t, trial * scale) - obs
            jac_trial = problem.jac(t, trial * scale) * scale
            res.nfev += 1
            res.njev += 1
            grad_trial = _gradient(jac_trial, r_trial)
            if not (grad_trial < grad and r_trial @ r_trial <= (r @ r) * (1 + _COST_ROUNDING)):
                break
            q, r, jac, grad = trial, r_trial, jac_trial, grad_trial
    res.x, res.fun, res.cost = q, r, 0.5 * float(r @ r)
    res.jac_at_x = jac        # in the scaled variables, for _statistics (not evaluated again)


def _gradient(jac, r):
    """The largest |cosine| between the residuals and a column of the Jacobian (0 at the
    least-squares minimum; a column of zeros counts as orthogonal)."""
    norms = np.linalg.norm(jac, axis=0) * np.linalg.norm(r)
    cos = np.abs(jac.T @ r) / np.where(norms > 0, norms, 1.0)
    return float(np.max(cos)) if np.all(np.isfinite(cos)) else np.inf


def _solve_near(problem, t, obs, near, starts):
    """:func:`_solve` from ``near`` alone (the answer of a nearby fit), or from ``starts``
    when there is none or it does not converge."""
    if near is not None:
        try:
            return _solve(problem, t, obs, [near])
        except ConvergenceError:
            pass
    return _solve(problem, t, obs, starts)


def _lag1_autocorrelation(t, r):
    """Lag-1 autocorrelation of the residuals in time order, clipped to [0, 0.95]."""
    r = r[np.argsort(t, kind="stable")]
    den = float(r @ r)
    if r.size < 3 or den == 0:
        return 0.0
    return float(np.clip((r[:-1] @ r[1:]) / den, 0.0, 0.95))


def _statistics(problem, t, obs, res, scale, errors=True):
    """Covariance under the fitted error model; errors, intervals, conditioning.

    Tracking errors are not white: the covariance is the least-squares sandwich under
    white plus exponentially correlated errors fitted by REML (:mod:`fits.errmodel`),
    so the intervals stay honest on real footage. The lag-1 autocorrelation of the
    residuals is kept as a diagnostic.
    """
    p = res.x * scale
    # the residuals and the Jacobian at the answer, as _polish left them (the model is
    # not evaluated again for them)
    r = res.fun
    n, k = obs.size, p.size
    dof = n - k
    rss = float(r @ r)
    jac = res.jac_at_x                   # in the scaled variables
    s = np.linalg.svd(jac, compute_uv=False)
    cond = float(s[0] / s[-1]) if s[-1] > 0 else np.inf
    if not errors:       # the estimates only (fit_throw(errors=False)): no covariance
        cov_q, err_model = np.full((k, k), np.nan), None
    elif dof > 0 and s[-1] > s[0] * 1e-13:
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

def _near_values(near, names):
    """A starting value for ``names`` from ``near``, an :class:`AxisFit` of a nearby
    track (or None): its values; (y0, vy0, k, k) from a vertical fit of one phase."""
    if near is None:
        return None
    if near.names == names:
        return tuple(near.values)
    if names == ("y0", "vy0", "k1", "k2") and len(near.names) == 3:
        return (*near.values, near.values[2])
    return None


def _fit_drag_axis(axis, t, obs, cp, g, model, frame_speed, n_boot, rng, errors=True,
                   near=None):
    kname, vname, pname = ("k3", "vx0", "x0") if axis == "x" else ("k4", "vz0", "z0")
    p_pos, slope, accel = _poly2(t, obs)
    v0 = slope + frame_speed
    has_drag = model != "free" and cp > 0
    if has_drag:
        names = (pname, vname, kname)

        def fun(tt, p):
            return flight_drag(tt, p[0], p[1], p[2], cp, g=g, model=model,
                               frame_speed=frame_speed)[0]

        def jac(tt, p):
            return flight_drag_jacobian(tt, p[0], p[1], p[2], cp, g=g, model=model)
        k0 = _drag_k_start(accel, v0, cp, g, model)
        starts = [(p_pos, v0, k0 * f) for f in (1.0, 0.2, 5.0)]
        lower = np.array([-np.inf, -np.inf, _K_BOUNDS[0]])
        upper = np.array([np.inf, np.inf, _K_BOUNDS[1]])
    else:
        names = (pname, vname)

        def fun(tt, p):
            return p[0] + (p[1] - frame_speed) * tt

        def jac(tt, p):
            return np.column_stack([np.ones_like(tt), tt])
        starts = [(p_pos, v0)]
        lower, upper = np.full(2, -np.inf), np.full(2, np.inf)
    problem = _Problem(axis, names, fun, jac, lower, upper)
    res, scale = _solve_near(problem, t, obs, _near_values(near, names), starts)
    fit = _statistics(problem, t, obs, res, scale, errors)
    if n_boot and errors:
        fit = _bootstrap(problem, t, obs, fit, n_boot, rng)
    return fit


def _fit_y(t, obs, cp, g, model, n_boot, rng, errors=True, near=None):
    y_start, v_start, accel = _poly2(t, obs)
    k_start = float(np.clip(-accel / g, 0.05, 50.0)) if accel < 0 else 1.0

    def full(tt, p):
        return flight_y(tt, p[0], p[1], p[2], p[3], cp, g=g, model=model)[0]

    def full_jac(tt, p):
        return flight_y_jacobian(tt, p[0], p[1], p[2], p[3], cp, g=g, model=model)

    def one_k(tt, q):       # one coefficient for ascent and descent: (y0, vy0, k)
        return flight_y(tt, q[0], q[1], q[2], q[2], cp, g=g, model=model)[0]

    def one_k_jac(tt, q):
        j = flight_y_jacobian(tt, q[0], q[1], q[2], q[2], cp, g=g, model=model)
        return np.column_stack([j[:, 0], j[:, 1], j[:, 2] + j[:, 3]])

    starts = [(y_start, v_start, k_start * a, k_start * b)
              for a in (1.0, 0.5, 2.0) for b in (1.0, 0.5, 2.0)]
    inf = np.inf
    problem = _Problem("y", ("y0", "vy0", "k1", "k2"), full, full_jac,
                       np.array([-inf, -inf, _K_BOUNDS[0], _K_BOUNDS[0]]),
                       np.array([inf, inf, _K_BOUNDS[1], _K_BOUNDS[1]]))
    res, scale = _solve_near(problem, t, obs, _near_values(near, problem.names), starts)
    p = res.x * scale
    notes = []
    apex_t = _apex_time(p[1], p[2], cp, g, model)
    n_up = int(np.sum(t <= apex_t)) if apex_t is not None else 0
    n_down = t.size - n_up
    if n_down < MIN_POINTS:
        # no descent in view: k2 has (almost) no effect; fit the ascent law alone
        problem = _Problem("y", ("y0", "vy0", "k1"), one_k, one_k_jac, problem.lower[:3],
                           problem.upper[:3])
        res, scale = _solve(problem, t, obs, [p[:3], (y_start, v_start, k_start)])
        notes.append(f"k2: no descent observed ({n_down} points after the apex at "
                     f"t = {apex_t:.4g} s; at least {MIN_POINTS} needed)")
    elif p[1] <= 0 or n_up < MIN_POINTS:
        # no ascent in view: the descent law from the first point
        problem = _Problem("y", ("y0", "vy0", "k2"), one_k, one_k_jac,
                           problem.lower[[0, 1, 3]], np.array([inf, 0.0, _K_BOUNDS[1]]))
        res, scale = _solve(problem, t, obs, [(y_start, min(v_start, -1e-3), k_start)])
        why = ("thrown downward" if p[1] <= 0 else
               f"{n_up} points before the apex; at least {MIN_POINTS} needed")
        notes.append(f"k1: no ascent observed ({why})")
    fit = _statistics(problem, t, obs, res, scale, errors)
    if n_boot and errors:
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

def _coefficient(fit, name, errors=True):
    i = fit.names.index(name)
    value, se = float(fit.values[i]), float(fit.stderr[i])
    if not errors:
        return Coefficient(value, None, None, True)
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
              rng=None, errors=True, near=None):
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
    errors : bool, keyword-only
        False: the estimates only, for refits that need no more (the sensitivity of k
        to a view's scale): no error model, no bootstrap; every determined coefficient
        has ``stderr`` and ``ci95`` None and the axes' covariances are NaN. A
        coefficient is then "determined" when the axis fits it, without the interval's
        test against 0. About three times faster.
    near : ThrowFit, keyword-only
        A fit of the same model to a nearby track (the same throw with a view's scale
        moved, say): each axis is fitted from its values alone instead of from several
        starting values, and from those where it does not converge. The answer is the
        least-squares minimum next to ``near``'s.

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
        near_axis = near.axes.get(axis) if near is not None else None
        if axis == "y":
            fit = _fit_y(t, obs, cp, g, model, bootstrap, rng, errors, near_axis)
        else:
            fit = _fit_drag_axis(axis, t, obs, cp, g, model, v1 if axis == "z" else 0.0,
                                 bootstrap, rng, errors, near_axis)
        axes[axis] = fit
        log.debug("%s: %d points, parameters %s, residual RMS %.3g mm, %d evaluations",
                  axis, fit.n_points, ", ".join(fit.names), 1000 * fit.residual_rms_m,
                  fit.nfev)
        for k in kname:
            if k in fit.names:
                coeffs[k] = _coefficient(fit, k, errors)
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
