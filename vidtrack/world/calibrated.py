"""From calibrated cameras at any angle to the world track, in the throw's own frame.

Each view's track (tracked footage or points digitized elsewhere) gives pixels per frame;
with each camera's model (:class:`calibration.projective.ProjectiveCamera`) every frame
seen by two or more views is triangulated by minimising the reprojection error
(:func:`calibration.triangulation.triangulate`). One view alone is never enough: there is
no silent 2-D fallback.

Time: view v's frame f is at f / fps_v - offset_v. The offset comes from ``sync_frame``
(the frame of that view at t = 0) or, where none is given, from the data: the offset that
makes the views agree best (smallest median reprojection error over the frames both saw),
searched over whole frames and then refined to a twentieth of a frame, the other view's
pixels interpolated linearly between its frames.

Frames whose reprojection error is far above the run's typical error (beyond the median
plus 6 robust standard deviations, at least twice the median and at least 0.5 px) are
flagged and not fitted. With two views only an error across the epipolar line shows; one
along it moves the point in depth unseen: a third view catches it.

A straw is a rod, and a rod slanted in depth images with its near half longer and wider
than its far half: each view's tracked centroid (the silhouette's) is off the projection
of the rod's centre, towards its near end, by up to about f L^2 / (6 depth^2) px (0.3 px
for a 0.12 m straw at 1 m). After the first triangulation the rod is placed in 3-D
(:mod:`vidtrack.world.rod_centroid`): its axis from the views' image lines (the centroid
and the tracked angle: each line back-projects to a plane through its camera's centre;
the planes meet in the axis), its length and radius from the views' ``length_px`` and
``area_px`` (medians over the flight), and each view's centroid is moved by the
predicted offset of the silhouette's centroid from the projected centre; the views are
triangulated again (twice). A view whose tracker gives the rod's two ends places it by
them instead: its point is where it images the rod's 3-D centre
(:func:`vidtrack.world.rod_centroid.centre_from_ends`; the taper only shares out how
far the ends lie beyond the caps' centres). The axis, rotated into the throw's frame, is
also the world track's attitude (:mod:`vidtrack.world.attitude`). Frames whose axis is
not determined (fewer than two views with an elongated image, or their planes less than
10 degrees apart: a rod lying in the plane of two cameras and itself) are left as
measured and counted. Points digitized elsewhere carry no angle: nothing is corrected
then.

The throw's frame: the calibration's frame is rotated so that Y is up (``[world] up``) and
X is the throw's horizontal direction (``[world] forward``, or the horizontal part of the
initial velocity of a quadratic fitted to the points); Z = X x Y completes a right-handed
frame, as the orthogonal rigs' frame is (X outward, Y up, Z along the travel). k1..k4 keep
their meaning.
"""

import logging
import numpy as np

from vidtrack.errors import TrackError
from vidtrack.track.tracker import END_COLUMNS
from vidtrack.world.attitude import MIN_ELONGATION, MIN_PLANE_ANGLE_DEG, attitude_columns
from vidtrack.world.world_track import WorldTrack

log = logging.getLogger(__name__)

__all__ = ["triangulate_views", "throw_rotation", "REPROJECTION"]

#: Flag of a world row whose reprojection error is far above the run's typical error.
REPROJECTION = 1

_MIN_OVERLAP = 8
_FINE_STEP = 0.05


def _usable(track):
    from vidtrack.world.attitude import image_angle

    d = track.data
    ok = track.usable
    if all(c in d for c in _SHAPE_COLUMNS):
        shape = np.column_stack([image_angle(d), d[list(_SHAPE_COLUMNS[1:])].to_numpy(float)])
        shape = shape[ok]
    else:
        shape = np.full((int(np.count_nonzero(ok)), len(_SHAPE_COLUMNS)), np.nan)
    ends = (d[list(END_COLUMNS)].to_numpy(float)[ok] if all(c in d for c in END_COLUMNS)
            else np.full((int(np.count_nonzero(ok)), len(END_COLUMNS)), np.nan))
    return d["frame"].to_numpy()[ok], d[["u_px", "v_px"]].to_numpy(float)[ok], shape, ends


