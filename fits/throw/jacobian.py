"""Derivatives of the closed forms with respect to their parameters, in closed form.

The least-squares fit (:mod:`fits.lsq`) needs, at every time, the derivative of one axis's
position with respect to that axis's parameters: ``(x0, v0, kd)`` for
:func:`~fits.throw.flight_drag`, ``(y0, vy0, k1, k2)`` for :func:`~fits.throw.flight_y`.
Two facts give them without differencing:

- A coefficient k scales its law, dv/dt = -k g f(v) with f free of k, so at a fixed
  starting speed time runs as k t: a phase's displacement s(t) with velocity v(t) has
  ``ds/dk = (v t - s) / k``.
- The displacement's derivative with respect to the starting speed v0 is the integral
  of dv/dv0; per law (s = k g cp t, p = cp v0)::

      quadratic ascent:   t tan(s)/s / (1 + p tan s)
      quadratic descent:  t tanh(s)/s / (1 - p tanh s)        (v0 <= 0)
      quadratic, x and z: t / (1 + k g cp^2 |v0| t)
      linear (any axis):  t expm1(-s)/(-s)

The descent of :func:`~fits.throw.flight_y` starts at the apex (t1, y1), which moves with
vy0 and k1: its columns follow by the chain rule, with dt1/dvy0 = 1 / (k1 g (1 + p^2))
(linear: 1 / (k1 g (1 + p))), dy1/dvy0 the ascent's at t1, and t1, y1 scaling as 1/k1.
Every form is evaluated with the same stable ratios as the positions (cp = 0 included);
``tests/test_throw_jacobian.py`` checks them against central differences.
"""

import numpy as np

from fits.throw import _stable as st
from fits.throw.closed_form import (G_STANDARD, _apex_linear, _apex_quadratic,
                                    _ascent_quadratic, _descent_quadratic, _linear_pos,
                                    _linear_vel)

__all__ = ["flight_y_jacobian", "flight_drag_jacobian"]


def _speed_sensitivity(t, v0, a, cp, law):
    """d(displacement)/d(v0) after ``t`` s of one phase at effective gravity ``a``.

    ``law`` is ``"ascent"`` or ``"descent"`` (quadratic drag; v0 <= 0 for the descent)
    or ``"linear"``.
    """
    s = a * cp * t
    if law == "linear":
        return t * st.expm1_ratio(-s)
    if law == "ascent":
        return t * st.tanc(s) / (1.0 + cp * v0 * np.tan(s))
    return t * st.tanhc(s) / (1.0 - cp * v0 * np.tanh(s))


def _phi1_minus_phi2(z):
    """``expm1_ratio(z) - expm1_ratio2(z)`` for z <= 0, without cancelling for large -z."""
    phi1 = st.expm1_ratio(z)
    with np.errstate(divide="ignore", invalid="ignore"):      # z = 0 takes the other side
        return np.where(z < -1.0, (np.exp(z) - phi1) / z, phi1 - st.expm1_ratio2(z))


def _phase(t, v0, a, cp, linear, ascent):
    """Velocity ``v`` and ``v t - s`` (s the displacement) of one phase of ``flight_y``.

    ``v t - s`` is what the phase's coefficient scales (``ds/dk = (v t - s) / k``). Past
    the terminal speed v t and s grow alike and their difference stays bounded, so it is
    computed in a form that does not cancel: linear, -a t^2 (1 + cp v0) (phi1 - phi2);
    a quadratic descent at u = a cp t > 1, (lam + u (1 - w0) (1 - tanh u) /
    (1 + w0 tanh u)) / (a cp^2) with w0 = -cp v0 and lam as in the descent's position.
    """
    if linear:
        v = _linear_vel(t, v0, a, cp)
        return v, -a * t * t * (1.0 + cp * v0) * _phi1_minus_phi2(-a * cp * t)
    s, v = (_ascent_quadratic if ascent else _descent_quadratic)(t, v0, a, cp)
    gap = v * t - s
    u = a * cp * t
    far = u > 1.0
    if not ascent and np.any(far):
        w0, uf = -cp * v0, u[far]
        lam = np.log1p(0.5 * (w0 - 1.0)) + np.log1p((1.0 - w0) / (1.0 + w0) * np.exp(-2.0 * uf))
        th = np.tanh(uf)
        gap[far] = (lam + uf * (1.0 - w0) * (1.0 - th) / (1.0 + w0 * th)) / (a * cp * cp)
    return v, gap


