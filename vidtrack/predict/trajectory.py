"""The predicted 3-D throw from the release to the ground or an inlet plane (Chen 2018, s. 4).

Step 3 of the chain of section 4 (:mod:`vidtrack.predict.forward`): the throw
(``fits.throw.position``, eqs. 11-19) from a release state and k1..k4 until the straw
reaches the ground plane ``y = -H`` (H: the shaft's height above the ground) or a given
vertical inlet plane (:func:`throw_trajectory`); with the variances of the k's, the
pointwise 95 % band by linearisation. Also the straw drag parameter Cp
(:func:`drag_parameter`) and the flight helpers the device placement
(:mod:`vidtrack.predict.placement`) shares.

Every length is in m, in the world frame (docs/reference.md: origin at the blade shaft, x outward,
y up, z along travel, z relative to the machine).
"""

import math
from dataclasses import dataclass

import numpy as np

from fits.blade import G_STANDARD
from fits.errors import InputError
from vidtrack.predict.coefficients import _Z95

#: Default straw drag parameter, s/m: Cp = sqrt(C a_s rho / (2 m g)) with C = 1.0,
#: a_s = 0.0172 m^2 (the paper's mean straw, 25.7 mm x 669.3 mm, section 3.2),
#: rho = 1.205 kg/m^3 and an assumed mass m = 0.080 kg (not published): 0.1149 s/m.
DEFAULT_CP_S_PER_M = 0.115

__all__ = ["DEFAULT_CP_S_PER_M", "drag_parameter", "Trajectory", "throw_trajectory"]


def drag_parameter(mass_kg, area_m2, *, drag_coefficient=1.0, air_density_kg_m3=1.205,
                   g=G_STANDARD):
    """Cp = sqrt(C a_s rho / (2 m g)), s/m (Chen 2018, after eq. 12).

    Raises
    ------
    fits.errors.InputError
        A mass or area that is not > 0, or a negative C or density.
    """
    for name, v in (("mass_kg", mass_kg), ("area_m2", area_m2)):
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"{name} must be > 0, got {v}")
    for name, v in (("drag_coefficient", drag_coefficient),
                    ("air_density_kg_m3", air_density_kg_m3)):
        if not (math.isfinite(v) and v >= 0):
            raise InputError(f"{name} must be >= 0, got {v}")
    return math.sqrt(drag_coefficient * area_m2 * air_density_kg_m3 / (2.0 * mass_kg * g))


@dataclass(frozen=True)
class Trajectory:
    """The predicted flight from release to its end (the ground or an inlet plane).

    Attributes
    ----------
    t_s : ndarray (N,)
    xyz_m : ndarray (N, 3)
        Positions in the world frame (z relative to the machine).
    end : str
        ``"ground"`` (y = -H) or ``"inlet"`` (x = the inlet plane).
    t_end_s : float
    apex : dict or None
        ``{"t_s", "x_m", "y_m"}`` of the highest point, None when there is no ascent
        or it lies beyond the end.
    y_sd_at_x_m, z_sd_at_x_m : ndarray (N,) or None
        Linearised standard deviation of the height and of z across the path at each
        point's x (from the k covariance); None without covariance.
    end_sd_m : dict or None
        Standard deviation of the end point's free coordinates (x and z at the ground;
        y and z at an inlet plane).
    """

    t_s: np.ndarray
    xyz_m: np.ndarray
    end: str
    t_end_s: float
    cp_s_per_m: float
    v1_m_s: float
    shaft_height_m: float
    apex: object = None
    y_sd_at_x_m: object = None
    z_sd_at_x_m: object = None
    end_sd_m: object = None

    def __repr__(self):
        end = ", ".join(f"{v:.4g}" for v in self.end_point_m)
        band = "" if self.y_sd_at_x_m is None else ", with band"
        return (f"Trajectory(end={self.end!r}, t_end_s={self.t_end_s:.4g}, "
                f"end_point_m=({end}), points={len(self.t_s)}{band})")

    @property
    def end_point_m(self):
        """``(x, y, z)`` at the end."""
        return tuple(float(v) for v in self.xyz_m[-1])

    def to_dict(self):
        """Plain JSON-ready values; the 95 % band is ``value +- 1.96 sd`` at each x."""
        x, y, z = self.xyz_m.T
        d = {"end": self.end, "t_end_s": self.t_end_s,
             "end_point_m": dict(zip("xyz", self.end_point_m)),
             "apex": self.apex, "cp_s_per_m": self.cp_s_per_m, "v1_m_s": self.v1_m_s,
             "shaft_height_m": self.shaft_height_m, "ground_y_m": -self.shaft_height_m,
             "t_s": self.t_s.tolist(), "x_m": x.tolist(), "y_m": y.tolist(),
             "z_m": z.tolist(), "band95": None, "end_sd_m": self.end_sd_m}
        if self.y_sd_at_x_m is not None:
            d["band95"] = {"y_m_low": (y - _Z95 * self.y_sd_at_x_m).tolist(),
                           "y_m_high": (y + _Z95 * self.y_sd_at_x_m).tolist(),
                           "z_m_low": (z - _Z95 * self.z_sd_at_x_m).tolist(),
                           "z_m_high": (z + _Z95 * self.z_sd_at_x_m).tolist(),
                           "meaning": "pointwise 95 % band of y and z at each x of the "
                                      "path, from the k covariance (linearised)"}
        return d