#: A track's columns that describe the rod's image (the tracker's; NaN for points); the
#: angle is the rod's ends' where the tracker gives them
#: (:func:`vidtrack.world.attitude.image_angle`).
_SHAPE_COLUMNS = ("angle_rad", "length_px", "area_px")
#: The rod correction's settings: two views' planes must be this far from parallel, a
#: view's image this elongated (axis length / diameter of the capsule its moments fit)
#: for its angle to count, and the correction is iterated this many times.
ROD_MIN_PLANE_ANGLE_DEG = MIN_PLANE_ANGLE_DEG
ROD_MIN_ELONGATION = MIN_ELONGATION
ROD_ITERATIONS = 2
#: Rows without an axis between rows with one are interpolated (the rod turns smoothly)
#: across at most this many rows where the axes on either side differ by at most this.
ROD_MAX_GAP_ROWS = 60
ROD_MAX_GAP_TURN_DEG = 60.0


def _fill_axis(axis, t):
    """Axes interpolated in time across short gaps (in place); returns how many rows."""
    have = np.flatnonzero(np.all(np.isfinite(axis), axis=1))
    if have.size < 2:
        return 0
    for i in range(1, have.size):                 # one sense along the flight
        if np.dot(axis[have[i]], axis[have[i - 1]]) < 0:
            axis[have[i]] = -axis[have[i]]
    filled = 0
    for a, b in zip(have[:-1], have[1:]):
        if b - a < 2 or b - a - 1 > ROD_MAX_GAP_ROWS:
            continue
        if np.degrees(np.arccos(np.clip(np.dot(axis[a], axis[b]), -1, 1))) > \
                ROD_MAX_GAP_TURN_DEG:
            continue
        w = ((t[a + 1:b] - t[a]) / (t[b] - t[a]))[:, None]
        mid = (1 - w) * axis[a] + w * axis[b]
        axis[a + 1:b] = mid / np.linalg.norm(mid, axis=1, keepdims=True)
        filled += int(b - a - 1)
    return filled


#: How far (in frames) a view's pixels are carried on, once the offsets are found, beyond a
#: frame with none after it (or before): an offset within a hundredth of a frame of a
#: whole frame is that frame within what the reprojection error can tell (a few
#: hundredths on synchronous views), and the straight line through two frames misses a
#: curved track by ``a r (1 + r) / 2`` over ``r`` frames (``a`` its change of velocity per
#: frame). Farther (0.03 frames on a real 25 fps rig) the frame is left out: carried on,
#: the rig's first point of one camera, 4 px from the others', moved its fitted g by 5 %.
_REACH = 0.01
#: How far (in frames) beside a gap inside a view's track (a frame tracked beyond it too:
#: an excluded or flagged frame, not the track's end) its pixels are carried on. The
#: offset found on synchronous views is a few hundredths off the whole frame (0.0099
#: and, with cam1's frames 180..194 excluded, 0.0108 on the synthetic rig of
#: tests/test_corrections.py), and at :data:`_REACH` every frame beside a gap of the
#: other view flipped out of the world track with that last ten-thousandth (7 of 271).
#: Carried on 0.05 frame (the refinement's step) the straight line misses the track by
#: ``a 0.026``, far below a reprojection error; a track's first and last points, which
#: the 25 fps rig showed to be the ones to fear, keep :data:`_REACH` (that rig's g from
#: k1, k2 moves from 10.11, 9.655 to 10.125, 9.639 m/s^2, its 25 rows as before).
_REACH_GAP = 0.05


