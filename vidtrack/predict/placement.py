"""The recovery device's place: H1 and H2 from the blade shaft O to its impeller centre O1.

Step 4 of the chain of Chen 2018, section 4 (:mod:`vidtrack.predict.forward`), optional:
H1 (horizontal) and H2 (vertical) from the blade shaft O to the device's impeller centre
O1, for a given inlet geometry (:class:`InletGeometry`) and the predicted throw. The
paper's Fig. 6 flow chart is not legible in our copy, so the placement rule is ours and
written down in :func:`place_device`.

Every length is in m, in the world frame (docs/reference.md: origin at the blade shaft, x outward,
y up).
"""

import math
from dataclasses import dataclass

import numpy as np

from fits.blade import G_STANDARD
from fits.errors import InputError
from vidtrack.predict.coefficients import _Z95
from vidtrack.predict.trajectory import (_check_release_above_ground, _first_crossing,
                                         _Flight, _ground_time)

__all__ = ["InletGeometry", "DevicePlacement", "place_device"]


@dataclass(frozen=True)
class InletGeometry:
    """The straw recovery device, relative to its impeller centre O1 (Chen 2018, Fig. 5).

    The paper gives neither the device's dimensions nor a legible Fig. 6; these are the
    inputs our placement rule needs (all in m; the defaults are assumptions).

    Attributes
    ----------
    offset_m : float
        Horizontal distance from the inlet plane (the vertical opening the straw enters,
        facing the blade) out to O1; H1 = inlet plane x + offset. Default 0.15.
    low_m, high_m : float
        The opening's lower and upper edge relative to O1's height (low < high).
        Default -0.10 and 0.10.
    bottom_m : float
        How far the housing reaches below O1 (its lowest point). Default 0.20.
    blade_clearance_m : float
        Least horizontal gap between the blade circle (radius R) and the inlet plane.
        Default 0.05.
    ground_clearance_m : float
        Least gap between the housing's lowest point and the ground. Default 0.05.
    """

    offset_m: float = 0.15
    low_m: float = -0.10
    high_m: float = 0.10
    bottom_m: float = 0.20
    blade_clearance_m: float = 0.05
    ground_clearance_m: float = 0.05

    def __post_init__(self):
        for name in ("offset_m", "low_m", "high_m", "bottom_m", "blade_clearance_m",
                     "ground_clearance_m"):
            v = float(getattr(self, name))
            if not math.isfinite(v):
                raise InputError(f"inlet geometry: {name} must be finite, got {v}")
            object.__setattr__(self, name, v)
        if self.low_m >= self.high_m:
            raise InputError(f"inlet geometry: low_m ({self.low_m}) must be below high_m "
                             f"({self.high_m})")
        for name in ("offset_m", "bottom_m", "blade_clearance_m", "ground_clearance_m"):
            if getattr(self, name) < 0:
                raise InputError(f"inlet geometry: {name} must be >= 0, got "
                                 f"{getattr(self, name)}")

    def to_dict(self):
        """Plain JSON-ready values."""
        return {"offset_m": self.offset_m, "low_m": self.low_m, "high_m": self.high_m,
                "bottom_m": self.bottom_m, "blade_clearance_m": self.blade_clearance_m,
                "ground_clearance_m": self.ground_clearance_m}


@dataclass(frozen=True)
class DevicePlacement:
    """H1, H2 and what they rest on (world frame, m; H2 > 0: O1 above the shaft)."""

    h1_m: float
    h2_m: float
    inlet_x_m: float
    inlet_y_m: tuple
    stream_y_m: tuple
    t_inlet_s: float
    binding: str
    geometry: InletGeometry

    def to_dict(self):
        """Plain JSON-ready values."""
        return {"h1_m": self.h1_m, "h2_m": self.h2_m, "inlet_x_m": self.inlet_x_m,
                "inlet_y_m": list(self.inlet_y_m), "stream_y_m": list(self.stream_y_m),
                "t_inlet_s": self.t_inlet_s, "binding": self.binding,
                "geometry": self.geometry.to_dict()}


