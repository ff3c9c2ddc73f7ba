"""How much the perspective left uncorrected in a view could move k1..k4, and the note.

A ``front`` or ``top`` view without ``camera_distance_m`` is read with one scale at every
depth (:mod:`vidtrack.world.parallax` corrects only the views that give it). Whether that
matters depends on the flight and on where the camera stood, which the run does not
say. :func:`perspective_effect` works it out for this flight, per such view:

1. **How near the camera can be.** The views both see X, each at its own scale: a view
   whose camera is d metres from its scale plane sees X about its principal point's foot
   magnified by d / (d - depth), the depth measured by the other view. Uncorrected, the
   views then disagree on X by, to first order,
   ``a_v * depth_v(t) * (X(t) - x_foot_v)`` per view v, a_v = 1 / d_v. The difference of
   the two views' X on the merged clock is fitted by least squares with these terms
   (one per view without the distance) and the terms a flight without perspective can
   also show: an offset (the origins) and X (the scales' ratio). A constant depth is a
   scale error, which the X term absorbs: a_v is measured by how the depth changes over
   the flight, which is also what biases k beyond the scale. Its standard error is
   widened for the residuals' lag-1 autocorrelation rho by sqrt((1 + rho) / (1 - rho)).
   The clock offset is not a term of the fit: over one flight the speed along X spans
   nearly the same shapes in time as the perspective's terms, and with it a_v is
   undetermined (its standard error 40 times larger on ``datasets/run42``); the merge
   found the offset on this same X. When a_v is clearly positive (a perspective seen:
   beyond :data:`BOUND_Z` standard errors) the views are merged again corrected at
   1 / a_v (the clock offset found again on the corrected X) and the fit is repeated on
   what is left, a few times: the first-order terms and the offset found on the
   uncorrected X understate a strong perspective (on the square rig a front camera
   1.5 m away reads 1.31 m from the first fit, 1.50 m after).

   The views' agreement is what tells: at any one distance taken for every run, the
   sample run, rendered with no perspective at all, would get the note (a camera 10 m
   from its plane would move its k3 by 7.7 standard errors), while its views agree on X
   so well that neither camera can be nearer than a few hundred metres.

   The **assumed distance** is the nearest the data allow,
   ``1 / (|a_v| + BOUND_Z * se(a_v))``, but never nearer than
   :func:`nearest_plausible_distance`: half the frame's larger side at the scale plane
   (a lens of :data:`WIDEST_FIELD_DEG` degrees spans the frame from there) and twice the
   flight's largest depth towards the camera.

2. **The effect on k.** The world track's points of that view are scaled about its
   principal point's foot by (d - depth) / d at the assumed distance d, as the
   correction would scale them (the depth is the other view's coordinate in the same
   row), and refitted (estimates only, :func:`fits.lsq.fit_throw` ``errors=False``,
   about 0.05 s); the shift of each k is set against its standard error (fit.json's
   ``stderr``: the fit's own and the views' scales' together). A shift of at least
   :data:`SCREEN_SHARE` of the note's threshold is computed again the way the run
   would get it with ``camera_distance_m`` given: the tracks merged again with that
   distance (which finds the clock offset again on the corrected X: it moves the other
   view's axis in time, by up to a ninth of the largest shift in standard errors on the
   square rig) and refitted, against the same merge without it. The refit is cheap
   enough that the fit's Jacobian (the delta method) would save little: on
   ``datasets/run42`` the whole step takes about 0.12 s of the fit's 4 s.

3. **The note.** Only when some k moves by at least :data:`NOTE_SHARE` of its standard
   error does the run get a note, per view: the assumed distance and why, each k's
   shift in its units and in standard errors, and what to do: give
   ``views.<view>.camera_distance_m`` in scene.toml (the world stage then corrects the
   perspective). Otherwise the numbers are logged (``vidtrack -v fit``) and nothing else
   changes.

Calibrated cameras (``[world]``) model perspective themselves, and a run with one view
has no depth: neither gets a note.
"""

import contextlib
import dataclasses
import logging
import math
from dataclasses import dataclass

import numpy as np

from vidtrack.run.scale_error import K_NAMES
from vidtrack.world.shared_x import MIN_POINTS, common_points, widened_lstsq

log = logging.getLogger(__name__)