def _at(times, t_view, uv_view, fps, *, reach=0.0, reach_gap=None):
    """The view's pixels at ``times`` (its clock), between its frames.

    Cubic (4-point Lagrange) where the two frames on each side are consecutive, linear
    where only the bracketing pair is. Within ``reach`` frames of a frame whose frame on
    the other side is missing (an excluded or lost frame, the track's end), the straight
    line through it and its consecutive neighbour carried on (:data:`_REACH` once the
    offsets are found: an offset found a hundredth of a frame off zero does not lose the
    frames next to a gap; none while they are searched for, which weigh the frames the
    views share); beside a gap with frames on both sides, within ``reach_gap`` frames
    (default ``reach``; :data:`_REACH_GAP` once the offsets are found). NaN elsewhere.
    """
    out = np.full((len(times), 2), np.nan)
    n = len(t_view)
    if n < 2:
        return out
    step = 1.0 / fps
    j = np.clip(np.searchsorted(t_view, times), 1, n - 1)
    t0, t1 = t_view[j - 1], t_view[j]
    tol = 1e-6 * step
    exact0 = np.abs(times - t0) <= tol
    exact1 = np.abs(times - t1) <= tol
    inside = (times > t0) & (times < t1) & (t1 - t0 <= 1.5 * step) & ~exact0 & ~exact1
    w = np.where(inside, (times - t0) / np.where(t1 > t0, t1 - t0, 1.0), 0.0)
    out[inside] = (uv_view[j - 1] * (1 - w[:, None]) + uv_view[j] * w[:, None])[inside]
    # cubic where frames j-2 .. j+1 are consecutive
    jm, jp = j - 2, j + 1
    cub = inside & (jm >= 0) & (jp < n)
    if cub.any():
        jc = j[cub]
        tt = np.stack([t_view[jc - 2], t_view[jc - 1], t_view[jc], t_view[jc + 1]], axis=1)
        even = np.all(np.abs(np.diff(tt, axis=1) - step) <= 0.25 * step, axis=1)
        x = times[cub]
        coef = np.ones((len(jc), 4))
        for a in range(4):
            for b in range(4):
                if a != b:
                    coef[:, a] *= (x - tt[:, b]) / (tt[:, a] - tt[:, b])
        pts = np.stack([uv_view[jc - 2], uv_view[jc - 1], uv_view[jc], uv_view[jc + 1]], axis=1)
        val = np.einsum("na,nak->nk", coef, pts)
        rows = np.flatnonzero(cub)[even]
        out[rows] = val[even]
    out[exact0] = uv_view[j - 1][exact0]
    out[exact1] = uv_view[j][exact1]
    if not reach > 0:
        return out
    # beside a gap: carried on from the nearest frame and its neighbour on the far side
    k = np.where(np.abs(times - t0) <= np.abs(times - t1), j - 1, j)
    d = times - t_view[k]
    far = np.where(d < 0, k + 1, k - 1)
    # beside a gap inside the track (the view has a frame beyond it) or at its end
    inner = np.where(d < 0, k > 0, k < n - 1)
    lim = np.where(inner, reach if reach_gap is None else max(reach, reach_gap), reach)
    ok = np.isnan(out[:, 0]) & (np.abs(d) <= lim * step) & (far >= 0) & (far < n)
    if ok.any():
        kk, ff, dd = k[ok], far[ok], d[ok]
        gap = t_view[kk] - t_view[ff]
        near = np.abs(np.abs(gap) - step) <= 0.25 * step
        rows = np.flatnonzero(ok)[near]
        kk, ff, dd, gap = kk[near], ff[near], dd[near], gap[near]
        out[rows] = uv_view[kk] + (uv_view[kk] - uv_view[ff]) * (dd / gap)[:, None]
    return out


