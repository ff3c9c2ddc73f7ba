"""The views' scales in k1..k4's error: the calibration's part, by the delta method.

Every coordinate the ``front`` or ``top`` view gives is its pixels times its scale s
(m per px), so an error in s moves every point of that view by the same factor, in every
frame and in every throw of the run: a systematic error, which averaging throws does not
reduce. Its relative standard uncertainty rel_v comes from the scene
(:attr:`vidtrack.scene.ViewSpec.scale_rel_uncertainty`: sqrt(2) sigma / N for a ruler of
N px whose ends are each uncertain by sigma px; stated for ``m_per_px``).

:func:`scale_error` carries it into k by refitting: the views' tracks merged again into
the world track with view v's scale times (1 + h) and (1 - h), h = rel_v (so the
difference spans the scale's own uncertainty: the response of k is not quite linear, as
the merge finds the views' clock offset again on the shared X), each fitted (estimates
only), and the central difference gives dk / d(ln s_v). The delta method then gives
the calibration's standard error,

    sd_cal(k) = sqrt( sum_v (dk / d(ln s_v) * rel_v)^2 ),

the views' scales independent. When the views' scales were reconciled on the shared X
(:mod:`vidtrack.world.shared_x`) the refits start from the reconciled scales and the
scales' errors are those left after the reconciliation, with their covariance P (the
two scales wrong by nearly the same factor): ``sd_cal(k)^2 = g^T P g``, g the vector of
dk / d(ln s_v). Measured against renders whose ruler was read off by a
known amount (tests/test_scale_error.py): the k shift is what dk / d(ln s) predicts.

Calibrated cameras (``[world]``) are not covered here: their calibration's covariance is
not carried yet (said in the notes).
"""

import dataclasses
import logging
from dataclasses import dataclass

log = logging.getLogger(__name__)

__all__ = ["ScaleError", "scale_error", "MIN_STEP", "MAX_STEP"]

#: Smallest and largest relative step of a view's scale in the refits: the step is the
#: scale's own relative uncertainty, kept within these (below 1e-4 the refits' own
#: tolerance, 1e-12 relative, would still do, but the merge's clock offset is found to
#: 1e-4 frame).
MIN_STEP = 1e-4
MAX_STEP = 0.1
K_NAMES = ("k1", "k2", "k3", "k4")


@dataclass(frozen=True)
class ScaleError:
    """The calibration's part of k1..k4's error from the views' scales.

    Attributes
    ----------
    rel_uncertainty : dict of str to float or None
        Per view, the relative standard uncertainty of its scale (None: not stated,
        taken as exact).
    how : dict of str to str
        Per view, where that uncertainty comes from.
    sensitivity : dict of str to dict of str to float
        Per coefficient, {view: dk / d(ln s_v)} for the views with an uncertainty > 0.
    stderr : dict of str to float or None
        Per coefficient, sd_cal(k); None where a refit failed (the notes say why).
    notes : tuple of str
        What was taken as exact, refits that failed.
    shared : vidtrack.world.shared_x.SharedScale or None
        The reconciliation on the shared X, when the views' scales were reconciled.
    """

    rel_uncertainty: dict
    how: dict
    sensitivity: dict
    stderr: dict
    notes: tuple = ()
    shared: object = None

    def parts(self):
        """``{k: (stderr_calibration, scale_sensitivity)}`` for
        :meth:`fits.lsq.ThrowFit.with_calibration`."""
        return {k: (self.stderr.get(k), self.sensitivity.get(k, {})) for k in self.stderr}

    def to_dict(self):
        """fit.json's ``calibration``: per view its scale's uncertainty and source."""
        views = {v: {"scale_rel_uncertainty": self.rel_uncertainty[v], "from": self.how[v]}
                 for v in self.rel_uncertainty}
        if self.shared is not None:
            for v in views:
                views[v]["scale_factor_reconciled"] = self.shared.factors[v]
                views[v]["scale_rel_uncertainty_reconciled"] = self.shared.stderr_rel(v)
        return {"views": views, "systematic": True,
                "reconciled": self.shared is not None,
                "method": "delta method: each view's scale moved by +- its relative "
                          "uncertainty, the views merged and fitted again"
                          + ("; the scales reconciled on the shared X, their errors' "
                             "covariance after it" if self.shared is not None else "")}


