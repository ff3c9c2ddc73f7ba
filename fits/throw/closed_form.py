"""Flight of a thrown straw after release: stable closed forms of the throw models.

World frame (docs/reference.md): origin at the blade shaft, x outward, y up, z along the
machine's travel; t = 0 at release; SI units. The machine (and the cameras) move at
``v1`` along +z, so z is relative to the machine.

Three models share one interface:

``"quadratic"`` (Chen et al. 2018, eqs. 11-18), each axis its own ODE with a drag
parameter ``cp`` (s/m, 1/cp is the terminal speed) and correction coefficients k1..k4::

    ascent  (vy > 0):  dvy/dt = -k1 g (1 + cp^2 vy^2)
    descent (vy <= 0): dvy/dt = -k2 g (1 - cp^2 vy^2)
    x:                 dvx/dt = -k3 g cp^2 vx |vx|
    z (absolute):      dvz/dt = -k4 g cp^2 vz |vz|,   z = z_abs - v1 t

``"linear"`` (Liao et al. 2021, eqs. 15-18, with the same meaning of k and cp: k scales
gravity and drag alike, 1/cp is the terminal speed)::

    ascent:  dvy/dt = -k1 g (1 + cp vy)      descent: dvy/dt = -k2 g (1 + cp vy)
    x:       dvx/dt = -k3 g cp vx            z:       dvz/dt = -k4 g cp vz

Liao's ``m x'' = -k x'`` is k1 = k2 = k3 = 1 with cp = k_Liao / (m g).

``"free"`` (Hou et al. 2019, eq. 3): no drag; k1 and k2 scale gravity in ascent and
descent, k3 and k4 have no effect. It is the quadratic model at cp = 0, computed as such.

The printed solutions overflow, cancel or divide by zero outside the paper's own case
(docs/throw-models.md). The forms here are rewritten with exact identities so that every
cp >= 0 (cp = 0 included), every k > 0, long times, both signs of vx0 and vy0 and
downward speeds beyond the terminal speed are evaluated to a few ulp of the terms
involved; ``tests/test_throw.py`` checks them against ``fits.throw.ode``.
"""

from dataclasses import dataclass

import numpy as np

from fits.throw import _stable as st
from fits.errors import InputError

G_STANDARD = 9.80665
MODELS = ("quadratic", "linear", "free")

__all__ = ["G_STANDARD", "MODELS", "Apex", "apex", "position", "velocity",
           "terminal_speed", "flight_y", "flight_drag"]


# ---------------------------------------------------------------- validation

def _finite(name, value):
    value = float(value)
    if not np.isfinite(value):
        raise InputError(f"{name} must be finite, got {value}")
    return value


def _check_params(state, k, cp, g, v1, model):
    if model not in MODELS:
        raise InputError(f"model must be one of {', '.join(MODELS)}, got {model!r}")
    state = np.asarray(state, dtype=float).reshape(-1)
    if state.shape != (6,):
        raise InputError("state must be (x0, y0, z0, vx0, vy0, vz0), "
                         f"got {state.size} values")
    names = ("x0", "y0", "z0", "vx0", "vy0", "vz0")
    for name, value in zip(names, state):
        _finite(f"state {name}", value)
    k = np.asarray(k, dtype=float).reshape(-1)
    if k.shape != (4,):
        raise InputError(f"k must be (k1, k2, k3, k4), got {k.size} values")
    for i, value in enumerate(k, start=1):
        if not np.isfinite(value) or value <= 0:
            raise InputError(f"k{i} must be finite and > 0, got {value}")
    cp = _finite("cp", cp)
    if cp < 0:
        raise InputError(f"cp must be >= 0 s/m, got {cp}")
    g = _finite("g", g)
    if g <= 0:
        raise InputError(f"g must be > 0 m/s^2, got {g}")
    v1 = _finite("v1", v1)
    return state, k, cp, g, v1