__all__ = ["PerspectiveEffect", "ViewEffect", "perspective_effect", "nearest_plausible_distance",
           "camera_bound", "NOTE_SHARE", "SCREEN_SHARE", "BOUND_Z", "WIDEST_FIELD_DEG"]

#: The note's threshold: a view gets the note when some k would move, with the camera at
#: the assumed distance, by at least this many of its standard errors (fit.json's
#: ``stderr``, the fit's and the views' scales' parts together). A bias of one standard
#: error lowers the 95 % interval's coverage of the true k to 83 %; as the assumed
#: distance is the nearest the views allow, the real shift is most likely smaller.
NOTE_SHARE = 1.0
#: A shift (from the cheap refit of the scaled world track) of at least this share of
#: :data:`NOTE_SHARE` is computed again through the merge, as a run with the distance
#: given gets it; below it the merge's part (the clock offset found again) cannot lift it
#: over the threshold (in standard errors it was at most a ninth of the largest shift, on
#: the square rig at 1.5 and 6 m).
SCREEN_SHARE = 0.5
#: Standard errors of 1 / d added to its estimate for the nearest distance the views'
#: agreement on X allows (two-sided 95 %).
BOUND_Z = 1.96
#: The widest field of view taken for a lens: a camera nearer the plane than half the
#: frame's larger side (at 90 degrees) could not span the frame.
WIDEST_FIELD_DEG = 90.0
#: Most refinements of 1 / d when a perspective is seen (each one merge of the views
#: corrected at the estimate and one least-squares fit); it stops when 1 / d moves by
#: less than a hundredth of its standard error.
_REFINE_PASSES = 6


@dataclass(frozen=True)
class ViewEffect:
    """What the perspective left uncorrected in one view could do to k.

    Attributes
    ----------
    view, other : str
        The view without ``camera_distance_m``, and the one that measures its depth.
    axis : str
        The depth's world axis (``z`` for ``front``, ``y`` for ``top``).
    inverse_distance, inverse_distance_se : float or None
        a = 1 / d (1/m) fitted to the views' disagreement on X, and its standard error
        (widened for the residuals' autocorrelation); None when too few common points.
    distance_m : float
        The assumed distance (m) from the camera to the view's scale plane.
    distance_from : str
        Why that distance: ``"agreement on X"`` or ``"field of view"``.
    depth_range_m : tuple of float
        The flight's depth coordinate (``axis``) as the other view sees it, min and max.
    shift : dict of str to float
        Per determined k, k with the perspective corrected at ``distance_m`` minus k.
    share : dict of str to float
        Per determined k, ``|shift| / stderr``.
    merged : bool
        True when the shifts were computed through the merge (else by the refit of the
        scaled world track).
    noted : bool
        Some share is at least :data:`NOTE_SHARE`.
    """

    view: str
    other: str
    axis: str
    inverse_distance: float | None
    inverse_distance_se: float | None
    distance_m: float
    distance_from: str
    depth_range_m: tuple
    shift: dict
    share: dict
    merged: bool = False
    noted: bool = False

    def note(self):
        """The note for the run's record (fit.json ``notes``, the report)."""
        A = self.axis.upper()
        if self.distance_from == "agreement on X":
            why = (f"the views' agreement on X allows its camera as near as "
                   f"{self.distance_m:.3g} m from the plane {A} = 0")
        else:
            why = (f"its camera is taken {self.distance_m:.3g} m from the plane {A} = 0, as "
                   f"near as it can stand (a lens of {WIDEST_FIELD_DEG:g} degrees spans the "
                   "frame from there, the flight in front of it)"
                   + ("" if self.inverse_distance is not None else
                      " (the views share too few points on X to tell more)"))
        lo, hi = self.depth_range_m
        moves = [f"{k} by {_signed(self.shift[k])} ({self.share[k]:.2g})" for k in self.shift]
        if moves:
            moves[0] = moves[0][:-1] + " standard errors)"
        return (f"perspective in the {self.view} view could move k (no views.{self.view}."
                f"camera_distance_m): {why} ({A} = {lo:+.3f} .. {hi:+.3f} m seen by the "
                f"{self.other} view); corrected for a camera there, k would move: "
                f"{', '.join(moves)} (the note's threshold: {NOTE_SHARE:g} standard error); "
                f"give views.{self.view}.camera_distance_m in scene.toml (the distance from "
                f"the camera to the plane {A} = 0, m; the perspective is then corrected)")


