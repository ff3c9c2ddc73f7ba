"""From a machine setting to a predicted throw and a recovery device's place (Chen 2018, s. 4).

The chain of the paper's section 4 and Fig. 6, run by :func:`predict`:

1. k1..k4 at the setting (n, delta1, v1) from a regression in natural units
   (:mod:`vidtrack.predict.regression`, :mod:`vidtrack.predict.coefficients`): the
   published eqs. 20-23 by default (package data ``vidtrack/data/chen2018_eqs_20_23.json``,
   no covariance published, hence no uncertainty band), or a JSON written by
   ``vidtrack anova --json`` (then the coefficient covariance is carried into the k's by
   the delta method, exact for a model linear in its coefficients, and into the
   trajectory by linearisation).
2. The release state from the blade model (``fits.blade``, eqs. 1-10).
3. The 3-D throw (``fits.throw.position``, eqs. 11-19) until the straw reaches the ground
   plane ``y = -H`` (H: the shaft's height above the ground) or a given inlet plane
   (:mod:`vidtrack.predict.trajectory`).
4. Optionally the recovery device's position: H1 (horizontal) and H2 (vertical) from the
   blade shaft O to the device's impeller centre O1, for a given inlet geometry
   (:mod:`vidtrack.predict.placement`; the paper's Fig. 6 flow chart is not legible in
   our copy, so the placement rule is ours and written down there).

Every length is in m, in the world frame (docs/reference.md: origin at the blade shaft, x outward,
y up, z along travel, z relative to the machine); the factors keep the paper's units.
"""

import logging
import math
from dataclasses import dataclass, field

from fits.blade import BladeSetting, G_STANDARD, release as blade_release
from fits.errors import InputError
from vidtrack.predict.coefficients import CoefficientPrediction, predict_coefficients
from vidtrack.predict.placement import place_device
from vidtrack.predict.regression import load_regression
from vidtrack.predict.trajectory import DEFAULT_CP_S_PER_M, Trajectory, throw_trajectory

log = logging.getLogger(__name__)

#: Working depth of the blade tip in the soil (Chen 2018, section 3.2): the default
#: shaft height is H = R - 0.050 m.
WORKING_DEPTH_M = 0.050

__all__ = ["WORKING_DEPTH_M", "Prediction", "predict"]


@dataclass(frozen=True)
class Prediction:
    """Everything ``vidtrack predict`` reports for one setting."""

    coefficients: CoefficientPrediction
    release: object
    trajectory: Trajectory
    device: object
    regression_source: str
    regression_provenance: object
    has_covariance: bool
    warnings: tuple = ()
    notes: tuple = ()
    extra: dict = field(default_factory=dict)

    def __repr__(self):
        s = self.coefficients.setting
        setting = ", ".join(f"{k}={v:g}" for k, v in s.items())
        ks = ", ".join(f"{v:#.4g}" for v in self.coefficients.k)
        end = ", ".join(f"{v:.3g}" for v in self.trajectory.end_point_m)
        more = "".join(f", {n} {w}" for n, w in ((len(self.warnings), "warnings"),
                                                 (len(self.notes), "notes")) if n)
        return (f"Prediction({setting}: k=({ks}), end={self.trajectory.end!r} at "
                f"({end}) m{more})")

    def to_dict(self):
        """The ``vidtrack predict --json`` object (the fixed keys coefficients, release,
        trajectory first; docs/predict.md)."""
        return {
            "coefficients": self.coefficients.to_dict(),
            "release": self.release.to_dict(),
            "trajectory": self.trajectory.to_dict(),
            "schema": 1,
            "setting": dict(self.coefficients.setting),
            "coded": dict(self.coefficients.coded),
            "extrapolation": self.coefficients.extrapolation,
            "regression": {"source": self.regression_source,
                           "covariance": self.has_covariance,
                           "provenance": self.regression_provenance},
            "device": None if self.device is None else self.device.to_dict(),
            "warnings": list(self.warnings),
            "notes": list(self.notes),
        }