def place_device(state, k, cp, geometry, *, radius_m, shaft_height_m, v1_m_s,
                 k_variance=None, g=G_STANDARD):
    """H1 and H2 of the recovery device's impeller centre O1 from the blade shaft O.

    Parameters
    ----------
    state, k, cp, v1_m_s, shaft_height_m, k_variance, g
        As :func:`throw_trajectory`.
    geometry : InletGeometry
    radius_m : float, keyword-only
        The blade's tip radius R.

    Returns
    -------
    DevicePlacement

    Raises
    ------
    fits.errors.InputError
        No place exists: the straw lands before the nearest admissible inlet plane, or
        the stream never rises high enough for a housing that clears the ground, or the
        95 % band is taller than the opening.

    Notes
    -----
    Our reading of section 4 (H1 as small as possible without touching the blade, H2
    such that the device does not touch the soil, the thrown straw entering the inlet):

    1. The inlet plane must lie at ``x_i >= R + blade_clearance``.
    2. At ``x_i`` the stream, ``y`` +- 1.96 sd (the sd only with a k covariance), must
       fit the opening ``[O1y + low, O1y + high]`` while the housing clears the ground:
       ``O1y - bottom >= -H + ground_clearance``.
    3. ``x_i`` is the smallest such plane (searched along the flight up to the landing),
       ``O1y`` centres the stream in the opening, raised if the ground requires.
    4. ``H1 = x_i + offset``, ``H2 = O1y``.
    """
    _check_release_above_ground(state, shaft_height_m)
    flight = _Flight(state, k, cp, v1=v1_m_s, g=g, k_variance=k_variance)
    t_ground = _ground_time(flight, -shaft_height_m)
    x_min = radius_m + geometry.blade_clearance_m
    x_land = float(flight.pos(t_ground)[0, 0])
    if x_land <= x_min:
        raise InputError(f"no place for the device: the straw lands at x = {x_land:.4g} m, "
                         f"before the nearest inlet plane x = R + blade clearance = "
                         f"{x_min:.4g} m")
    t_min = (0.0 if state[0] >= x_min else
             _first_crossing(lambda tt: flight.pos(tt)[:, 0] - x_min, 0.0, t_ground))
    floor = -shaft_height_m + geometry.ground_clearance_m + geometry.bottom_m  # lowest O1y
    width = geometry.high_m - geometry.low_m

    def spread(tt):
        if k_variance is None:
            return np.zeros(np.size(tt))
        return _Z95 * flight.sd_across(np.atleast_1d(tt), 0, (1,))[:, 0]

    def slack(tt):
        tt = np.atleast_1d(tt)
        y = flight.pos(tt)[:, 1]
        s = spread(tt)
        return np.minimum((y - s) - (floor + geometry.low_m), width - 2.0 * s)

    if slack(np.array([t_min]))[0] >= 0:
        t_i = t_min
        binding = "blade clearance"
    else:
        t_i = _first_crossing(slack, t_min, t_ground)
        binding = "ground clearance / opening"
        if not math.isfinite(t_i):
            s = spread(np.linspace(t_min, t_ground, 64))
            if np.all(2.0 * s > width):
                why = (f"the 95 % band of the stream is taller than the opening "
                       f"({width:g} m) everywhere")
            else:
                why = ("the stream never rises high enough for an opening whose lower "
                       f"edge is {geometry.low_m:g} m from O1 while the housing "
                       f"({geometry.bottom_m:g} m below O1) clears the ground by "
                       f"{geometry.ground_clearance_m:g} m")
            raise InputError(f"no place for the device between x = {x_min:.4g} m and the "
                             f"landing at x = {x_land:.4g} m: {why}")
    p = flight.pos(t_i)[0]
    s = float(spread(t_i)[0])
    o1y = max(floor, p[1] - 0.5 * (geometry.low_m + geometry.high_m))
    return DevicePlacement(
        h1_m=float(p[0] + geometry.offset_m), h2_m=float(o1y), inlet_x_m=float(p[0]),
        inlet_y_m=(float(o1y + geometry.low_m), float(o1y + geometry.high_m)),
        stream_y_m=(float(p[1] - s), float(p[1] + s)), t_inlet_s=float(t_i),
        binding=binding, geometry=geometry)