@dataclass(frozen=True)
class PerspectiveEffect:
    """Per view without ``camera_distance_m`` its :class:`ViewEffect`, and the notes."""

    views: dict
    notes: tuple = ()


def _signed(x):
    return "0" if x == 0 else f"{x:+.3g}"


@contextlib.contextmanager
def _quiet_merges():
    """The merges made here say nothing (the run's own merge said it all, and a note
    that perspective was corrected at an assumed distance would mislead)."""
    merge_log = logging.getLogger("vidtrack.world.orthogonal")
    level = merge_log.level
    merge_log.setLevel(logging.ERROR)
    try:
        yield
    finally:
        merge_log.setLevel(level)


def _step(track):
    t = track.data["t_s"].to_numpy(dtype=np.float64)
    dt = np.diff(t)
    dt = dt[dt > 0]
    return float(np.median(dt)) if dt.size else 1.0


def _foot(mapping, track):
    """The principal point's foot on the view's scale plane (world, the view's axes),
    or None when the principal point is unknown (no frame size)."""
    from vidtrack.world.parallax import _principal

    pp, _ = _principal(track, mapping)
    if pp is None:
        return None
    # the principal point is in undistorted pixels, as the correction takes it
    return mapping._ideal_to_world(np.asarray(pp, dtype=np.float64).reshape(1, 2))[0]


def nearest_plausible_distance(mapping, track, max_depth_m):
    """The nearest a view's camera is taken to stand from its scale plane, m.

    Half the frame's larger side at the plane (a lens of :data:`WIDEST_FIELD_DEG` degrees
    spans the frame from there), and at least twice the flight's largest depth towards
    the camera (the straw stays in front of it, magnified at most twofold).
    """
    shape = getattr(track, "frame_shape", None) or (0, 0)
    side = max(int(shape[0]), int(shape[1])) * mapping.m_per_px
    fov = 0.5 * side / math.tan(math.radians(0.5 * WIDEST_FIELD_DEG))
    return max(fov, 2.0 * max(float(max_depth_m), 0.0))


def _fit_disagreement(points, t0, reference, steps, mappings, feet, unknown):
    """a_v = 1 / d_v and their standard errors from the views' disagreement on X (the
    module's step 1, one least-squares fit); None when too few common points."""
    cols, t = common_points(points, t0, reference, steps)
    other = next(v for v in points if v != reference)
    if ("x", reference) not in cols or ("x", other) not in cols:
        return None
    x = cols[("x", reference)]
    depth = {}
    for v in unknown:
        axis, sign = mappings[v].toward_camera
        seen_by = other if v == reference else reference
        depth[v] = sign * cols.get((axis, seen_by), np.full(t.size, np.nan))
    ok = np.isfinite(x) & np.isfinite(cols[("x", other)])
    for v in unknown:
        ok &= np.isfinite(depth[v])
    n = int(np.count_nonzero(ok))
    if n < MIN_POINTS + 2 + len(unknown):
        return None
    xk = x[ok]
    r = xk - cols[("x", other)][ok]
    design = [np.ones(n), xk - xk.mean()]
    for v in unknown:
        i = mappings[v].world_axes.index("x")
        design.append((1.0 if v == reference else -1.0) * depth[v][ok] * (xk - feet[v][i]))
    coef, cov, _, _ = widened_lstsq(np.column_stack(design), r)
    out = {}
    for j, v in enumerate(unknown):
        c = len(design) - len(unknown) + j
        out[v] = (float(coef[c]), float(math.sqrt(cov[c, c])))
    return out