def _views_cost(cameras, clocks, offsets, reference, focus, *, smooth=False):
    """How badly view ``focus`` agrees with the other views placed in time: the median
    reprojection distance of the linear triangulation over the frames ``focus`` and at
    least one other view saw (with ``smooth``, the RMS of the best 80 %: a smooth function
    of the offsets, for refining); inf with fewer than the minimum overlap."""
    from calibration.triangulation import _linear

    names = [n for n in clocks if n in offsets]
    t_rows = clocks[reference][0] - offsets[reference]
    obs = np.stack([clocks[n][1] if n == reference
                    else _at(t_rows + offsets[n], *clocks[n][:3]) for n in names], axis=1)
    seen = np.all(np.isfinite(obs), axis=2)
    rows = (seen.sum(axis=1) >= 2) & seen[:, names.index(focus)]
    if rows.sum() < _MIN_OVERLAP:
        return np.inf
    obs, seen = obs[rows], seen[rows]
    cams = [cameras[n] for n in names]
    ideal = np.stack([c.ideal(obs[:, k]) for k, c in enumerate(cams)], axis=1)
    xyz = _linear(cams, ideal, seen)
    err = np.concatenate([np.linalg.norm(c.project(xyz) - obs[:, k], axis=1)[seen[:, k]]
                          for k, c in enumerate(cams)])
    err = np.sort(err[np.isfinite(err)])
    if not err.size:
        return np.inf
    if smooth:
        return float(np.sqrt(np.mean(err[: max(1, int(0.8 * err.size))] ** 2)))
    return float(np.median(err))


def _refine(cameras, clocks, offsets, reference, name, centre_frames):
    """The offset of ``name`` near ``centre_frames`` (frames), to a fraction of a frame."""
    fps = clocks[name][2]
    fine = centre_frames + np.arange(-1.0, 1.0 + _FINE_STEP / 2, _FINE_STEP)
    cost = np.array([_views_cost(cameras, clocks, {**offsets, name: f / fps}, reference,
                                 name, smooth=True) for f in fine])
    k = int(np.argmin(cost))
    best = fine[k]
    if 0 < k < len(fine) - 1 and np.all(np.isfinite(cost[k - 1:k + 2])):
        a, b, c = cost[k - 1:k + 2]
        denom = a - 2 * b + c
        if denom > 0:
            best += 0.5 * (a - c) / denom * _FINE_STEP
    return best


def _auto_offsets(cameras, clocks, offsets, reference, how):
    """Offsets of the views without one: whole frames first (each view against those
    already placed), then every such view refined to a fraction with all the others."""
    todo = [n for n in sorted(clocks, key=lambda n: -len(clocks[n][0])) if n not in offsets]
    frames, margins = {}, {}
    for name in todo:
        t_o, _, fps_o = clocks[name][:3]
        span = max(clocks[reference][0][-1] - clocks[reference][0][0], t_o[-1] - t_o[0])
        steps = np.arange(-int(np.ceil(span * fps_o)), int(np.ceil(span * fps_o)) + 1)
        cost = np.array([_views_cost(cameras, clocks, {**offsets, name: s / fps_o}, reference,
                                     name) for s in steps])
        if not np.isfinite(cost).any():
            raise TrackError(f"view {name}: no frame offset lets it see the object together "
                             f"with the other views on {_MIN_OVERLAP} or more frames: give "
                             "sync_frame for each view")
        ranked = np.sort(cost[np.isfinite(cost)])
        margins[name] = ranked[1] / ranked[0] if len(ranked) > 1 and ranked[0] > 0 else np.inf
        frames[name] = float(steps[int(np.argmin(cost))])
        offsets[name] = frames[name] / fps_o
    for _ in range(2):
        for name in todo:
            frames[name] = _refine(cameras, clocks, offsets, reference, name, frames[name])
            offsets[name] = frames[name] / clocks[name][2]
    warnings = []
    for name in todo:
        how[name] = f"reprojection ({frames[name]:+.2f} frames against {reference})"
        log.info("view %s: clock offset %+.2f frames from the reprojection error", name,
                 frames[name])
        if margins[name] < 1.5:
            warnings.append(f"view {name}: the automatic frame offset is weakly determined "
                            f"(the next best whole-frame offset agrees {margins[name]:.2f}x "
                            "as badly): give sync_frame")
    return warnings


def _robust_threshold(err):
    med = float(np.median(err))
    mad = float(np.median(np.abs(err - med))) * 1.4826
    return med, max(med + 6 * mad, 2 * med, 0.5)


