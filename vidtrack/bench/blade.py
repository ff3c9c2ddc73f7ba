"""The blade slide (Chen 2018, eqs. 1-3): printed forms and solve_ivp against 50-digit truth.

For each case the straw's coordinate l(t) along the blade is evaluated on 200 points
from the impact to the release, by

- the exact closed form of ``fits.blade`` (what vidtrack uses),
- eq. 2 with its constants as printed (C2 has a wrong sign: misses l(0) = l1),
- eq. 3, the paper's two-term series ``l1 + a0 t^2 / 2`` (what the paper computes with),
- ``scipy.integrate.solve_ivp`` (RK45 at rtol 1e-6, DOP853 at rtol 1e-12),

against the exact solution evaluated with mpmath at 50 significant digits (and its
release time found there with ``mpmath.findroot``). Columns:
``case``, ``method``, ``max_error_m`` (over the slide), ``error_at_release_m`` (at the
true release time), ``release_time_s`` (each method's own root of l = R cos delta1),
``release_time_error_s``, ``time_per_eval_s`` (median wall time of one evaluation of
the whole slide), then ``cpu_min_s``, ``cpu_median_s``, ``wall_min_s``,
``wall_median_s`` and ``calls`` (:func:`vidtrack.bench._timing.timed`: one warm-up call
uncounted, then ``repeats`` counted calls and more while they take less than the time
budget, at most 25).
"""

import math

import numpy as np
import pandas as pd

from fits.blade import (BladeSetting, release, slide_eq2_printed, slide_eq3_series,
                        slide_ode, slide_position)
from vidtrack.bench._timing import timed

#: (name, setting) pairs; the first is the slide check of docs/predict.md (not published).
CASES = (
    ("slide check", BladeSetting(550, -10, radius_m=0.25, start_m=0.10, friction=0.5,
                              phase_deg=30)),
    ("worked example", BladeSetting(450, -10)),
    ("backward rake, slow", BladeSetting(350, 10)),
    ("fast, mu = 1", BladeSetting(750, 0, friction=1.0)),
)
POINTS = 200


def _exact_mp(t, s, digits=50, *, release_near=None):
    """l(t) from the exact closed form in mpmath (C1, C2 in their simplified form).

    With ``release_near`` (a time in s), return instead the release time: the root of
    l(t) = R cos(delta1) nearest to it, at ``digits`` digits."""
    import mpmath as mp

    with mp.workdps(digits):
        w = mp.pi * mp.mpf(s.n_rpm) / 30
        mu = mp.mpf(s.friction)
        g = mp.mpf(s.g_m_s2)
        d1 = mp.radians(mp.mpf(s.blade_angle_deg))
        a0 = mp.radians(mp.mpf(s.phase_deg))
        phi = mp.atan(mu)
        root = mp.sqrt(1 + mu * mu)
        lam1, lam2 = -mu + root, -mu - root
        shift = mp.mpf(s.start_m) + mu * mp.mpf(s.radius_m) * mp.sin(d1)
        q = g / (4 * w * w)
        c1 = q * (mp.cos(2 * phi - d1 + a0) - mp.sin(phi - d1 + a0)) \
            + (1 + mp.sin(phi)) / 2 * shift
        c2 = q * (mp.cos(2 * phi - d1 + a0) + mp.sin(phi - d1 + a0)) \
            + (1 - mp.sin(phi)) / 2 * shift
        d = -2 * q * mp.cos(2 * phi - d1)
        m = 2 * q * mp.sin(2 * phi - d1)
        off = -mu * mp.mpf(s.radius_m) * mp.sin(d1)

        def ell(tt):
            return (c1 * mp.exp(lam1 * w * tt) + c2 * mp.exp(lam2 * w * tt)
                    + d * mp.cos(w * tt + a0) + m * mp.sin(w * tt + a0) + off)
        if release_near is not None:
            tip = mp.mpf(s.radius_m) * mp.cos(d1)
            return float(mp.findroot(lambda tt: ell(tt) - tip, mp.mpf(release_near)))
        out = []
        for tt in np.atleast_1d(t):
            tt = mp.mpf(float(tt))
            out.append(float(ell(tt)))
    return np.array(out)