def camera_bound(tracks, mappings, t0, reference, unknown, *, sync=None):
    """1 / d for each view in ``unknown`` fitted to the views' disagreement on X.

    Parameters
    ----------
    tracks : dict of str to vidtrack.track.tracker.Track
        The merged tracks of both views.
    mappings : dict of str to calibration.ViewMapping
        As the merge used them (a view with ``camera_distance_m`` corrected).
    t0 : dict of str to float
        Each view's t = 0 on its clock (:attr:`WorldTrack.t0_s`).
    reference : str
        The world track's reference view.
    unknown : list of str
        The views without ``camera_distance_m``.
    sync : dict, optional
        The views' ``sync_frame`` (or "auto"), for the merges of the refinement.

    Returns
    -------
    dict of str to (float, float) or None
        Per view (a, se(a)) in 1/m, or None with too few common points.
    """
    from vidtrack.errors import VidtrackError
    from vidtrack.world.orthogonal import merge_tracks
    from vidtrack.world.parallax import corrected_points

    steps = {v: _step(tracks[v]) for v in tracks}
    feet = {v: _foot(mappings[v], tracks[v]) for v in unknown}
    if any(f is None for f in feet.values()):
        return None
    points = corrected_points(tracks, mappings, t0)
    est = _fit_disagreement(points, t0, reference, steps, mappings, feet, unknown)
    if est is None or not any(a > BOUND_Z * se for a, se in est.values()):
        return est
    # a perspective is seen: merge the views corrected at the estimate (the clock offset
    # found again on the corrected X) and fit what is left
    a = {v: est[v][0] for v in unknown}
    for _ in range(_REFINE_PASSES):
        maps = dict(mappings)
        for v in unknown:
            if a[v] > 0:
                maps[v] = dataclasses.replace(mappings[v], camera_distance_m=1.0 / a[v])
        try:
            w = merge_tracks(tracks, maps, sync=sync)
        except (VidtrackError, ValueError):
            break
        more = _fit_disagreement(corrected_points(w.tracks, maps, w.t0_s), w.t0_s,
                                 w.reference, steps, maps, feet, list(unknown))
        if more is None:
            break
        moved = 0.0
        for v in unknown:
            da, se = more[v]
            # corrected at 1 / a: what is left is a_true - a, to first order
            a[v] = a[v] + da if maps[v] is not mappings[v] else da
            est[v] = (a[v], se)
            moved = max(moved, abs(da) / se if se > 0 else 0.0)
        if moved < 0.01:
            break
    return est


def _scaled(world_data, mapping, view, reference, foot, distance):
    """The world track with the view's coordinates scaled as the correction at
    ``distance`` would scale them (x only when the view is the reference)."""
    axis, sign = mapping.toward_camera
    data = world_data.copy()
    depth = sign * data[f"{axis}_m"].to_numpy(dtype=np.float64)
    factor = (distance - depth) / distance
    factor[~(factor > 0)] = np.nan
    for i, a in enumerate(mapping.world_axes):
        if a == "x" and view != reference:
            continue
        col = f"{a}_m"
        data[col] = foot[i] + (data[col].to_numpy(dtype=np.float64) - foot[i]) * factor
    return data


def _merged_as_given(tracks, mappings, sync, world):
    """The views merged as the run merged them: their scales measured on the shared X
    and reconciled where it did that (:mod:`vidtrack.world.shared_x`)."""
    from vidtrack.world.orthogonal import merge_tracks
    from vidtrack.world.shared_x import merge_reconciled

    shared = world.shared_x
    if shared is None:
        return merge_tracks(tracks, mappings, sync=sync)
    return merge_reconciled(tracks, mappings, sync=sync, rel=shared.rel_uncertainty)