def throw_rotation(xyz, t, up, forward=None):
    """Rows X, Y, Z of the throw frame in the calibration's frame.

    Parameters
    ----------
    xyz : array_like, shape (N, 3)
        Points in the calibration's frame (NaN rows ignored).
    t : array_like, shape (N,)
        Their times (s).
    up : array_like, shape (3,)
        The vertical, against gravity.
    forward : array_like, shape (3,), optional
        The throwing direction; its horizontal part is X.

    Returns
    -------
    (numpy.ndarray, str)
        The rotation and where X came from (``"given"``, ``"initial velocity"``,
        ``"displacement"``, ``"none"``: no horizontal motion, X is the calibration axis
        most nearly horizontal).
    """
    y = np.asarray(up, dtype=np.float64)
    y = y / np.linalg.norm(y)

    def horizontal(v):
        h = np.asarray(v, dtype=np.float64) - np.dot(v, y) * y
        return h / np.linalg.norm(h) if np.linalg.norm(h) > 1e-9 * max(np.linalg.norm(v), 1e-300) \
            else None

    source, x = "given", None
    if forward is not None:
        x = horizontal(forward)
    else:
        xyz = np.asarray(xyz, dtype=np.float64)
        t = np.asarray(t, dtype=np.float64)
        ok = np.all(np.isfinite(xyz), axis=1)
        if ok.sum() >= 3:
            tt = t[ok] - t[ok][0]
            coef, *_ = np.linalg.lstsq(np.column_stack([np.ones_like(tt), tt, tt * tt]),
                                       xyz[ok], rcond=None)
            v0 = coef[1]
            h = horizontal(v0)
            if h is not None and np.linalg.norm(v0 - np.dot(v0, y) * y) > 0.02 * np.linalg.norm(v0):
                source, x = "initial velocity", h
            else:
                h = horizontal(xyz[ok][-1] - xyz[ok][0])
                if h is not None:
                    source, x = "displacement", h
    if x is None:
        axis = np.eye(3)[int(np.argmin(np.abs(y)))]
        source, x = ("none" if forward is None else "given"), horizontal(axis)
    z = np.cross(x, y)
    return np.vstack([x, y, z]), source


def _rod_lines(uv, shape_rows):
    """A view's image lines at the rows: the unit direction (camera's convention; NaN
    where the image is not elongated enough to give an angle) and the capsule its moments
    fit (axis length, radius; px)."""
    from vidtrack.world.rod_centroid import capsule_from_moments

    c2, s2, length, area = shape_rows.T
    theta = 0.5 * np.arctan2(s2, c2)
    ell, rho = capsule_from_moments(length, area)
    with np.errstate(invalid="ignore", divide="ignore"):
        long_enough = ell >= ROD_MIN_ELONGATION * 2.0 * rho
    direction = np.column_stack([np.cos(theta), np.sin(theta)])
    direction[~(long_enough & np.all(np.isfinite(uv), axis=1))] = np.nan
    return direction, ell, rho


def _rod_axis(cams, uvs, shapes):
    """The views' image lines at the rows (:func:`_rod_lines`) and the rod's axis they
    give (calibration frame, (N, 3); NaN where not measured)."""
    from vidtrack.world.rod_centroid import axis_from_lines

    lines = [_rod_lines(uv, sh) for uv, sh in zip(uvs, shapes)]
    axis, _ = axis_from_lines(cams, np.stack(uvs, axis=1),
                              np.stack([ln[0] for ln in lines], axis=1),
                              min_angle_deg=ROD_MIN_PLANE_ANGLE_DEG)
    return lines, axis