def _check_times(t):
    t = np.asarray(t, dtype=float)
    if t.ndim > 1:
        raise InputError(f"t must be a 1-D array of times, got shape {t.shape}")
    t = np.atleast_1d(t)
    if not np.all(np.isfinite(t)):
        raise InputError("t must be finite")
    if np.any(t < 0):
        raise InputError(f"t must be >= 0 s (t = 0 is the release), got min {t.min()}")
    return t


# ---------------------------------------------------------------- the vertical axis

@dataclass(frozen=True)
class Apex:
    """The top of the ascent: time ``t_s`` after release and height ``y_m``."""

    t_s: float
    y_m: float

    def to_dict(self):
        return {"t_s": self.t_s, "y_m": self.y_m}


def _apex_quadratic(vy0, a, cp):
    """Apex time and rise for an ascent at effective gravity ``a`` (= k1 g)."""
    p = np.array([cp * vy0])
    t1 = vy0 / a * st.atanc(p)[0]
    rise = vy0 * vy0 / (2.0 * a) * st.log1p_ratio(p * p)[0]
    return t1, rise


def _apex_linear(vy0, a, cp):
    p = np.array([cp * vy0])
    t1 = vy0 / a * st.log1p_ratio(p)[0]
    rise = _linear_pos(np.array([t1]), vy0, a, cp)[0]
    return t1, rise


def _ascent_quadratic(t, vy0, a, cp):
    """Rise and velocity during the ascent (eq. 12 rewritten), for 0 <= t <= t1."""
    s = a * cp * t
    q = vy0 * t * st.sinc(s) - 0.5 * a * t * t * st.sinc(0.5 * s) ** 2
    rise = q * st.log1p_ratio(a * cp * cp * q)
    p = cp * vy0
    vel = (vy0 - a * t * st.tanc(s)) / (1.0 + p * np.tan(s))
    return rise, vel


def _descent_quadratic(tau, va, d, cp):
    """Drop and velocity after ``tau`` s of descent from speed ``va`` <= 0.

    ln(cosh u + w0 sinh u) / (d cp^2) with u = d cp tau and w0 = cp |va| covers the
    tanh branch (w0 < 1), the terminal speed (w0 = 1) and the coth branch (w0 > 1).
    Small u: log1p with the 1/cp^2 divided out exactly (no cancellation as cp -> 0);
    large u: the asymptotic form, which cannot overflow.
    """
    speed = -va
    w0 = cp * speed
    u = d * cp * tau
    drop = np.empty_like(tau)
    small = u <= 1.0
    ts, us = tau[small], u[small]
    q = 0.5 * d * ts * ts * st.sinhc(0.5 * us) ** 2 + speed * ts * st.sinhc(us)
    drop[small] = q * st.log1p_ratio(d * cp * cp * q)
    if np.any(~small):
        ul = u[~small]
        lam = np.log1p(0.5 * (w0 - 1.0)) + np.log1p((1.0 - w0) / (1.0 + w0) * np.exp(-2.0 * ul))
        drop[~small] = (ul + lam) / (d * cp * cp)
    vel = -(d * tau * st.tanhc(u) + speed) / (1.0 + w0 * np.tanh(u))
    return -drop, vel


def _linear_pos(t, v0, a, cp):
    """Displacement under dv/dt = -a (1 + cp v) from speed v0 after t s."""
    z = -a * cp * t
    return v0 * t * st.expm1_ratio(z) - a * t * t * st.expm1_ratio2(z)


def _linear_vel(t, v0, a, cp):
    z = -a * cp * t
    return v0 * np.exp(z) - a * t * st.expm1_ratio(z)


