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

The throw's frame: the calibration's frame is rotated so that Y is up (``[world] up``) and
X is the throw's horizontal direction (``[world] forward``, or the horizontal part of the
initial velocity of a quadratic fitted to the points); Z = X x Y completes a right-handed
frame, as the orthogonal rigs' frame is (X outward, Y up, Z along the travel). k1..k4 keep
their meaning.
"""

import logging
from dataclasses import dataclass

import numpy as np

from vidtrack.errors import TrackError

log = logging.getLogger(__name__)

__all__ = ["CalibratedWorld", "triangulate_views", "throw_rotation", "REPROJECTION"]

#: Flag of a world row whose reprojection error is far above the run's typical error.
REPROJECTION = 1

_MIN_OVERLAP = 8
_FINE_STEP = 0.05


@dataclass(frozen=True, eq=False)
class CalibratedWorld:
    """Triangulated points of one run, in the calibration's frame and the throw's.

    Attributes
    ----------
    data : pandas.DataFrame
        One row per frame of the reference view that two or more views saw: ``frame``
        (the reference view's frame), ``t_s`` (s from the first triangulated frame),
        ``x_m, y_m, z_m`` (the throw's frame; NaN where flagged), ``views`` (how many
        saw it), ``reprojection_px_<view>`` (each view's reprojection distance, NaN where
        it did not see the point), ``flags``
        (:data:`REPROJECTION`), and ``X_m, Y_m, Z_m`` (the calibration's frame, unflagged
        or not).
    reference : str
        The view whose frames are the rows.
    offsets_s : dict
        View -> its clock's offset (s): t = frame / fps - offset.
    sync : dict
        View -> how the offset was found (``"sync_frame 12"``, ``"reference"``,
        ``"reprojection (+3.45 frames)"``).
    rotation : numpy.ndarray, shape (3, 3)
        Rows: the throw frame's X, Y, Z axes in the calibration's frame.
    forward_from : str
        ``"given"``, ``"initial velocity"``, ``"displacement"`` or ``"none"``.
    median_reprojection_px : float
        Median reprojection distance over every view and unflagged row.
    flag_threshold_px : float
        Rows with any view beyond this are flagged.
    warnings : tuple of str
    """

    data: object
    reference: str
    offsets_s: dict
    sync: dict
    rotation: np.ndarray
    forward_from: str
    median_reprojection_px: float
    flag_threshold_px: float
    warnings: tuple = ()

    def __repr__(self):
        ok = int(np.count_nonzero(self.data["flags"].to_numpy() == 0))
        return (f"CalibratedWorld(rows={len(self.data)}, unflagged={ok}, "
                f"reference={self.reference!r}, "
                f"median_reprojection_px={self.median_reprojection_px:.3g})")

    def to_dict(self):
        """A JSON-ready summary (not the rows)."""
        flags = self.data["flags"].to_numpy()
        return {"rows": int(len(self.data)), "reference": self.reference,
                "flagged": int(np.count_nonzero(flags)),
                "offsets_s": {k: float(v) for k, v in self.offsets_s.items()},
                "sync": dict(self.sync), "rotation": self.rotation.tolist(),
                "forward_from": self.forward_from,
                "median_reprojection_px": float(self.median_reprojection_px),
                "flag_threshold_px": float(self.flag_threshold_px),
                "warnings": list(self.warnings)}


def _usable(track):
    d = track.data
    ok = track.usable
    return d["frame"].to_numpy()[ok], d[["u_px", "v_px"]].to_numpy(float)[ok]


def _at(times, t_view, uv_view, fps):
    """The view's pixels at ``times`` (its clock), between its frames.

    Cubic (4-point Lagrange) where the two frames on each side are consecutive, linear
    where only the bracketing pair is; NaN where the bracketing frames are not adjacent.
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


def triangulate_views(tracks, cameras, *, fps, sync=None, image_heights=None, up,
                      forward=None):
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

    Returns
    -------
    CalibratedWorld

    Raises
    ------
    TrackError
        Fewer than two views, no frame seen by two views, an offset that cannot be found.
    """
    import pandas as pd

    from calibration.triangulation import triangulate

    names = list(tracks)
    if len(names) < 2:
        raise TrackError("calibrated cameras: triangulation needs two or more views; "
                         f"the scene has {len(names)} ({', '.join(names)})")
    sync = dict(sync or {})
    image_heights = dict(image_heights or {})
    clocks = {}
    for n in names:
        frames, uv = _usable(tracks[n])
        if n in image_heights:
            uv = cameras[n].from_image_pixels(uv, image_heights[n])
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
           else _at(t_rows + offsets[n], clocks[n][0], clocks[n][1], clocks[n][2])
           for n in names]
    tri = triangulate([cameras[n] for n in names], uvs)
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
    good = res[keep]
    med_ok = float(np.median(good[np.isfinite(good)])) if keep.any() else med
    if int(np.count_nonzero(flags)):
        log.info("%d of %d triangulated frames flagged: reprojection error beyond %.3g px",
                 int(np.count_nonzero(flags)), len(flags), thr)
    return CalibratedWorld(data=pd.DataFrame(data), reference=reference, offsets_s=offsets,
                           sync=how, rotation=rot, forward_from=source,
                           median_reprojection_px=med_ok, flag_threshold_px=thr,
                           warnings=tuple(warnings))