def perspective_effect(scene, tracks, world, fit, *, cp, model="quadratic"):
    """The effect on k of the perspective left uncorrected, per view, and the notes.

    Parameters
    ----------
    scene : vidtrack.scene.Scene
    tracks : dict of str to vidtrack.track.tracker.Track
        The views' tracks as merged.
    world : vidtrack.world.world_track.WorldTrack
        The world track fitted.
    fit : fits.lsq.ThrowFit
        Its fit, with the calibration's part of the errors when known.
    cp : float
        The drag parameter used, s/m.
    model : str
        The throw model used.

    Returns
    -------
    PerspectiveEffect or None
        None for calibrated cameras, one view, or no view without ``camera_distance_m``.
    """
    from fits.errors import ConvergenceError, InputError
    from fits.lsq import fit_throw
    from vidtrack.errors import VidtrackError
    from vidtrack.world.orthogonal import merge_tracks

    if scene.calibrated:
        return None
    names = [v for v in ("front", "top") if v in tracks and v in scene.views]
    if len(names) != 2 or not all(v in world.t0_s for v in names):
        return None
    # as the world track was merged: the scales reconciled on the shared X where they were
    given = {n: scene.views[n].mapping() for n in names}
    mappings = world.mappings(given)
    unknown = [v for v in names if mappings[v].camera_distance_m is None]
    if not unknown:
        return None
    determined = {k: c for k, c in fit.coefficients.items()
                  if k in K_NAMES and c.determined and c.value is not None}
    stderr = {k: (c.stderr_total if c.stderr_total is not None else c.stderr)
              for k, c in determined.items()}
    stderr = {k: s for k, s in stderr.items() if s is not None and s > 0}
    if not stderr:
        return None
    fit_args = {"cp": cp, "g": scene.physics.gravity_m_s2, "v1": scene.v1_m_s,
                "model": model}
    reference = world.reference
    sync = {n: scene.views[n].sync_frame for n in names}
    with _quiet_merges():
        bound = camera_bound(tracks, mappings, world.t0_s, reference, unknown, sync=sync)
    plain = []                                  # the merge without a distance, refitted once
    effects, notes = {}, []
    for v in unknown:
        other = next(o for o in names if o != v)
        axis, sign = mappings[v].toward_camera
        foot = _foot(mappings[v], tracks[v])
        coord = world.data[f"{axis}_m"].to_numpy(dtype=np.float64)
        coord = coord[np.isfinite(coord)]
        if foot is None or not coord.size:
            continue
        near = nearest_plausible_distance(mappings[v], tracks[v], float(np.max(sign * coord)))
        a, se = bound[v] if bound is not None else (None, None)
        if a is None:                           # the views' X tell nothing
            allowed = 0.0
        else:
            bound_a = abs(a) + BOUND_Z * se
            allowed = 1.0 / bound_a if bound_a > 0 else math.inf
        distance, why = ((allowed, "agreement on X") if allowed > near else
                         (near, "field of view"))
        depth_range = (float(coord.min()), float(coord.max()))
        shift, merged = {}, False
        if math.isfinite(distance):
            try:
                moved = fit_throw(_scaled(world.data, mappings[v], v, reference, foot,
                                          distance), errors=False, near=fit, **fit_args)
                shift = {k: moved.coefficients[k].value - determined[k].value for k in stderr
                         if moved.coefficients[k].determined}
            except (ConvergenceError, InputError, ValueError) as exc:
                log.info("perspective of the %s view: the refit at %.3g m failed (%s)", v,
                         distance, exc)
            worst = max((abs(s) / stderr[k] for k, s in shift.items()), default=0.0)
            if worst >= SCREEN_SHARE * NOTE_SHARE:
                try:
                    with _quiet_merges():
                        if not plain:
                            plain.append(fit_throw(merge_tracks(tracks, mappings,
                                                                sync=sync).data,
                                                   errors=False, near=fit, **fit_args))
                        # as a run with the distance given: from the scene's scales,
                        # measured (and reconciled) again on the corrected shared X
                        maps = dict(given)
                        maps[v] = dataclasses.replace(given[v], camera_distance_m=distance)
                        moved = fit_throw(_merged_as_given(tracks, maps, sync, world).data,
                                          errors=False, near=fit, **fit_args)
                    base = plain[0].coefficients
                    shift = {k: moved.coefficients[k].value - base[k].value for k in stderr
                             if moved.coefficients[k].determined and base[k].determined}
                    merged = True
                except (ConvergenceError, InputError, VidtrackError, ValueError) as exc:
                    log.info("perspective of the %s view: the merge at %.3g m failed (%s); "
                             "the refit's shifts kept", v, distance, exc)
        share = {k: abs(s) / stderr[k] for k, s in shift.items()}
        noted = any(s >= NOTE_SHARE for s in share.values())
        eff = ViewEffect(view=v, other=other, axis=axis, inverse_distance=a,
                         inverse_distance_se=se, distance_m=float(distance),
                         distance_from=why, depth_range_m=depth_range, shift=shift,
                         share=share, merged=merged, noted=noted)
        effects[v] = eff
        log.info("perspective of the %s view: 1/d = %s from the views' X; assumed %.4g m "
                 "(%s); k shifts %s%s", v,
                 "unknown" if a is None else f"{a:.3g} +- {se:.2g} /m", distance, why,
                 ", ".join(f"{k} {s:+.3g} ({share[k]:.2g} se)" for k, s in shift.items())
                 or "none", " (through the merge)" if merged else "")
        if noted:
            notes.append(eff.note())
    return PerspectiveEffect(views=effects, notes=tuple(notes))
