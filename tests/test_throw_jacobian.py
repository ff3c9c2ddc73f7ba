"""fits.throw.jacobian against central differences of the textbook solutions in 80 digits.

The reference differentiates forms that share no code with ``fits.throw``: the quadratic
law of ``fits.throw.mp`` and the linear law written out below, with a step of 1e-25 at
80 significant digits (exact to far below float64), over the corners of the parameter
space the closed forms are tested on.
"""

import mpmath as mp
import numpy as np
import pytest

from fits.throw import G_STANDARD, flight_y
from fits.throw import mp as throw_mp
from fits.throw.jacobian import flight_drag_jacobian, flight_y_jacobian

DPS = 80
STEP = mp.mpf("1e-25")


def _linear_disp(t, v0, a, c):
    """Displacement under dv/dt = -a (1 + c v), the textbook form (c > 0)."""
    return -t / c + (v0 + 1 / c) * (1 - mp.exp(-a * c * t)) / (a * c)


def _y_linear(t, y0, vy0, a, d, c):
    if vy0 > 0:
        t1 = mp.log(1 + c * vy0) / (a * c)
        if t <= t1:
            return y0 + _linear_disp(t, vy0, a, c)
        return y0 + _linear_disp(t1, vy0, a, c) + _linear_disp(t - t1, 0, d, c)
    return y0 + _linear_disp(t, vy0, d, c)


def _y(model, t, y0, vy0, k1, k2, c):
    g = mp.mpf(G_STANDARD)
    law = throw_mp._y if model == "quadratic" else _y_linear
    return law(t, y0, vy0, k1 * g, k2 * g, c)


def _drag(model, t, x0, v0, kd, c):
    g = mp.mpf(G_STANDARD)
    if model == "quadratic":
        return throw_mp._drag(t, x0, v0, kd * g * c * c, 0)
    return x0 + v0 * (1 - mp.exp(-kd * g * c * t)) / (kd * g * c)


def _reference(f, t, params):
    """Central differences of ``f(t, *params)`` in 80 digits: shape (N, len(params))."""
    with mp.workdps(DPS):
        p = [mp.mpf(float(v)) for v in params]
        cols = []
        for j in range(len(p)):
            up, dn = list(p), list(p)
            up[j] += STEP
            dn[j] -= STEP
            cols.append([(f(mp.mpf(float(ti)), *up) - f(mp.mpf(float(ti)), *dn)) / (2 * STEP)
                         for ti in t])
        return np.array(cols, dtype=float).T


def _assert_columns_match(got, ref):
    assert np.all(np.isfinite(got))
    scale = np.max(np.abs(ref), axis=0)
    err = np.max(np.abs(got - ref), axis=0)
    assert np.all(err <= 1e-12 * scale + 1e-300), f"error per column {err / scale}"


# (y0, vy0, k1, k2, cp, t_max): the paper's throw and the corners of the closed forms
Y_CASES = [
    (0.15, 4.5, 2.2, 2.5, 0.115, 0.6),            # the paper's throw
    (0.15, 4.5, 2.2, 2.5, 1e-7, 0.6),             # Cp -> 0
    (0.0, 30.0, 1e4, 1e4, 1.0, 10.0),             # k = 1e4, long past terminal speed
    (0.0, 4.5, 1e-3, 1e-3, 0.1, 100.0),           # k = 1e-3
    (0.0, 0.01, 50.0, 0.05, 0.115, 0.6),          # a tiny ascent, a jump of law at the apex
    (1.0, -40.0, 2.2, 2.5, 0.5, 10.0),            # thrown down faster than terminal
    (1.0, -1.0, 2.2, 2.5, 0.5, 3.0),              # thrown down, slower than terminal
]
# (x0, v0, kd, cp, t_max)
DRAG_CASES = [
    (0.25, 7.0, 4.6, 0.115, 0.6),
    (0.0, 2.0, 21.3, 0.115, 0.6),
    (0.0, -7.0, 4.6, 0.3, 5.0),                   # thrown back
    (0.0, 50.0, 1e4, 2.0, 0.6),                   # strong drag: the speed is gone at once
    (0.0, 7.0, 1e-4, 1e-6, 0.6),                  # almost no drag
]
#: each axis's derivatives and the law they are checked against
AXES = {"y": (flight_y_jacobian, _y), "x or z": (flight_drag_jacobian, _drag)}


@pytest.mark.parametrize("model", ["quadratic", "linear"])
@pytest.mark.parametrize("axis, case", [("y", c) for c in Y_CASES]
                         + [("x or z", c) for c in DRAG_CASES])
def test_derivatives_match_80_digit_differences(axis, case, model):
    jacobian, law = AXES[axis]
    *params, cp, t_max = case
    t = np.concatenate([np.linspace(0, t_max, 29), np.geomspace(1e-6, t_max, 8)])
    got = jacobian(t, *params, cp, model=model)
    ref = _reference(lambda ti, *p: law(model, ti, *p, mp.mpf(cp)), t, params)
    _assert_columns_match(got, ref)


@pytest.mark.parametrize("cp", [0.0, 0.115])
def test_drag_free_derivatives_are_those_of_projectile_motion(cp):
    g, t = G_STANDARD, np.linspace(0, 1.5, 31)
    k1, k2, vy0 = 2.2, 2.5, 4.5
    t1 = vy0 / (k1 * g)
    up = t <= t1
    jac = flight_y_jacobian(t, 0.1, vy0, k1, k2, cp, model="free")
    np.testing.assert_allclose(jac[:, 1], np.where(up, t, t1 + k2 / k1 * (t - t1)),
                               rtol=1e-12, atol=1e-15)
    # ascent: -g t^2 / 2; descent: through the apex, which moves as 1/k1
    dk1 = np.where(up, -g * t**2 / 2, -vy0**2 / (2 * k1**2 * g) - k2 * g * (t - t1) * t1 / k1)
    np.testing.assert_allclose(jac[:, 2], dk1, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(jac[:, 3], np.where(up, 0, -g * (t - t1) ** 2 / 2),
                               rtol=1e-12, atol=1e-15)
    drag = flight_drag_jacobian(t, 0.0, 7.0, 4.6, cp, model="free")
    np.testing.assert_array_equal(drag, np.column_stack([np.ones_like(t), t, 0 * t]))


def test_a_common_k_is_the_sum_of_the_columns():
    """The fit of an ascent (or descent) alone ties k1 = k2: its column is the sum."""
    t = np.linspace(0, 0.6, 61)
    jac = flight_y_jacobian(t, 0.15, 4.5, 2.2, 2.2, 0.115)
    h = 1e-6
    fd = (flight_y(t, 0.15, 4.5, 2.2 + h, 2.2 + h, 0.115)[0]
          - flight_y(t, 0.15, 4.5, 2.2 - h, 2.2 - h, 0.115)[0]) / (2 * h)
    np.testing.assert_allclose(jac[:, 2] + jac[:, 3], fd, rtol=0, atol=1e-8)