def _root(fn, tip, t_hi):
    """First t in (0, t_hi] where fn(t) reaches ``tip`` (fn vectorised), or nan."""
    from scipy.optimize import brentq

    grid = np.linspace(0.0, t_hi, 401)
    gap = fn(grid) - tip
    idx = np.flatnonzero((gap[:-1] < 0) & (gap[1:] >= 0))
    if idx.size == 0:
        return math.nan
    i = int(idx[0])
    return float(brentq(lambda x: float(fn(np.array([x]))[0]) - tip, grid[i], grid[i + 1],
                        xtol=1e-15, rtol=1e-14))


def _ode(method, rtol):
    def evaluate(t, s):
        return slide_ode(t, s, method=method, rtol=rtol, atol=rtol * 1e-3)[:, 0]
    evaluate.ode = (method, rtol)
    return evaluate


def _ode_release_time(s, method, rtol):
    """The release time by solve_ivp with an event at l = R cos(delta1) (eq. 1 as in
    ``fits.blade.slide_ode``)."""
    from scipy.integrate import solve_ivp

    w, mu, g, r0 = s.omega_rad_s, s.friction, s.g_m_s2, s.r0_m

    def rhs(t, y):
        beta = s.alpha0_rad + w * t - s.delta1_rad
        return [y[1], y[0] * w * w + g * math.cos(beta) - mu * g * math.sin(beta)
                - mu * (2.0 * w * y[1] - r0 * w * w)]

    def tip(t, y):
        return y[0] - s.tip_m
    tip.terminal, tip.direction = True, 1
    sol = solve_ivp(rhs, (0.0, 4.0 * math.pi / w), [s.start_m, 0.0], method=method,
                    rtol=rtol, atol=rtol * 1e-3, events=tip)
    return float(sol.t_events[0][0]) if sol.t_events[0].size else math.nan


METHODS = (
    ("exact closed form (vidtrack)", slide_position),
    ("eq. 2 as printed", slide_eq2_printed),
    ("eq. 3 series (paper)", slide_eq3_series),
    ("solve_ivp RK45 rtol 1e-6", _ode("RK45", 1e-6)),
    ("solve_ivp DOP853 rtol 1e-12", _ode("DOP853", 1e-12)),
)


def run_blade_bench(*, cases=CASES, budget_s=0.1, repeats=3, warmup=1):
    """Benchmark every method on every case; returns a DataFrame (see the module doc).

    Parameters
    ----------
    cases : sequence of (str, fits.blade.BladeSetting), keyword-only
    budget_s : float, keyword-only
        Time budget for repeating one method's evaluation past ``repeats``.
    repeats, warmup : int, keyword-only
        Counted calls of each method (at least), and uncounted calls before them.
    """
    rows = []
    for name, s in cases:
        t0 = _exact_mp(None, s, release_near=release(s).release_time_s)
        t = np.linspace(0.0, t0, POINTS)
        truth = _exact_mp(t, s)
        truth_t0 = float(_exact_mp([t0], s)[0])
        for method, fn in METHODS:
            timing = timed(lambda fn=fn, t=t, s=s: fn(t, s), repeats=repeats, warmup=warmup,
                           budget_s=budget_s, max_repeats=25)
            err = np.abs(np.asarray(timing.result) - truth)
            at_release = abs(float(np.asarray(fn(np.array([0.0, t0]), s))[-1]) - truth_t0)
            if hasattr(fn, "ode"):
                t_rel = _ode_release_time(s, *fn.ode)
            else:
                t_rel = _root(lambda tt, fn=fn, s=s: np.asarray(fn(tt, s)), s.tip_m, 2.0 * t0)
            rows.append({"case": name, "method": method,
                         "max_error_m": float(np.max(err)),
                         "error_at_release_m": at_release,
                         "release_time_s": t_rel,
                         "release_time_error_s": abs(t_rel - t0),
                         "time_per_eval_s": timing.wall_median_s, **timing.columns()})
    return pd.DataFrame(rows)
