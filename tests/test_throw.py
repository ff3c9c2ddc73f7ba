"""fits.throw against truth it did not make: a tight ODE solution, exact limits, the paper.

The reference is ``fits.throw.ode.solve_throw`` at rtol 1e-12 (solve_ivp, one smooth law
per flight phase, the apex as an event): DOP853 where the problem is not stiff, LSODA
with the exact Jacobian where an explicit method could not reach the end (Radau agrees
with it to 1e-12 there, at a hundred times the cost).
"""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as hs

from fits.errors import InputError
from fits.throw import G_STANDARD, apex, position, terminal_speed, velocity
from fits.throw.ode import solve_throw
from fits.throw.printed import printed_position

G = G_STANDARD
PAPER_STATE = (0.25, 0.15, 0.0, 7.0, 4.5, 2.0)
PAPER_K = (2.2, 2.5, 4.6, 21.3)
PAPER_CP = 0.115


def _stiffness(t_max, state, k, cp, model):
    """Largest (time span x Jacobian magnitude) over the axes, a bound for explicit steps."""
    if model == "free":
        return 0.0
    vmax = max(abs(state[3]), abs(state[4]), abs(state[5]), 1.0 / cp if cp else 0.0)
    c = cp * cp * 2 * vmax if model == "quadratic" else cp
    return t_max * max(k) * G * c


def reference(t, state, k, cp, *, v1=0.0, model="quadratic"):
    method = "LSODA" if _stiffness(np.max(t), state, k, cp, model) > 200 else "DOP853"
    try:
        return solve_throw(t, state, k, cp, v1=v1, model=model, method=method,
                           rtol=1e-12, atol=1e-15)
    except ValueError:
        # LSODA's dense output can fail on a long phase followed by a very stiff one
        # (it repeats a step time); Radau with the exact Jacobian does not
        return solve_throw(t, state, k, cp, v1=v1, model=model, method="Radau",
                           rtol=1e-12, atol=1e-15)


def assert_close_to_reference(t, state, k, cp, *, v1=0.0, model="quadratic"):
    got = position(t, state, k, cp, v1=v1, model=model)
    ref = reference(t, state, k, cp, v1=v1, model=model)
    assert np.all(np.isfinite(got)), "closed form returned a non-finite value"
    scale = np.max(np.abs(ref), axis=0)
    tol = 1e-9 * scale + 1e-12
    err = np.max(np.abs(got - ref), axis=0)
    assert np.all(err <= tol), f"max error per axis {err}, allowed {tol}"


# ---------------------------------------------------------------- the sweep

log_k = hs.floats(-3, 4).map(lambda e: 10.0**e)
log_cp = hs.one_of(hs.just(0.0), hs.floats(-9, 1).map(lambda e: 10.0**e))
# below 1e-30 a speed is 0: scipy's DOP853 error norm squares it to 0/0 (the reference's
# limit, not the closed form's; the closed form at 1e-162 m/s is tested below)
def _speeds(lo, hi):
    return hs.floats(lo, hi, allow_subnormal=False).map(lambda v: 0.0 if abs(v) < 1e-30 else v)


speed = _speeds(-50, 50)
throws = hs.tuples(
    hs.tuples(hs.floats(-1, 1, allow_subnormal=False), hs.floats(-1, 1, allow_subnormal=False),
              hs.floats(-1, 1, allow_subnormal=False), speed, speed,
              _speeds(-20, 20)),
    hs.tuples(log_k, log_k, log_k, log_k),
    log_cp,
    _speeds(-20, 20),                                     # v1
    hs.floats(-3, 3).map(lambda e: 10.0**e),              # t_max: 1 ms to 1000 s
)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(throws, hs.sampled_from(["quadratic", "linear", "free"]))
def test_closed_form_matches_tight_ode(throw, model):
    state, k, cp, v1, t_max = throw
    t = np.linspace(0.0, t_max, 41)
    assert_close_to_reference(t, state, k, cp, v1=v1, model=model)