def flight_y(t, y0, vy0, k1, k2, cp, *, g=G_STANDARD, model="quadratic"):
    """Height and vertical velocity of the throw: ascent with k1, then descent with k2.

    Parameters
    ----------
    t : array_like
        Times after release, s (>= 0, any order).
    y0, vy0 : float
        Height (m) and vertical velocity (m/s) at release. vy0 <= 0 means no ascent.
    k1, k2 : float
        Correction coefficients of the ascent and the descent (> 0).
    cp : float
        Drag parameter, s/m (>= 0; 0 is the drag-free throw).
    g : float, keyword-only
        Gravity, m/s^2.
    model : {"quadratic", "linear", "free"}, keyword-only

    Returns
    -------
    y, vy : ndarray
        Height in m and vertical velocity in m/s at each ``t``.

    Notes
    -----
    Chen et al. 2018 eqs. 12 and 14 (quadratic); Liao et al. 2021 eqs. 16-18 (linear).
    The apex is at ``apex(...)``; the descent starts there with vy = 0.
    """
    t = np.asarray(t, dtype=float)
    if model == "free":
        cp, model = 0.0, "quadratic"
    a, d = k1 * g, k2 * g
    y = np.empty_like(t)
    vy = np.empty_like(t)
    if vy0 > 0:
        t1, rise = (_apex_quadratic if model == "quadratic" else _apex_linear)(vy0, a, cp)
        up = t <= t1
        if model == "quadratic":
            r, v = _ascent_quadratic(t[up], vy0, a, cp)
        else:
            r, v = _linear_pos(t[up], vy0, a, cp), _linear_vel(t[up], vy0, a, cp)
        y[up], vy[up] = y0 + r, v
        down = ~up
        tau, ya, va = t[down] - t1, y0 + rise, 0.0
    else:
        down = np.ones(t.shape, dtype=bool)
        tau, ya, va = t, y0, vy0
    if model == "quadratic":
        r, v = _descent_quadratic(tau, va, d, cp)
    else:
        r, v = _linear_pos(tau, va, d, cp), _linear_vel(tau, va, d, cp)
    y[down], vy[down] = ya + r, v
    return y, vy


# ---------------------------------------------------------------- horizontal axes

def flight_drag(t, x0, v0, kd, cp, *, g=G_STANDARD, model="quadratic", frame_speed=0.0):
    """Position and velocity along a horizontal axis with drag only (x with k3, z with k4).

    Parameters
    ----------
    t : array_like
        Times after release, s.
    x0, v0 : float
        Position (m, in the moving frame) and absolute velocity (m/s) at release.
    kd : float
        Correction coefficient (k3 for x, k4 for z), > 0.
    cp : float
        Drag parameter, s/m (>= 0).
    g : float, keyword-only
    model : {"quadratic", "linear", "free"}, keyword-only
    frame_speed : float, keyword-only
        Speed of the measuring frame along the axis (v1 for z, 0 for x), m/s.

    Returns
    -------
    pos, vel : ndarray
        Position relative to the moving frame (m) and absolute velocity (m/s).

    Notes
    -----
    Quadratic: x = x0 + v0 t ln(1 + b|v0|t) / (b|v0|t), b = kd g cp^2 (Chen 2018
    eqs. 16 and 18, with the sign of v0 honoured). Where drag is weak the drag's loss
    ``v0 t (L - 1)`` is carried beside ``(v0 - frame_speed) t`` so that z keeps its
    relative accuracy when the straw moves with the machine; where it is strong,
    ``v0 t L`` is used directly so nothing cancels.
    """
    t = np.asarray(t, dtype=float)
    if model == "free":
        cp = 0.0
    if model == "linear":
        z = -kd * g * cp * t
        ratio, ratio_m1 = st.expm1_ratio(z), z * st.expm1_ratio2(z)    # phi1, phi1 - 1
        vel = v0 * np.exp(z)
    else:
        e = kd * g * cp * cp * abs(v0) * t
        ratio, ratio_m1 = st.log1p_ratio(e), st.log1p_ratio_m1(e)
        vel = v0 / (1.0 + e)
    # weak drag: the travel relative to the frame, without cancelling v0 t against
    # frame_speed t; strong drag: the travel itself, without cancelling v0 t against
    # the drag's loss
    weak = ratio > 0.5
    travel = np.where(weak, (v0 - frame_speed) * t + v0 * t * ratio_m1,
                      v0 * t * ratio - frame_speed * t)
    return x0 + travel, vel