def _rod_correction(cams, uvs, lines, axis, tri, taper, t_rows, ends):
    """Correct each view's centroids for the rod's perspective and triangulate again.

    ``lines`` and ``axis``: the views' image lines and the axis measured from them
    (:func:`_rod_axis`); ``ends``: each view's rod ends at the rows ((N, 4) px, NaN where
    none): where a view has them its point is where it images the rod's 3-D centre
    (:func:`vidtrack.world.rod_centroid.centre_from_ends`), elsewhere its centroid less
    the silhouette's predicted offset. Returns the new triangulation, the corrections'
    lengths (N, M; NaN where none) and the settings found (taper, length_m, radius_m,
    ...), or the first triangulation and None where the rod could not be measured."""
    from calibration.triangulation import triangulate

    from vidtrack.world.rod_centroid import centre_from_ends, pixels_per_m, silhouette_bias

    n, m = len(uvs[0]), len(cams)
    axis = np.array(axis, copy=True)
    measured = int(np.all(np.isfinite(axis), axis=1).sum())
    filled = _fill_axis(axis, t_rows)
    xyz = tri.xyz
    rows = np.all(np.isfinite(axis), axis=1) & np.all(np.isfinite(xyz), axis=1)
    # the rod's size: each view where its image is elongated and it lies at least 70 %
    # across the line of sight, the capsule of its moments scaled back to metres
    lengths, radii = [], []
    probe = 0.1
    for cam, (direction, ell, rho) in zip(cams, lines):
        ok = rows & np.all(np.isfinite(direction), axis=1) & np.isfinite(ell)
        if not ok.any():
            continue
        x, d = xyz[ok], axis[ok]
        sight = x - cam.centre
        sight /= np.linalg.norm(sight, axis=1, keepdims=True)
        across = np.sqrt(np.clip(1.0 - np.sum(d * sight, axis=1) ** 2, 0.0, None))
        unit = np.linalg.norm(cam.project(x + 0.5 * probe * d) - cam.project(x - 0.5 * probe * d),
                              axis=1) / probe
        keep = across >= 0.7
        lengths.append((ell[ok] / unit)[keep])
        radii.append((rho[ok] / pixels_per_m(cam, x))[keep])
    lengths = np.concatenate(lengths) if lengths else np.empty(0)
    radii = np.concatenate(radii) if radii else np.empty(0)
    lengths, radii = lengths[np.isfinite(lengths)], radii[np.isfinite(radii)]
    if lengths.size < _MIN_OVERLAP or not rows.any():
        return tri, None, None
    length_m, radius_m = float(np.median(lengths)), float(np.median(radii))
    shifts = np.full((n, m), np.nan)
    for _ in range(ROD_ITERATIONS):
        from_ends = 0
        rows = np.all(np.isfinite(axis), axis=1) & np.all(np.isfinite(tri.xyz), axis=1)
        fixed = []
        for j, (cam, uv) in enumerate(zip(cams, uvs)):
            bias = np.zeros_like(uv)
            bias[rows] = silhouette_bias(cam, tri.xyz[rows], axis[rows], length_m, radius_m,
                                         taper=taper)
            bias[~np.isfinite(bias)] = 0.0
            at_ends = rows & np.all(np.isfinite(ends[j]), axis=1)
            if at_ends.any():
                centre = centre_from_ends(cam, ends[j][at_ends, :2], ends[j][at_ends, 2:],
                                          tri.xyz[at_ends], axis[at_ends],
                                          length_m=length_m, taper=taper)
                good = np.all(np.isfinite(centre), axis=1)
                bias[np.flatnonzero(at_ends)[good]] = uv[at_ends][good] - centre[good]
                from_ends += int(good.sum())
            fixed.append(uv - bias)
            shifts[:, j] = np.where(rows & np.all(np.isfinite(uv), axis=1),
                                    np.linalg.norm(bias, axis=1), np.nan)
        tri = triangulate(cams, fixed)
    settings = {"taper": taper, "length_m": length_m, "radius_m": radius_m,
                "min_plane_angle_deg": ROD_MIN_PLANE_ANGLE_DEG,
                "iterations": ROD_ITERATIONS, "rows_axis_measured": measured,
                "rows_axis_interpolated": filled, "view_rows_from_ends": from_ends}
    return tri, shifts, settings