@pytest.mark.parametrize("case", [
    # (state, k, cp, v1, t_max): the corners the issue names
    (PAPER_STATE, PAPER_K, PAPER_CP, 2.0, 0.6),                       # the paper's case
    (PAPER_STATE, (2.2, 2.5, 4.6, 2000.0), 0.5, 2.0, 0.6),             # stiff k4
    ((0, 0, 0, 7.0, 4.5, 2.0), PAPER_K, 1e-9, 2.0, 100.0),             # Cp -> 0, long descent
    ((0, 0, 0, 7.0, 4.5, 2.0), PAPER_K, 0.0, 2.0, 1000.0),             # exactly drag-free
    ((0, 0, 0, -7.0, -4.5, -3.0), PAPER_K, 0.3, 1.0, 5.0),             # thrown back and down
    ((0, 1, 0, 3.0, -40.0, 2.0), PAPER_K, 0.5, 2.0, 10.0),             # faster than terminal
    ((0, 1, 0, 3.0, -2.0, 2.0), PAPER_K, 0.5, 2.0, 10.0),              # exactly terminal
    ((0, 0, 0, 7.0, 30.0, 2.0), (1e4, 1e4, 1e4, 1e4), 1.0, 2.0, 1000.0),  # k = 1e4
    ((0, 0, 0, 7.0, 4.5, 2.0), (1e-3, 1e-3, 1e-3, 1e-3), 0.1, 2.0, 1000.0),  # k = 1e-3
    ((0, 0, 0, 0.0, 2.0, 0.0), (1e-3, 1e4, 1.0, 1.0), 0.1, 0.0, 1000.0),  # 200 s up, stiff down
])
@pytest.mark.parametrize("model", ["quadratic", "linear"])
def test_named_corners_match_ode(case, model):
    state, k, cp, v1, t_max = case
    t = np.concatenate([np.linspace(0, t_max, 200), np.geomspace(1e-6, t_max, 50)])
    assert_close_to_reference(t, state, k, cp, v1=v1, model=model)


# ---------------------------------------------------------------- limits in closed form

