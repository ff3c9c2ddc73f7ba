"""What moves where at time t, in metres: the throws, the straw's pose, the second straw.

World frame (docs/reference.md), z relative to the machine; t in seconds from the release
(negative: before it). Before release (t < 0) the straw rides a tooth of the rotor,
sliding outward; at t = 0 it leaves at the release state and flies on the throw model of
:func:`fits.throw.position`, spinning about a fixed axis (:func:`straw_pose`). The rotor
turns at ``blade_rpm``, or else at the rate at which the straw's velocity is continuous
at release. Replicate throws spread the release speed, direction and k1..k4 at random
(``_make_throws``). The optional second straw leaves the same release point, its centre
meets the main straw's centre at ``second_cross_s`` (:func:`second_straw_state`), and it
tumbles about a tilted axis.
"""

import math
from dataclasses import dataclass

import numpy as np

from vidtrack.synth.spec import _fail

__all__ = ["straw_pose", "second_straw_state"]

# The second straw starts out of the XOY plane and tumbles about a tilted axis, so that
# it crosses the main straw at an angle in both views.
_SECOND_DIRECTION = np.array([0.35, 0.45, 0.82])
_SECOND_AXIS = np.array([0.2, 0.9, 0.4])


@dataclass(frozen=True)
class _Throw:
    """One throw: the release state, k, and the rotor and spin rates."""

    state: tuple
    k: tuple
    blade_rad_s: float
    spin_rad_s: float
    blade_radius_m: float

    @property
    def release_angle_rad(self):
        return math.atan2(self.state[1], self.state[0])

    @property
    def release_radius_m(self):
        return math.hypot(self.state[0], self.state[1])


def _matched_blade_rate(state):
    """Rotor rate (rad/s) at which the straw's tangential speed is continuous at release."""
    x0, y0, _, vx0, vy0, _ = state
    return (x0 * vy0 - y0 * vx0) / (x0 * x0 + y0 * y0)


#: The smallest factor a random spread scales a k by (a k stays > 0).
_MIN_K_FACTOR = 0.2


def _make_throws(spec):
    """The throws of a run: release state and k of each, spread at random (seeded).

    With ``k_spread`` each throw's k is ``k * (1 + k_spread * N(0, 1))`` (one draw per
    coefficient and throw, from a stream of its own), a single throw included;
    ``throw_spread`` then spreads only the release speed and direction.
    """
    rng = np.random.default_rng([spec.seed, 7])
    rng_k = np.random.default_rng([spec.seed, 8])
    out = []
    for _ in range(spec.throws):
        state = np.asarray(spec.state, dtype=np.float64)
        k = np.asarray(spec.k, dtype=np.float64)
        if spec.throws > 1 and spec.throw_spread > 0:
            e = rng.standard_normal(6) * spec.throw_spread
            speed = math.hypot(state[3], state[4]) * (1.0 + e[0])
            angle = math.atan2(state[4], state[3]) + 0.5 * e[1]
            state[3], state[4] = speed * math.cos(angle), speed * math.sin(angle)
            if spec.k_spread is None:
                k = k * np.clip(1.0 + e[2:], _MIN_K_FACTOR, None)
        if spec.k_spread is not None:
            e_k = rng_k.standard_normal(4) * np.asarray(spec.k_spread, dtype=np.float64)
            k = k * np.clip(1.0 + e_k, _MIN_K_FACTOR, None)
        state_t = tuple(float(v) for v in state)
        blade = (_matched_blade_rate(state_t) if spec.blade_rpm is None
                 else spec.blade_rpm * math.pi / 30.0)
        spin = blade if spec.spin_rad_s is None else float(spec.spin_rad_s)
        radius = (spec.blade_radius_m if spec.blade_radius_m is not None
                  else math.hypot(state_t[0], state_t[1]))
        out.append(_Throw(state=state_t, k=tuple(float(v) for v in k), blade_rad_s=blade,
                          spin_rad_s=spin, blade_radius_m=float(radius)))
    return out


def _rotate(d0, axis, angle):
    """Rodrigues: unit vector ``d0`` turned by ``angle`` (array) about unit ``axis``."""
    angle = np.asarray(angle, dtype=np.float64)[:, None]
    kx = np.cross(axis, d0)
    return (d0[None, :] * np.cos(angle) + kx[None, :] * np.sin(angle)
            + axis[None, :] * float(axis @ d0) * (1.0 - np.cos(angle)))