def predict(n_rpm, blade_angle_deg, speed_kmh, *, regression=None, radius_m=0.25,
            start_m=0.10, friction=0.5, phase_deg=-30.0, release_method="exact",
            cp_s_per_m=DEFAULT_CP_S_PER_M, shaft_height_m=None, inlet_x_m=None,
            device=None, points=101, g=G_STANDARD):
    """Predict k1..k4, the release and the throw for one machine setting (section 4).

    Parameters
    ----------
    n_rpm, blade_angle_deg, speed_kmh : float
        Blade speed n (r/min), rake angle delta1 (deg), travel speed v1 (km/h).
    regression : Regression, optional, keyword-only
        Default: the published eqs. 20-23 (:func:`load_regression`).
    radius_m, start_m, friction, phase_deg : float, keyword-only
        The blade model's R, l1, mu and alpha0 (``fits.blade.BladeSetting``; defaults
        there are assumptions, the paper publishes none of them).
    release_method : {"exact", "series"}, keyword-only
        ``fits.blade.release`` method.
    cp_s_per_m : float, keyword-only
        Straw drag parameter (see ``DEFAULT_CP_S_PER_M``).
    shaft_height_m : float, optional, keyword-only
        H, the shaft's height above the ground; default R - 0.050 (the tip works 50 mm
        deep, section 3.2).
    inlet_x_m : float, optional, keyword-only
        End the trajectory at this vertical inlet plane instead of the ground.
    device : InletGeometry, optional, keyword-only
        Place the recovery device (H1, H2) for this geometry; the trajectory then ends
        at its inlet.
    points : int, keyword-only
        Trajectory samples.

    Returns
    -------
    Prediction

    Raises
    ------
    fits.errors.InputError
        A setting that violates a throwing condition (the message names eq. 5, 6, 7 or
        the exact slide), a release below the ground, no place for the device, bad values.

    Warns
    -----
    ExtrapolationWarning
        The setting lies outside the regression's design region.
    """
    if regression is None:
        regression = load_regression()
    coefs = predict_coefficients(regression, n_rpm=n_rpm, blade_angle_deg=blade_angle_deg,
                                 speed_kmh=speed_kmh)
    blade = BladeSetting(n_rpm, blade_angle_deg, radius_m=radius_m, start_m=start_m,
                         friction=friction, phase_deg=phase_deg, g_m_s2=g)
    rel = blade_release(blade, method=release_method, speed_kmh=speed_kmh).require_thrown()
    if not (math.isfinite(cp_s_per_m) and cp_s_per_m >= 0):
        raise InputError(f"cp_s_per_m must be >= 0 s/m, got {cp_s_per_m}")
    if shaft_height_m is None:
        shaft_height_m = radius_m - WORKING_DEPTH_M
    state = rel.state()
    v1 = float(speed_kmh) / 3.6
    notes = []
    if not regression.has_covariance:
        notes.append("the regression carries no coefficient covariance (the published "
                     "eqs. 20-23 give none): no uncertainty band")
    if rel.min_normal_accel_m_s2 < 0:
        notes.append(f"the blade's normal force in eq. 1 is negative during part of the "
                     f"slide (min N/m = {rel.min_normal_accel_m_s2:.3g} m/s^2): there the "
                     "paper's friction term pushes the straw outward, where in fact it "
                     "would lift off the blade face; the model (and this prediction) "
                     "ignores that")
    kvar = coefs.k_variance
    placement = None
    if device is not None:
        placement = place_device(state, coefs.k, cp_s_per_m, device, radius_m=radius_m,
                                 shaft_height_m=shaft_height_m, v1_m_s=v1, k_variance=kvar,
                                 g=g)
        inlet_x_m = placement.inlet_x_m
    traj = throw_trajectory(state, coefs.k, cp_s_per_m, v1_m_s=v1,
                            shaft_height_m=shaft_height_m, inlet_x_m=inlet_x_m,
                            k_variance=kvar, points=points, g=g)
    for note in notes:
        log.info("%s", note)
    return Prediction(coefs, rel, traj, placement, regression.source,
                      regression.provenance, regression.has_covariance,
                      tuple(coefs.warnings), tuple(notes))
