"""The throw models as ODEs, solved numerically: the independent reference.

Same equations as ``fits.throw`` (see its module docstring), integrated with
``scipy.integrate.solve_ivp``. Each axis is integrated on its own; the vertical axis in
two phases, each with its own smooth law, the apex (vy = 0) found as a terminal event.
This is what the closed forms are tested against and what ``vidtrack bench model``
times them against.
"""

import numpy as np
from scipy.integrate import solve_ivp

from fits.throw.closed_form import G_STANDARD, _check_params, _check_times

__all__ = ["solve_throw"]

IMPLICIT = ("Radau", "BDF", "LSODA")


def _laws(model, cp):
    """Acceleration laws (y ascent, y descent, drag axis) and their d/dv, per unit k g."""
    if model == "free":
        cp = 0.0
    c2 = cp * cp
    if model == "linear":
        up = (lambda v: -(1.0 + cp * v), lambda v: -cp)
        down = up
        drag = (lambda v, s: -cp * v, lambda v, s: -cp)
    else:
        up = (lambda v: -(1.0 + c2 * v * v), lambda v: -2.0 * c2 * v)
        down = (lambda v: -(1.0 - c2 * v * v), lambda v: 2.0 * c2 * v)
        # the sign s of the velocity is fixed within the flight: v|v| = s v^2
        drag = (lambda v, s: -s * c2 * v * v, lambda v, s: -2.0 * s * c2 * v)
    return up, down, drag


def _integrate(rhs, jac, y0, t0, t_out, method, rtol, atol, events=None):
    """Integrate from t0 to max(t_out) (> t0); return the solution with dense output."""
    t_end = float(t_out.max())
    kwargs = {"jac": jac} if method in IMPLICIT else {}
    sol = solve_ivp(rhs, (t0, t_end), y0, method=method, rtol=rtol,
                    atol=atol, dense_output=True, events=events, **kwargs)
    if sol.status < 0:
        raise RuntimeError(f"solve_ivp ({method}) failed: {sol.message}")
    return sol


def _axis_drag(t, x0, v0, scale, law, frame_speed, method, rtol, atol):
    f, dfdv = law
    s = 1.0 if v0 >= 0 else -1.0

    def rhs(_, u):
        return [u[1] - frame_speed, scale * f(u[1], s)]

    def jac(_, u):
        return [[0.0, 1.0], [0.0, scale * dfdv(u[1], s)]]

    if t.max() <= 0:
        return np.full(t.shape, x0)
    sol = _integrate(rhs, jac, [x0, v0], 0.0, t, method, rtol, atol)
    return sol.sol(t)[0]


def _axis_y(t, y0, vy0, a, d, up, down, method, rtol, atol):
    out = np.full(t.shape, float(y0))        # t = 0, and every t if nothing follows
    t_start, y_start, v_start = 0.0, y0, vy0
    if vy0 > 0:
        f, dfdv = up

        def rhs(_, u):
            return [u[1], a * f(u[1])]

        def jac(_, u):
            return [[0.0, 1.0], [0.0, a * dfdv(u[1])]]

        def top(_, u):
            return u[1]
        top.terminal, top.direction = True, -1
        # integrate far enough to meet the apex (the drag-free apex time bounds it)
        horizon = np.array([vy0 / a * 1.0000001 + 1e-12])
        sol = _integrate(rhs, jac, [y0, vy0], 0.0, horizon, method, rtol, atol,
                            events=top)
        t1 = float(sol.t_events[0][0])
        t_start, y_start, v_start = t1, float(sol.y_events[0][0][0]), 0.0
        asc = t <= t1
        out[asc] = sol.sol(t[asc])[0]
    desc = t > t_start
    if np.any(desc):
        f, dfdv = down

        def rhs(_, u):
            return [u[1], d * f(u[1])]

        def jac(_, u):
            return [[0.0, 1.0], [0.0, d * dfdv(u[1])]]

        sol = _integrate(rhs, jac, [y_start, v_start], t_start, t[desc], method,
                            rtol, atol)
        out[desc] = sol.sol(t[desc])[0]
    return out


def solve_throw(t, state, k, cp, *, g=G_STANDARD, v1=0.0, model="quadratic",
                method="DOP853", rtol=1e-12, atol=1e-14):
    """Positions of the throw by numerical integration of its ODEs.

    Parameters
    ----------
    t, state, k, cp, g, v1, model
        As ``fits.throw.position``.
    method : str, keyword-only
        Any ``solve_ivp`` method ("RK45", "DOP853", "Radau", "BDF", "LSODA"); the
        implicit ones get the exact Jacobian.
    rtol, atol : float, keyword-only
        Tolerances handed to ``solve_ivp``.

    Returns
    -------
    ndarray, shape (N, 3)
        x, y, z in m.

    Raises
    ------
    RuntimeError
        When ``solve_ivp`` reports a failure.
    """
    state, k, cp, g, v1 = _check_params(state, k, cp, g, v1, model)
    t = _check_times(t)
    x0, y0, z0, vx0, vy0, vz0 = state
    k1, k2, k3, k4 = k
    up, down, drag = _laws(model, cp)
    x = _axis_drag(t, x0, vx0, k3 * g, drag, 0.0, method, rtol, atol)
    y = _axis_y(t, y0, vy0, k1 * g, k2 * g, up, down, method, rtol, atol)
    z = _axis_drag(t, z0, vz0, k4 * g, drag, v1, method, rtol, atol)
    return np.column_stack([x, y, z])