def triangulate_views(tracks, cameras, *, fps, sync=None, image_heights=None, up,
                      forward=None, rod="perspective"):
    """Triangulate the views' tracks frame by frame and rotate into the throw's frame.

    Parameters
    ----------
    tracks : dict of str to vidtrack.track.tracker.Track
        Two or more views. Pixels are in vidtrack's image convention (top-left) for
        tracked footage; points read from a file are in their camera's convention.
    cameras : dict of str to calibration.projective.ProjectiveCamera
    fps : dict of str to float
    sync : dict of str to int or "auto", optional
        The frame of each view at t = 0; "auto" or missing: found from the data.
    image_heights : dict of str to int, optional
        Frame heights of views whose pixels are in the top-left convention while their
        camera's is bottom-left (tracked footage with a DLTdv calibration).
    up, forward : array_like, shape (3,)
        The world's vertical and (optional) throwing direction in the calibration frame.
    rod : {"perspective", "uniform"} or None
        Correct the views' centroids for the perspective of a rod (see the module):
        ``"perspective"`` (default) for a real rod, its near end imaged wider;
        ``"uniform"`` for a silhouette of one width (as ``vidtrack synth`` draws it);
        None: the centroids as measured. Views without the tracker's ``angle_rad``,
        ``length_px`` and ``area_px`` (points digitized elsewhere) give no axis.

    Returns
    -------
    vidtrack.world.world_track.WorldTrack
        ``kind = "calibrated"``: rows at the reference view's frames that two or more
        views saw, ``t_s`` from the first of them, the throw's frame in ``x_m, y_m,
        z_m`` (NaN where flagged) and the triangulation's own columns; ``tracks`` the
        views' tracks as given.

    Raises
    ------
    TrackError
        Fewer than two views, no frame seen by two views, an offset that cannot be found.
    """
    import pandas as pd

    from calibration.triangulation import triangulate

    from vidtrack.world.rod_centroid import TAPERS

    if rod is not None and rod not in TAPERS:
        raise ValueError(f"rod must be one of {TAPERS} or None, got {rod!r}")
    names = list(tracks)
    if len(names) < 2:
        raise TrackError("calibrated cameras: triangulation needs two or more views; "
                         f"the scene has {len(names)} ({', '.join(names)})")
    sync = dict(sync or {})
    image_heights = dict(image_heights or {})
    clocks, shapes, ends = {}, {}, {}
    for n in names:
        frames, uv, shape, ends[n] = _usable(tracks[n])
        # the image angle as a doubled-angle vector (interpolates across +-pi/2)
        c, si = np.cos(shape[:, 0]), np.sin(shape[:, 0])
        if n in image_heights:
            uv = cameras[n].from_image_pixels(uv, image_heights[n])
            ends[n] = np.column_stack([cameras[n].from_image_pixels(ends[n][:, k:k + 2],
                                                                    image_heights[n])
                                       for k in (0, 2)])
            si = -si
        shapes[n] = (np.column_stack([c * c - si * si, 2.0 * c * si]), shape[:, 1:3])
        if len(frames) < 2:
            raise TrackError(f"view {n}: {len(frames)} usable frame(s): nothing to triangulate")
        clocks[n] = (frames / float(fps[n]), uv, float(fps[n]), frames)
    reference = max(names, key=lambda n: len(clocks[n][0]))
    offsets, how = {}, {}
    for n in names:
        s = sync.get(n, "auto")
        if s not in (None, "auto"):
            offsets[n] = float(s) / float(fps[n])
            how[n] = f"sync_frame {s}"
    if reference not in offsets:
        given = [n for n in names if n in offsets]
        if given:       # the clock of a view with sync_frame is the reference
            reference = max(given, key=lambda n: len(clocks[n][0]))
        else:
            offsets[reference] = 0.0
            how[reference] = "reference"
    warnings = _auto_offsets(cameras, {n: c[:3] for n, c in clocks.items()}, offsets,
                             reference, how)
    ref_clock = clocks[reference]
    t_rows = ref_clock[0] - offsets[reference]
    uvs = [ref_clock[1] if n == reference
           else _at(t_rows + offsets[n], clocks[n][0], clocks[n][1], clocks[n][2],
                    reach=_REACH, reach_gap=_REACH_GAP)
           for n in names]
    cams = [cameras[n] for n in names]
    tri = triangulate(cams, uvs)
    shifts = settings = None
    axis = np.full((len(t_rows), 3), np.nan)
    shaped = any(np.isfinite(shapes[n][0]).any() for n in names)
    if shaped:
        rows_shape = [np.column_stack(
            [shapes[n][0], shapes[n][1]] if n == reference else
            [_at(t_rows + offsets[n], clocks[n][0], shapes[n][k], clocks[n][2], reach=_REACH,
                 reach_gap=_REACH_GAP) for k in (0, 1)]) for n in names]
        lines, axis = _rod_axis(cams, uvs, rows_shape)
    if rod is not None and shaped:
        rows_ends = [ends[n] if n == reference else np.column_stack(
            [_at(t_rows + offsets[n], clocks[n][0], ends[n][:, k:k + 2], clocks[n][2],
                 reach=_REACH, reach_gap=_REACH_GAP) for k in (0, 2)]) for n in names]
        tri, shifts, settings = _rod_correction(cams, uvs, lines, axis, tri, rod, t_rows,
                                                rows_ends)
        if shifts is None:
            log.info("rod correction: the rod's length could not be measured (too few "
                     "frames with an elongated image in a view): centroids as measured")
    ok = np.isfinite(tri.xyz[:, 0])
    if ok.sum() < 3:
        raise TrackError("calibrated cameras: fewer than 3 frames are seen by two or more "
                         f"views ({int(ok.sum())}): check the views' sync_frame and that each "
                         "view follows the same object")
    res = tri.residual_px[ok]
    med, thr = _robust_threshold(res[np.isfinite(res)])
    flags = np.where(np.nanmax(np.where(np.isfinite(res), res, 0), axis=1) > thr,
                     REPROJECTION, 0)
    xyz = tri.xyz[ok]
    t = t_rows[ok]
    t = t - t[0]
    keep = flags == 0
    rot, source = throw_rotation(np.where(keep[:, None], xyz, np.nan), t, up, forward)
    local = xyz @ rot.T
    data = {"frame": ref_clock[3][ok], "t_s": t, "x_m": np.where(keep, local[:, 0], np.nan),
            "y_m": np.where(keep, local[:, 1], np.nan),
            "z_m": np.where(keep, local[:, 2], np.nan), "views": tri.views[ok],
            "flags": flags}
    for j, n in enumerate(names):
        data[f"reprojection_px_{n}"] = res[:, j]
    data.update({"X_m": xyz[:, 0], "Y_m": xyz[:, 1], "Z_m": xyz[:, 2]})
    if shifts is not None:
        for j, n in enumerate(names):
            data[f"rod_shift_px_{n}"] = shifts[ok, j]
        done = np.isfinite(shifts[ok]).any(axis=1)
        log.info("rod correction (%s, %.3g m x %.3g m): %d of %d rows corrected, median "
                 "%.3g px", rod, settings["length_m"], 2 * settings["radius_m"],
                 int(done.sum()), len(done), float(np.nanmedian(shifts[ok])))
    # the rod's attitude in the throw's frame, where measured (not where flagged)
    data.update(attitude_columns(np.where(keep[:, None], axis[ok] @ rot.T, np.nan), t))
    good = res[keep]
    med_ok = float(np.median(good[np.isfinite(good)])) if keep.any() else med
    if int(np.count_nonzero(flags)):
        log.info("%d of %d triangulated frames flagged: reprojection error beyond %.3g px",
                 int(np.count_nonzero(flags)), len(flags), thr)
    return WorldTrack(data=pd.DataFrame(data), t0_s={}, sync=how, reference=reference,
                      kind="calibrated", warnings=tuple(warnings), tracks=dict(tracks),
                      offsets_s=offsets, rotation=rot, forward_from=source,
                      median_reprojection_px=med_ok, flag_threshold_px=thr, rod=settings)