def flight_y_jacobian(t, y0, vy0, k1, k2, cp, *, g=G_STANDARD, model="quadratic"):
    """Derivatives of :func:`~fits.throw.flight_y`'s height with respect to its parameters.

    Parameters
    ----------
    t, y0, vy0, k1, k2, cp, g, model
        As :func:`fits.throw.flight_y`.

    Returns
    -------
    numpy.ndarray, shape (N, 4)
        Columns dy/dy0, dy/dvy0 (s), dy/dk1 and dy/dk2 (m) at each ``t``.
    """
    t = np.asarray(t, dtype=float)
    if model == "free":
        cp, model = 0.0, "quadratic"
    linear = model == "linear"
    a, d = k1 * g, k2 * g
    jac = np.zeros(t.shape + (4,))
    jac[:, 0] = 1.0
    if vy0 > 0:
        t1, rise1 = (_apex_linear if linear else _apex_quadratic)(vy0, a, cp)
        up = t <= t1
        law = "linear" if linear else "ascent"
        _, gap = _phase(t[up], vy0, a, cp, linear, ascent=True)
        jac[up, 1] = _speed_sensitivity(t[up], vy0, a, cp, law)
        jac[up, 2] = gap / k1
        p = cp * vy0
        t1_vy0 = 1.0 / (a * (1.0 + (p if linear else p * p)))
        y1_vy0 = _speed_sensitivity(np.array([t1]), vy0, a, cp, law)[0]
        down = ~up
        tau, va = t[down] - t1, 0.0
    else:
        down = np.ones(t.shape, dtype=bool)
        tau, va = t, vy0
    v, gap = _phase(tau, va, d, cp, linear, ascent=False)
    if vy0 > 0:
        # the apex moves: dt1/dk1 = -t1/k1 and dy1/dk1 = -rise1/k1
        jac[down, 1] = y1_vy0 - v * t1_vy0
        jac[down, 2] = (v * t1 - rise1) / k1
    else:
        jac[down, 1] = _speed_sensitivity(tau, va, d, cp, "linear" if linear else "descent")
    jac[down, 3] = gap / k2
    return jac


def flight_drag_jacobian(t, x0, v0, kd, cp, *, g=G_STANDARD, model="quadratic"):
    """Derivatives of :func:`~fits.throw.flight_drag`'s position w.r.t. ``(x0, v0, kd)``.

    Parameters
    ----------
    t, x0, v0, kd, cp, g, model
        As :func:`fits.throw.flight_drag` (the frame's speed moves every position alike,
        so it does not enter).

    Returns
    -------
    numpy.ndarray, shape (N, 3)
        Columns dx/dx0, dx/dv0 (s) and dx/dkd (m) at each ``t``.
    """
    t = np.asarray(t, dtype=float)
    if model == "free":
        cp = 0.0
    jac = np.empty(t.shape + (3,))
    jac[:, 0] = 1.0
    if model == "linear":
        z = -kd * g * cp * t
        jac[:, 1] = t * st.expm1_ratio(z)
        # v t - s = v0 t (exp(z) - phi1(z)) = v0 t z (phi1 - phi2)
        jac[:, 2] = v0 * t * z * _phi1_minus_phi2(z) / kd
    else:
        e = kd * g * cp * cp * abs(v0) * t
        jac[:, 1] = t / (1.0 + e)
        # v t - s = v0 t (1/(1 + e) - log1p(e)/e), with the 1s taken out where they cancel
        gap = np.where(e > 1.0, 1.0 / (1.0 + e) - st.log1p_ratio(e),
                       -e / (1.0 + e) - st.log1p_ratio_m1(e))
        jac[:, 2] = v0 * t * gap / kd
    return jac