def straw_pose(t, throw_state, k, *, spec, blade_rad_s, spin_rad_s):
    """Centre (m) and unit direction of the main straw's rod at times ``t`` (s).

    Parameters
    ----------
    t : array_like
        Times relative to release (negative: before).
    throw_state, k : sequence
        Release state (x0, y0, z0, vx0, vy0, vz0) and (k1, k2, k3, k4).
    spec : SynthSpec, keyword-only
    blade_rad_s, spin_rad_s : float, keyword-only
        Rotor rate and spin rate after release, rad/s.

    Returns
    -------
    centre, direction : numpy.ndarray, shape (N, 3)
        World frame; z relative to the machine.

    Notes
    -----
    t >= 0: :func:`fits.throw.position`. t < 0: the straw rides a tooth that turns at
    ``blade_rad_s`` about the shaft, lying along it, its centre at radius
    ``max(rho0 + v_r t, rho0 / 2)`` (rho0 the release radius, v_r the radial part of
    the release velocity), at z = z0; the pose is continuous at t = 0.
    """
    from fits.throw import position

    t = np.atleast_1d(np.asarray(t, dtype=np.float64)).ravel()
    state = np.asarray(throw_state, dtype=np.float64)
    centre = np.empty((t.size, 3))
    direction = np.empty((t.size, 3))
    phi0 = math.atan2(state[1], state[0])
    d0 = np.array([math.cos(phi0), math.sin(phi0), 0.0])
    after = t >= 0
    if np.any(after):
        centre[after] = position(t[after], state, k, spec.cp_s_per_m, g=spec.gravity_m_s2,
                                 v1=spec.v1_m_s, model=spec.model)
        axis = np.asarray(spec.spin_axis, dtype=np.float64)
        axis = axis / np.linalg.norm(axis)
        direction[after] = _rotate(d0, axis, spin_rad_s * t[after])
    before = ~after
    if np.any(before):
        rho0 = math.hypot(state[0], state[1])
        v_r = (state[0] * state[3] + state[1] * state[4]) / rho0
        tb = t[before]
        rho = np.maximum(rho0 + v_r * tb, 0.5 * rho0)
        phi = phi0 + blade_rad_s * tb
        centre[before] = np.column_stack([rho * np.cos(phi), rho * np.sin(phi),
                                          np.full(tb.size, state[2])])
        direction[before] = np.column_stack([np.cos(phi), np.sin(phi), np.zeros(tb.size)])
    return centre, direction


def second_straw_state(spec, throw):
    """Release state and release time (main clock) of the second straw.

    It leaves the main straw's release point ``second_flight_s`` before
    ``second_cross_s`` with the velocity (found per axis by root finding on
    :func:`fits.throw.position`) that puts its centre on the main straw's centre at
    ``second_cross_s``.

    Returns
    -------
    state : tuple of 6 float
    t_release_s : float
    """
    from scipy.optimize import brentq

    from fits.throw import position

    target = position([spec.second_cross_s], throw.state, throw.k, spec.cp_s_per_m,
                      g=spec.gravity_m_s2, v1=spec.v1_m_s, model=spec.model)[0]
    dt = spec.second_flight_s
    x0, y0, z0 = throw.state[:3]
    vel = []
    for axis in range(3):
        def miss(v, axis=axis):
            st = [x0, y0, z0, 0.0, 0.0, spec.v1_m_s]
            st[3 + axis] = v
            p = position([dt], st, throw.k, spec.cp_s_per_m, g=spec.gravity_m_s2,
                         v1=spec.v1_m_s, model=spec.model)[0]
            return p[axis] - target[axis]
        lo, hi = -200.0, 200.0
        if miss(lo) > 0 or miss(hi) < 0:
            _fail(f"no second straw can reach the main straw at second_cross_s = "
                  f"{spec.second_cross_s} s after flying second_flight_s = {dt} s")
        vel.append(brentq(miss, lo, hi, xtol=1e-13, rtol=1e-14))
    return (x0, y0, z0, *vel), spec.second_cross_s - dt


def _second_pose(t, spec, throw, state2, t2):
    from fits.throw import position

    t = np.asarray(t, dtype=np.float64).ravel()
    centre = np.full((t.size, 3), np.nan)
    direction = np.full((t.size, 3), np.nan)
    live = t >= t2
    if np.any(live):
        tau = t[live] - t2
        centre[live] = position(tau, state2, throw.k, spec.cp_s_per_m, g=spec.gravity_m_s2,
                                v1=spec.v1_m_s, model=spec.model)
        d0 = _SECOND_DIRECTION / np.linalg.norm(_SECOND_DIRECTION)
        axis = _SECOND_AXIS / np.linalg.norm(_SECOND_AXIS)
        direction[live] = _rotate(d0, axis, -0.8 * throw.spin_rad_s * tau)
    return centre, direction