class _Flight:
    """The throw for one release state and k, with its k-derivatives by central differences."""

    def __init__(self, state, k, cp, *, v1, g, k_variance=None):
        from fits import throw

        self._throw = throw
        self.state, self.k, self.cp, self.v1, self.g = state, tuple(k), cp, v1, g
        self.k_variance = k_variance

    def pos(self, t, k=None):
        return self._throw.position(np.atleast_1d(np.asarray(t, dtype=float)), self.state,
                                    self.k if k is None else k, self.cp, g=self.g, v1=self.v1)

    def vel(self, t):
        v = self._throw.velocity(np.atleast_1d(np.asarray(t, dtype=float)), self.state,
                                 self.k, self.cp, g=self.g, v1=self.v1)
        v[:, 2] -= self.v1                 # z relative to the machine
        return v

    def jacobian(self, t):
        """d position / d k_j, shape (N, 3, 4), by central differences (h = 1e-5 k)."""
        out = np.empty((np.size(t), 3, 4))
        for j in range(4):
            h = 1e-5 * self.k[j]
            up, dn = list(self.k), list(self.k)
            up[j] += h
            dn[j] -= h
            out[:, :, j] = (self.pos(t, up) - self.pos(t, dn)) / (2 * h)
        return out

    def sd_across(self, t, axis_along, axes):
        """Linearised sd of ``axes`` at fixed coordinate ``axis_along`` (moving along the
        path to keep it fixed), shape (N, len(axes))."""
        jac = self.jacobian(t)
        vel = self.vel(t)
        var_k = np.asarray(self.k_variance)
        out = []
        for a in axes:
            with np.errstate(divide="ignore", invalid="ignore"):
                slope = vel[:, a] / vel[:, axis_along]
            g = jac[:, a, :] - slope[:, None] * jac[:, axis_along, :]
            out.append(np.sqrt(np.sum(g * g * var_k, axis=1)))
        return np.column_stack(out)


def _first_crossing(func, t_lo, t_hi, *, n=513):
    """First t in [t_lo, t_hi] where func (vectorised) goes from < 0 to >= 0, or nan."""
    from scipy.optimize import brentq

    grid = np.linspace(t_lo, t_hi, n)
    vals = func(grid)
    idx = np.flatnonzero((vals[:-1] < 0) & (vals[1:] >= 0))
    if idx.size == 0:
        return math.nan
    i = int(idx[0])
    if vals[i + 1] == 0:
        return float(grid[i + 1])
    return float(brentq(lambda t: float(func(np.array([t]))[0]), grid[i], grid[i + 1],
                        xtol=1e-14, rtol=1e-13, maxiter=200))


def _ground_time(flight, ground_y):
    span = 1.0
    while span <= 1000.0:
        t = _first_crossing(lambda tt: ground_y - flight.pos(tt)[:, 1], 0.0, span)
        if math.isfinite(t):
            return t
        span *= 4.0
    raise InputError(f"the straw does not come down to the ground plane y = {ground_y:g} m "
                     "within 1000 s")