def test_cp_zero_is_projectile_motion():
    state, k, v1 = (0.1, 0.2, 0.3, 7.0, 4.5, 2.5), (1.5, 2.5, 9.0, 9.0), 2.0
    t = np.linspace(0, 3, 301)
    xyz = position(t, state, k, 0.0, v1=v1)
    t1 = 4.5 / (1.5 * G)
    y1 = 0.2 + 4.5**2 / (2 * 1.5 * G)
    y = np.where(t <= t1, 0.2 + 4.5 * t - 1.5 * G * t**2 / 2, y1 - 2.5 * G * (t - t1) ** 2 / 2)
    np.testing.assert_allclose(xyz[:, 0], 0.1 + 7.0 * t, rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(xyz[:, 1], y, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(xyz[:, 2], 0.3 + (2.5 - v1) * t, rtol=1e-15, atol=1e-15)
    a = apex(state, k, 0.0)
    assert a.t_s == pytest.approx(t1, rel=1e-15) and a.y_m == pytest.approx(y1, rel=1e-15)


def test_free_model_is_quadratic_at_cp_zero():
    t = np.linspace(0, 2, 50)
    np.testing.assert_array_equal(position(t, PAPER_STATE, PAPER_K, 0.3, model="free"),
                                  position(t, PAPER_STATE, PAPER_K, 0.0))


@pytest.mark.parametrize("cp", [1e-300, 1e-150, 1e-12])
def test_tiny_cp_is_continuous_with_cp_zero(cp):
    t = np.linspace(0, 50, 101)
    np.testing.assert_allclose(position(t, PAPER_STATE, PAPER_K, cp, v1=2.0),
                               position(t, PAPER_STATE, PAPER_K, 0.0, v1=2.0),
                               rtol=1e-12, atol=1e-12)


def test_vanishing_speeds_are_continuous():
    t = np.linspace(0, 2, 21)
    tiny = position(t, (0, 0, 0, 1e-162, 1e-300, 4e-162), PAPER_K, PAPER_CP, v1=1e-200)
    np.testing.assert_allclose(tiny, position(t, (0, 0, 0, 0, 0, 0), PAPER_K, PAPER_CP),
                               rtol=0, atol=1e-150)


def test_descent_reaches_terminal_speed_exactly():
    cp = 0.5
    t = np.array([50.0, 100.0, 1000.0])
    v = velocity(t, (0, 0, 0, 1, 3, 0), PAPER_K, cp)
    np.testing.assert_allclose(v[:, 1], -terminal_speed(cp), rtol=1e-15)
    # so the height falls at 1/cp per second, without overflow
    y = position(t, (0, 0, 0, 1, 3, 0), PAPER_K, cp)[:, 1]
    np.testing.assert_allclose(np.diff(y) / np.diff(t), -1 / cp, rtol=1e-12)


def test_apex_formula_of_the_paper():
    """t1 = atan(cp vy0) / (k1 g cp), y1 = y0 + ln(1 + cp^2 vy0^2) / (2 k1 g cp^2)."""
    cp, (k1, vy0, y0) = PAPER_CP, (2.2, 4.5, 0.15)
    a = apex(PAPER_STATE, PAPER_K, cp)
    assert a.t_s == pytest.approx(np.arctan(cp * vy0) / (k1 * G * cp), rel=1e-14)
    assert a.y_m == pytest.approx(y0 + np.log1p(cp**2 * vy0**2) / (2 * k1 * G * cp**2),
                                  rel=1e-14)
    v = velocity([a.t_s], PAPER_STATE, PAPER_K, cp)
    assert abs(v[0, 1]) < 1e-14
    assert apex((0, 0, 0, 1, -1, 0), PAPER_K, cp) is None


def test_linear_model_matches_liao_closed_form():
    """Liao 2021 eqs. 15-18: m x'' = -kx', m y'' = -ky' - mg (k1 = k2 = k3 = 1)."""
    m, k_liao = 0.05, 0.02
    beta = k_liao / m
    cp = beta / G                              # the documented mapping cp = k / (m g)
    vx0, vy0 = 6.0, 3.0
    t = np.linspace(0, 1.5, 151)
    xyz = position(t, (0, 0, 0, vx0, vy0, 0), (1, 1, 1, 1), cp, model="linear")
    x = vx0 / beta * (1 - np.exp(-beta * t))
    y = (vy0 + G / beta) / beta * (1 - np.exp(-beta * t)) - G / beta * t
    np.testing.assert_allclose(xyz[:, 0], x, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(xyz[:, 1], y, rtol=1e-11, atol=1e-13)


# ---------------------------------------------------------------- the printed forms

def test_printed_forms_reproduced_where_valid():
    t = np.linspace(0, 0.5, 401)
    ours = position(t, PAPER_STATE, PAPER_K, PAPER_CP, v1=PAPER_STATE[5])
    printed = printed_position(t, PAPER_STATE, PAPER_K, PAPER_CP)
    np.testing.assert_allclose(ours, printed, rtol=1e-12, atol=1e-13)


def test_printed_forms_break_where_model_md_says():
    # eq. 14 overflows on a long descent; eq. 14 cancels as cp -> 0
    t = np.array([200.0])
    assert not np.isfinite(printed_position(t, (0, 0, 0, 1, 1, 0), (1, 1, 1, 1), 0.5)[0, 1])
    assert np.isfinite(position(t, (0, 0, 0, 1, 1, 0), (1, 1, 1, 1), 0.5)[0, 1])
    t = np.linspace(0, 0.6, 61)
    err = np.abs(printed_position(t, PAPER_STATE, PAPER_K, 1e-9)
                 - reference(t, PAPER_STATE, PAPER_K, 1e-9, v1=2.0)).max()
    assert err > 0.01          # metres off, as MODEL.md says
    ours = np.abs(position(t, PAPER_STATE, PAPER_K, 1e-9, v1=2.0)
                  - reference(t, PAPER_STATE, PAPER_K, 1e-9, v1=2.0)).max()
    assert ours < 1e-12


# ---------------------------------------------------------------- scale and input

def test_a_million_points_in_one_call():
    t = np.random.default_rng(1).uniform(0, 2.0, 1_000_000)   # any order
    xyz = position(t, PAPER_STATE, PAPER_K, PAPER_CP, v1=2.0)
    assert xyz.shape == (1_000_000, 3) and xyz.dtype == np.float64
    assert np.all(np.isfinite(xyz))
    i = np.argsort(t)[::9973]
    np.testing.assert_allclose(xyz[i], reference(t[i], PAPER_STATE, PAPER_K, PAPER_CP, v1=2.0),
                               rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("kwargs, word", [
    ({"cp": -0.1}, "cp"),
    ({"cp": np.nan}, "cp"),
    ({"k": (1, 0, 1, 1)}, "k2"),
    ({"k": (1, 1, -2, 1)}, "k3"),
    ({"k": (1, 1, 1, np.inf)}, "k4"),
    ({"state": (0, 0, np.nan, 1, 1, 1)}, "z0"),
    ({"state": (0, 0, 0, 1, 1)}, "state"),
    ({"t": [0.1, -0.2]}, "t"),
    ({"t": [0.1, np.inf]}, "t"),
    ({"model": "cubic"}, "model"),
])
def test_invalid_input_raises_value_error_naming_it(kwargs, word):
    args = {"t": [0.0, 0.1], "state": PAPER_STATE, "k": PAPER_K, "cp": PAPER_CP}
    args.update(kwargs)
    model = args.pop("model", "quadratic")
    with pytest.raises(ValueError, match=word) as info:
        position(args["t"], args["state"], args["k"], args["cp"], model=model)
    assert isinstance(info.value, InputError)