def _refit(tracks, mappings, sync, fit_args, near):
    from fits.lsq import fit_throw
    from vidtrack.world.orthogonal import merge_tracks

    world = merge_tracks(tracks, mappings, sync=sync)
    return fit_throw(world.data, errors=False, near=near, **fit_args)


def scale_error(scene, tracks, fit, *, cp, model="quadratic", world=None):
    """The calibration's part of each determined k's error, from the views' scales.

    Parameters
    ----------
    scene : vidtrack.scene.Scene
        The scene (its views' mappings and scale uncertainties).
    tracks : dict of str to vidtrack.track.tracker.Track
        The views' tracks that were merged into the world track fitted.
    fit : fits.lsq.ThrowFit
        The fit of that world track.
    cp : float
        The drag parameter used, s/m.
    model : str
        The throw model used.
    world : vidtrack.world.world_track.WorldTrack, optional
        The world track fitted: its ``shared_x`` gives the reconciled scales and their
        covariance (without it, the scene's scales, independent).

    Returns
    -------
    ScaleError or None
        None for calibrated cameras (not covered).
    """
    from fits.errors import ConvergenceError, InputError
    from vidtrack.errors import VidtrackError

    if scene.calibrated:
        return None
    names = [n for n in scene.view_names if n in tracks]
    mappings = {n: scene.views[n].mapping() for n in names}
    shared = None if world is None else world.shared_x
    if shared is not None and shared.reconciled:
        mappings = world.mappings(mappings)
    else:
        shared = None
    sync = {n: scene.views[n].sync_frame for n in names}
    fit_args = {"cp": cp, "g": scene.physics.gravity_m_s2, "v1": scene.v1_m_s, "model": model}
    rel, how, notes = {}, {}, []
    for n in names:
        rel[n], how[n] = scene.views[n].scale_rel_uncertainty
        if rel[n] is None:
            notes.append(f"the {n} view's scale is taken as exact: views.{n} gives m_per_px "
                         "(or a calibration file's scale) without m_per_px_rel_uncertainty, "
                         "so k's interval holds no part for it; state it (e.g. "
                         "m_per_px_rel_uncertainty = 0.005 for 0.5 %)")
    determined = [k for k in K_NAMES if fit.coefficients[k].determined]
    sens = {k: {} for k in determined}
    failed = set()
    for n in names:
        if not rel[n]:
            continue
        h = min(max(rel[n], MIN_STEP), MAX_STEP)
        moved = []
        for sign in (1.0, -1.0):
            m = dict(mappings)
            m[n] = dataclasses.replace(mappings[n], m_per_px=mappings[n].m_per_px
                                       * (1.0 + sign * h))
            try:
                moved.append(_refit(tracks, m, sync, fit_args, fit))
            except (ConvergenceError, InputError, VidtrackError, ValueError) as exc:
                notes.append(f"the {n} view's scale could not be carried into k: the fit "
                             f"with it {100 * sign * h:+.3g} % failed ({exc})")
                failed.add(n)
                break
        if n in failed:
            continue
        up, down = moved
        for k in determined:
            a, b = up.coefficients[k], down.coefficients[k]
            if a.determined and b.determined:
                sens[k][n] = (a.value - b.value) / (2.0 * h)
            else:
                failed.add(n)
    stderr = {}
    for k in determined:
        if any(rel[n] and n not in sens[k] for n in names):
            stderr[k] = None
            continue
        if shared is not None:
            g = [sens[k].get(v, 0.0) for v in (shared.reference, shared.other)]
            var = sum(g[i] * g[j] * shared.covariance[i][j] for i in (0, 1) for j in (0, 1))
            stderr[k] = float(max(var, 0.0) ** 0.5)
            continue
        stderr[k] = float(sum((sens[k][n] * rel[n]) ** 2 for n in sens[k]) ** 0.5)
    for k in determined:
        log.debug("%s: calibration stderr %s, dk/d(ln s) %s", k, stderr[k], sens[k])
    return ScaleError(rel_uncertainty=rel, how=how, sensitivity=sens, stderr=stderr,
                      notes=tuple(notes), shared=shared)