def _check_release_above_ground(state, shaft_height_m):
    if state[1] <= -shaft_height_m:
        raise InputError(
            f"the release point y0 = {state[1]:.4g} m lies at or below the ground plane "
            f"y = {-shaft_height_m:.4g} m (shaft height {shaft_height_m:g} m): the tip "
            "releases the straw in the soil; raise the shaft height or change the phase")


def throw_trajectory(state, k, cp, *, v1_m_s, shaft_height_m, inlet_x_m=None,
                     k_variance=None, points=101, g=G_STANDARD):
    """The 3-D throw from release until the ground plane or an inlet plane.

    Parameters
    ----------
    state : sequence of 6 floats
        ``(x0, y0, z0, vx0, vy0, vz0)``, m and m/s, vz0 the straw's absolute forward speed.
    k : sequence of 4 floats
    cp : float
        Drag parameter, s/m.
    v1_m_s : float, keyword-only
        Machine speed, m/s.
    shaft_height_m : float, keyword-only
        H, the blade shaft's height above the ground; the ground is ``y = -H``.
    inlet_x_m : float, optional, keyword-only
        Stop where the straw reaches the vertical plane ``x = inlet_x_m`` (if before the
        ground).
    k_variance : sequence of 4 floats, optional, keyword-only
        Variances of k1..k4 (independent); gives the band.
    points : int, keyword-only
        Number of samples (>= 2), evenly spaced in time.

    Returns
    -------
    Trajectory

    Raises
    ------
    fits.errors.InputError
        A release below the ground, k <= 0, an inlet the straw does not reach.
    """
    k = tuple(float(v) for v in k)
    bad = [f"k{i} = {v:.4g}" for i, v in enumerate(k, start=1) if not v > 0]
    if bad:
        raise InputError(f"the regression predicts {', '.join(bad)} at this setting: a "
                         "throw needs every k > 0 (the setting is too far outside the "
                         "design region)")
    if not (math.isfinite(shaft_height_m) and shaft_height_m > 0):
        raise InputError(f"shaft_height_m must be > 0 m, got {shaft_height_m}")
    if int(points) < 2:
        raise InputError(f"points must be >= 2, got {points}")
    _check_release_above_ground(state, shaft_height_m)
    flight = _Flight(state, k, cp, v1=v1_m_s, g=g, k_variance=k_variance)
    t_ground = _ground_time(flight, -shaft_height_m)
    end, t_end = "ground", t_ground
    if inlet_x_m is not None:
        x_end = float(flight.pos(t_ground)[0, 0])
        if inlet_x_m <= state[0]:
            raise InputError(f"the inlet plane x = {inlet_x_m:g} m is not outward of the "
                             f"release point x0 = {state[0]:.4g} m")
        if x_end < inlet_x_m:
            raise InputError(f"the straw lands at x = {x_end:.4g} m, before the inlet plane "
                             f"x = {inlet_x_m:g} m")
        t_end = _first_crossing(lambda tt: flight.pos(tt)[:, 0] - inlet_x_m, 0.0, t_ground)
        end = "inlet"
    t = np.linspace(0.0, t_end, int(points))
    xyz = flight.pos(t)
    xyz[-1] = flight.pos(t_end)[0]
    from fits import throw
    top = throw.apex(state, k, cp, g=g)
    apex = None
    if top is not None and top.t_s <= t_end:
        apex = {"t_s": top.t_s, "x_m": float(flight.pos(top.t_s)[0, 0]), "y_m": top.y_m}
    y_sd = z_sd = end_sd = None
    if k_variance is not None:
        y_sd, z_sd = flight.sd_across(t, 0, (1, 2)).T
        if end == "ground":
            sd = flight.sd_across(np.array([t_end]), 1, (0, 2))[0]
            end_sd = {"x_m": float(sd[0]), "z_m": float(sd[1])}
        else:
            end_sd = {"y_m": float(y_sd[-1]), "z_m": float(z_sd[-1])}
    return Trajectory(t, xyz, end, float(t_end), float(cp), float(v1_m_s),
                      float(shaft_height_m), apex, y_sd, z_sd, end_sd)