# ---------------------------------------------------------------- public API

def _evaluate(t, state, k, cp, g, v1, model):
    state, k, cp, g, v1 = _check_params(state, k, cp, g, v1, model)
    t = _check_times(t)
    x0, y0, z0, vx0, vy0, vz0 = state
    k1, k2, k3, k4 = k
    x, vx = flight_drag(t, x0, vx0, k3, cp, g=g, model=model)
    y, vy = flight_y(t, y0, vy0, k1, k2, cp, g=g, model=model)
    z, vz = flight_drag(t, z0, vz0, k4, cp, g=g, model=model, frame_speed=v1)
    return np.column_stack([x, y, z]), np.column_stack([vx, vy, vz])


def position(t, state, k, cp, *, g=G_STANDARD, v1=0.0, model="quadratic"):
    """Position of the straw at times ``t`` after release, by the stable closed form.

    Parameters
    ----------
    t : array_like, shape (N,)
        Times after release, s (>= 0, any order).
    state : sequence of 6 floats
        ``(x0, y0, z0, vx0, vy0, vz0)`` at t = 0, m and m/s; ``vz0`` is the straw's
        absolute forward speed, z0 is relative to the machine.
    k : sequence of 4 floats
        ``(k1, k2, k3, k4)``, each > 0. For ``model="free"`` k3 and k4 have no effect.
    cp : float
        Drag parameter Cp = sqrt(C a_s rho / (2 m g)), s/m, >= 0 (0: no drag).
    g : float, keyword-only
        Gravity, m/s^2.
    v1 : float, keyword-only
        The machine's travel speed, m/s; z(t) = z0 + (absolute forward travel) - v1 t.
    model : {"quadratic", "linear", "free"}, keyword-only
        The drag law (see the module docstring).

    Returns
    -------
    ndarray, shape (N, 3)
        x, y, z in m (float64).

    Raises
    ------
    fits.errors.InputError (a ValueError)
        cp < 0, k <= 0, non-finite values, negative times, an unknown model.

    Examples
    --------
    >>> position([0.0, 0.1], (0.25, 0.15, 0, 7.0, 4.5, 2.0), (2.2, 2.5, 4.6, 21.3), 0.115,
    ...          v1=2.0).round(4)
    array([[ 0.25  ,  0.15  ,  0.    ],
           [ 0.8349,  0.4727, -0.0408]])
    """
    return _evaluate(t, state, k, cp, g, v1, model)[0]


def velocity(t, state, k, cp, *, g=G_STANDARD, v1=0.0, model="quadratic"):
    """Absolute velocity (vx, vy, vz) in m/s at times ``t``; arguments as ``position``.

    The z component is the straw's absolute forward speed (not relative to the machine).
    """
    return _evaluate(t, state, k, cp, g, v1, model)[1]


def apex(state, k, cp, *, g=G_STANDARD, model="quadratic"):
    """The top of the ascent, or None when the straw is not thrown upward (vy0 <= 0).

    Quadratic: t1 = atan(cp vy0) / (k1 g cp), y1 = y0 + ln(1 + cp^2 vy0^2) / (2 k1 g cp^2)
    (Chen 2018, after eq. 12), evaluated without dividing by cp.
    """
    state, k, cp, g, _ = _check_params(state, k, cp, g, 0.0, model)
    y0, vy0 = state[1], state[4]
    if vy0 <= 0:
        return None
    a = k[0] * g
    if model == "free":
        cp, model = 0.0, "quadratic"
    t1, rise = (_apex_quadratic if model == "quadratic" else _apex_linear)(vy0, a, cp)
    return Apex(t_s=float(t1), y_m=float(y0 + rise))


def terminal_speed(cp):
    """Terminal (downward) speed 1/cp in m/s; ``inf`` for cp = 0 (no drag)."""
    cp = _finite("cp", cp)
    if cp < 0:
        raise InputError(f"cp must be >= 0 s/m, got {cp}")
    return np.inf if cp == 0 else 1.0 / cp
