"""The two-view merge: both tracks on one time base, the shared X checked, the 3-D track.

The ``front`` view sees world X and Y, the ``top`` view X and Z (docs/reference.md). Both see
X, which is how they are put on one clock and checked against each other:

1. **Time zero.** A view's ``sync`` is a frame index (the frame at which t = 0, from
   ``scene.toml``'s ``sync_frame``) or ``"auto"``. With ``"auto"`` the reference view
   (``front`` when it has a detected release, else a view that has one) takes t = 0 at
   its release instant (:attr:`vidtrack.track.tracker.Track.release_t_s`, between frames);
   without any release the first usable frame of the reference view is t = 0 (noted).
2. **The other view's offset.** A view with ``"auto"`` that is not the reference is
   shifted onto the reference's clock by the offset that minimises the mean squared
   disagreement of the shared X (its X linearly interpolated between its usable frames,
   never across gaps): a grid of a quarter frame, then Brent's method to a small
   fraction of a frame. X must change by at least 5 pixels over the overlap.
3. **The check.** On the common clock the RMS difference of the two X measurements is
   reported (m and px); a warning is recorded when it exceeds the coarser view's pixel
   scale: the views disagree (scale, origin or sync). A view whose own axis (y, z)
   covers less than half of the world track's time span is noted (on stderr too): what
   is fitted on it rests on that part of the flight.
4. **Before t = 0.** Every view's frames before its t = 0 (less 0.2 frame, the
   tracker's rule for the release frame) are flagged PRE_RELEASE, and only they: a view
   whose release was not identifiable on its own (the ``top`` view, which sees the
   rotor's plane edge-on) gets the release carried over from the reference through the
   shared X, and a ``sync_frame`` overrides a detected release. The re-flagged tracks
   are :attr:`WorldTrack.tracks`.
5. **The world track.** Rows at the reference view's frames from t = 0 on (``frame``, the
   reference view's file frame, and ``t_s``): x from the
   reference view (from the other where the reference has no usable point), y from
   ``front``, z from ``top``; a coordinate of the other view is interpolated between its
   usable frames at t >= 0 no more than 2 of its frames apart. NaN where not measured;
   with one view its missing axis is NaN throughout.

Perspective (:mod:`vidtrack.world.parallax`): once the views are on one clock, a view
whose mapping has ``camera_distance_m`` has each point's scale corrected by its depth,
which the other view measures (before the check of step 3); without it nothing is
corrected, and the fit stage weighs what that could do to k
(:mod:`vidtrack.run.perspective`).

Only usable points (flags 0) enter: flagged frames never become world coordinates, and
no point of any view from before its t = 0 reaches the world track.
"""

import logging
from dataclasses import replace

import numpy as np
import pandas as pd

from vidtrack.errors import TrackError
from vidtrack.track.tracker import PRE_RELEASE
from vidtrack.world.parallax import correct_parallax
from vidtrack.world.resample import frame_step as _frame_step
from vidtrack.world.resample import interp_gapless as _interp_gapless
from vidtrack.world.world_track import WorldTrack

log = logging.getLogger(__name__)

__all__ = ["merge_tracks", "view_world", "reference_frames", "WORLD_COLUMNS"]

#: Columns of :attr:`WorldTrack.data` (tracks.h5's ``/world`` and world.csv keep all but
#: ``frame``, which the reference view's track gives back: :func:`reference_frames`).
WORLD_COLUMNS = ("frame", "t_s", "x_m", "y_m", "z_m")
#: Fraction of the world track's time span under which a view's own axis is noted as
#: covering only part of the flight (:func:`_coverage_notes`).
COVERAGE_NOTE_FRACTION = 0.5
#: Most passes of finding an offset again on the perspective-corrected shared X.
_RESYNC_PASSES = 4
_AXES = ("x", "y", "z")


def view_world(track, mapping):
    """Usable points of one view in world metres on its source clock.

    Parameters
    ----------
    track : vidtrack.track.tracker.Track
    mapping : calibration.ViewMapping
        The view's pixel -> world mapping.

    Returns
    -------
    pandas.DataFrame
        Columns ``frame``, ``t_s`` (source clock) and one ``<axis>_m`` column per world
        axis the view sees, for the usable rows only.
    """
    d = track.data[track.usable]
    w = mapping.pixel_to_world(d[["u_px", "v_px"]].to_numpy(dtype=np.float64)) \
        if len(d) else np.empty((0, 2))
    out = {"frame": d["frame"].to_numpy(), "t_s": d["t_s"].to_numpy(dtype=np.float64)}
    for k, axis in enumerate(mapping.world_axes):
        out[f"{axis}_m"] = w[:, k]
    return pd.DataFrame(out)


def _shared_x_offset(ref_w, t0_ref, other_w, other_step, *, min_overlap, name, scale):
    """t0 of the other view (its clock) that best matches its X to the reference's."""
    from scipy.optimize import minimize_scalar

    tr = ref_w["t_s"].to_numpy() - t0_ref
    xr = ref_w["x_m"].to_numpy()
    to = other_w["t_s"].to_numpy()
    xo = other_w["x_m"].to_numpy()
    if tr.size < min_overlap or to.size < min_overlap:
        raise TrackError(f"view {name}: too few usable points to find its offset from the "
                         f"shared X ({to.size} here, {tr.size} in the reference view; "
                         f"need {min_overlap}): the straw was tracked in too few frames "
                         "('vidtrack -v fit' says how many each view tracked; a straw "
                         f"thinner than a pixel is lost); give views.{name}.sync_frame if "
                         "the tracks are right")
    max_step = 2.5 * other_step

    def cost(t0):
        xi = _interp_gapless(tr + t0, to, xo, max_step)
        ok = np.isfinite(xi)
        if np.count_nonzero(ok) < min_overlap:
            return np.inf
        return float(np.mean((xi[ok] - xr[ok]) ** 2))

    def costs_of(t0s):
        # cost() for many offsets at once, in blocks of about 16k points (their
        # temporaries stay in the cache instead of being mapped afresh each time)
        out = np.empty(t0s.size)
        per = max(1, 16_384 // max(tr.size, 1))
        for a in range(0, t0s.size, per):
            xi = _interp_gapless(tr[None, :] + t0s[a:a + per, None], to, xo, max_step)
            ok = np.isfinite(xi)
            cnt = np.count_nonzero(ok, axis=1)
            sq = np.sum(np.where(ok, (xi - xr) ** 2, 0.0), axis=1)
            out[a:a + per] = np.where(cnt >= min_overlap, sq / np.maximum(cnt, 1), np.inf)
        return out

    lo = to[0] - tr[-1]
    hi = to[-1] - tr[0]
    grid = np.arange(lo, hi + 1e-12, 0.25 * other_step)
    costs = costs_of(grid)
    if not np.isfinite(costs).any():
        raise TrackError(
            f"view {name}: its {to.size} usable points (t = {to[0]:.4g}..{to[-1]:.4g} s on "
            f"its clock) never overlap the reference view's {tr.size} by {min_overlap} "
            "points at any offset: too few frames were tracked in one of the views to "
            "put them on one clock ('vidtrack -v fit' says how many frames each view "
            "tracked; a straw thinner than a pixel is lost); give "
            f"views.{name}.sync_frame if the tracks are right")
    k = int(np.argmin(costs))
    # the cost is infinite where too few points overlap: Brent's parabola through such
    # points is simply rejected (numpy's warning about inf - inf says nothing more)
    with np.errstate(invalid="ignore", over="ignore"):
        res = minimize_scalar(cost, bounds=(grid[k] - 0.5 * other_step,
                                            grid[k] + 0.5 * other_step),
                              method="bounded", options={"xatol": 1e-4 * other_step})
    t0 = float(res.x) if np.isfinite(res.fun) and res.fun <= costs[k] else float(grid[k])
    xi = _interp_gapless(tr + t0, to, xo, max_step)
    ok = np.isfinite(xi)
    if np.ptp(xr[ok]) < 5.0 * scale:
        raise TrackError(f"view {name}: the shared X changes by only "
                         f"{np.ptp(xr[ok]) / scale:.2g} px over the common frames, too little "
                         f"to find the offset; give views.{name}.sync_frame")
    return t0


def merge_tracks(tracks, mappings, *, sync=None, min_overlap=10):
    """Merge one or two views' tracks into the world track.

    Parameters
    ----------
    tracks : dict of str to vidtrack.track.tracker.Track
        ``{"front": ..., "top": ...}`` (one or both).
    mappings : dict of str to calibration.ViewMapping
        Each view's pixel -> world mapping (``ViewSpec.mapping()``).
    sync : dict of str to int or "auto", optional
        Per view, the frame index (file frame, as in ``Track.data["frame"]``) at which
        t = 0, or ``"auto"`` (default for every view).
    min_overlap : int, optional
        Least number of common points to find or check an offset.

    Returns
    -------
    vidtrack.world.world_track.WorldTrack
        ``kind = "orthogonal"``.

    Raises
    ------
    TrackError
        No view, an unknown view, a view without a mapping or without usable points, a
        ``sync_frame`` that is not in the track, or an offset that the shared X cannot
        fix (too little overlap, X does not change).
    """
    if not tracks:
        raise TrackError("no view to merge")
    names = [v for v in ("front", "top") if v in tracks]
    unknown = set(tracks) - {"front", "top"}
    if unknown:
        raise TrackError(f"unknown view(s) {sorted(unknown)}: expected front and/or top")
    sync = dict(sync or {})
    world = {}
    steps = {}
    for v in names:
        if v not in mappings:
            raise TrackError(f"view {v}: no pixel -> world mapping given")
        world[v] = view_world(tracks[v], mappings[v])
        steps[v] = _frame_step(tracks[v])
        if not len(world[v]):
            raise TrackError(f"view {v}: no usable point (every frame is flagged or lost)")
    warnings = []
    t0, how = {}, {}
    for v in names:
        s = sync.get(v, "auto")
        if s is None or s == "auto":
            continue
        if isinstance(s, bool) or not isinstance(s, (int, np.integer)):
            raise TrackError(f"view {v}: sync must be a frame index or \"auto\", got {s!r}")
        rows = tracks[v].data.index[tracks[v].data["frame"] == int(s)]
        if not len(rows):
            fr = tracks[v].data["frame"]
            raise TrackError(f"view {v}: sync_frame {s} is not among its frames "
                             f"({int(fr.iloc[0])}..{int(fr.iloc[-1])})")
        t0[v] = float(tracks[v].data.loc[rows[0], "t_s"])
        how[v] = f"sync_frame {int(s)}"
    auto = [v for v in names if v not in t0]
    if t0:
        ref = names[0] if names[0] in t0 else next(v for v in names if v in t0)
    else:
        with_rel = [v for v in names if tracks[v].release_t_s is not None]
        ref = with_rel[0] if with_rel else names[0]
        if with_rel:
            t0[ref] = float(tracks[ref].release_t_s)
            how[ref] = "release"
        else:
            t0[ref] = float(world[ref]["t_s"].iloc[0])
            how[ref] = "first usable frame"
            warnings.append(f"view {ref}: no release detected; t = 0 is its first usable "
                            "frame")
        auto = [v for v in auto if v != ref]
    for v in auto:
        t0[v] = _shared_x_offset(world[ref], t0[ref], world[v], steps[v],
                                 min_overlap=min_overlap, name=v,
                                 scale=max(mappings[ref].m_per_px, mappings[v].m_per_px))
        how[v] = "shared x"
    merged = {v: _flag_before_t0(tracks[v], t0[v], how[v], steps[v], ref=ref,
                                 ref_how=how[ref]) for v in names}
    world = {v: world[v] if merged[v] is tracks[v] else view_world(merged[v], mappings[v])
             for v in names}     # a track the flagging left as it was keeps its points
    # perspective (vidtrack.world.parallax): a view with camera_distance_m scaled by the
    # other view's depth; an offset found on the shared X is found again on the corrected
    # X (uncorrected, the two views see X at different scales), and the views corrected
    # again on the new clock, until the offset moves by less than a hundredth of a frame
    world, parallax_notes = correct_parallax(world, merged, mappings, t0, steps)
    perspective = any(mappings[v].camera_distance_m is not None for v in names)
    for _ in range(_RESYNC_PASSES if perspective and auto else 0):
        moved = 0.0
        for v in auto:
            new = _shared_x_offset(world[ref], t0[ref], world[v], steps[v],
                                   min_overlap=min_overlap, name=v,
                                   scale=max(mappings[ref].m_per_px, mappings[v].m_per_px))
            moved, t0[v] = max(moved, abs(new - t0[v]) / steps[v]), new
        merged = {v: _flag_before_t0(tracks[v], t0[v], how[v], steps[v], ref=ref,
                                     ref_how=how[ref]) for v in names}
        world = {v: view_world(merged[v], mappings[v]) for v in names}
        world, parallax_notes = correct_parallax(world, merged, mappings, t0, steps)
        if moved < 0.01:
            break
    warnings += parallax_notes
    # the check of the shared X
    x_rms_m = x_rms_px = None
    x_points = 0
    if len(names) == 2:
        other = names[1] if ref == names[0] else names[0]
        tr = world[ref]["t_s"].to_numpy() - t0[ref]
        xi = _interp_gapless(tr + t0[other], world[other]["t_s"].to_numpy(),
                             world[other]["x_m"].to_numpy(), 2.5 * steps[other])
        ok = np.isfinite(xi)
        x_points = int(np.count_nonzero(ok))
        if x_points:
            diff = xi[ok] - world[ref]["x_m"].to_numpy()[ok]
            x_rms_m = float(np.sqrt(np.mean(diff ** 2)))
            scale = max(mappings[ref].m_per_px, mappings[other].m_per_px)
            x_rms_px = x_rms_m / scale
            if x_rms_m > scale:
                warnings.append(
                    f"the views disagree on X by {x_rms_m * 1000:.3g} mm RMS "
                    f"({x_rms_px:.2f} px) over {x_points} points, more than the pixel scale "
                    f"({scale * 1000:.3g} mm): check the scales, origins and sync")
        else:
            warnings.append("the views have no usable points at common times: X not checked")
    data = _world_rows(merged, world, t0, ref, names, steps)
    for note in _coverage_notes(data, names):
        warnings.append(note)
        log.warning("world track: %s", note, extra={"label": "note"})
    log.info("world track: %d rows from %s (reference %s; t = 0 by %s)", len(data),
             ", ".join(names), ref, ", ".join(f"{n}: {h}" for n, h in how.items()))
    for w in warnings:
        # kept in the result (fit.json notes, the report); shown with vidtrack -v
        log.info("world track: %s", w)
    return WorldTrack(data=data, t0_s=t0, sync=how, reference=ref, kind="orthogonal",
                      x_rms_m=x_rms_m,
                      x_rms_px=x_rms_px, x_points=x_points, warnings=tuple(warnings),
                      tracks=merged)


def _coverage_notes(data, names):
    """A note for each view whose own axis (y: front, z: top) covers less than
    :data:`COVERAGE_NOTE_FRACTION` of the world track's time span: the coefficients
    fitted on that axis rest on that part of the flight only (a cut or shifted footage,
    a straw lost), which widens their interval without any other sign."""
    out = []
    if len(names) < 2 or not len(data):
        return out
    t = data["t_s"].to_numpy()
    span = float(t[-1] - t[0])
    if span <= 0:
        return out
    for view, axis, ks in (("front", "y", "k1, k2"), ("top", "z", "k3, k4")):
        ok = np.isfinite(data[f"{axis}_m"].to_numpy())
        if view not in names or not ok.any():
            continue
        a, b = float(t[ok][0]), float(t[ok][-1])
        if b - a < COVERAGE_NOTE_FRACTION * span:
            out.append(f"view {view} measures {axis} over t = {a:.4g}..{b:.4g} s only "
                       f"({int(ok.sum())} of {len(t)} rows, {100 * (b - a) / span:.0f} % of "
                       f"the flight's {span:.4g} s): the coefficients fitted on {axis} "
                       f"({ks} with the other axes) rest on that part; check that view's "
                       "footage (cut or shifted?) and its track (vidtrack overlay)")
    return out


def _flag_before_t0(track, t0, how, step, *, ref, ref_how):
    """The track with PRE_RELEASE on exactly its measured frames before t = 0.

    A frame counts as before t = 0 when it is more than 0.2 frame earlier (the
    tracker's rule for the first frame of free flight). The release fields follow the
    view's t = 0 unless it is the view's own detected release.
    """
    d = track.data
    t = d["t_s"].to_numpy(dtype=np.float64)
    flags = d["flags"].to_numpy()
    before = (t < t0 - 0.2 * step) & np.isfinite(d["u_px"].to_numpy(dtype=np.float64))
    new_flags = np.where(before, flags | PRE_RELEASE, flags & ~PRE_RELEASE).astype(flags.dtype)
    changes = {}
    if how == "shared x" and (ref_how == "release" or ref_how.startswith("sync_frame")):
        changes["release_note"] = (f"carried over from the {ref} view ({ref_how}) through "
                                   "the shared X")
    elif how.startswith("sync_frame"):
        changes["release_note"] = f"t = 0 at {how} (given in the scene)"
    if changes:
        after = np.flatnonzero(t >= t0 - 0.2 * step)
        changes["release_frame"] = int(d["frame"].iloc[after[0]]) if after.size else None
        changes["release_t_s"] = float(t0)
    if not changes and np.array_equal(new_flags, flags):
        return track
    data = d.copy()
    data["flags"] = new_flags
    return replace(track, data=data, **changes)


def reference_frames(data, t0_s, t_s):
    """The reference view's file frame at each world time: the world track's rows.

    Parameters
    ----------
    data : pandas.DataFrame
        The reference view's :attr:`vidtrack.track.tracker.Track.data` (``frame``,
        ``t_s`` on the source's clock).
    t0_s : float
        The time on that clock that is t = 0 (:attr:`WorldTrack.t0_s` of the view).
    t_s : array_like
        World times (s since t = 0).

    Returns
    -------
    numpy.ndarray
        int64: the frame at each time, -1 where no frame of the view is at it (within
        1e-12 s).
    """
    t_ref = data["t_s"].to_numpy(dtype=np.float64) - t0_s
    frames = data["frame"].to_numpy(dtype=np.int64)
    order = np.argsort(t_ref, kind="stable")
    t_sorted = t_ref[order]
    t_s = np.asarray(t_s, dtype=np.float64)
    out = np.full(t_s.size, -1, dtype=np.int64)
    if not t_sorted.size:
        return out
    # the nearest frame time on either side (a time a rounding below its frame's sorts
    # after it)
    right = np.clip(np.searchsorted(t_sorted, t_s), 0, t_sorted.size - 1)
    left = np.clip(right - 1, 0, t_sorted.size - 1)
    pos = np.where(np.abs(t_sorted[left] - t_s) < np.abs(t_sorted[right] - t_s), left, right)
    hit = np.isclose(t_sorted[pos], t_s, rtol=0, atol=1e-12)
    out[hit] = frames[order[pos[hit]]]
    return out


def _world_rows(tracks, world, t0, ref, names, steps):
    t_ref = tracks[ref].data["t_s"].to_numpy(dtype=np.float64) - t0[ref]
    keep = t_ref >= -1e-9 * max(1.0, abs(t0[ref]))
    t_rows = t_ref[keep]
    cols = {a: np.full(t_rows.size, np.nan) for a in _AXES}
    wr = world[ref]
    tw = wr["t_s"].to_numpy() - t0[ref]
    pos = np.searchsorted(t_rows, tw)
    inside = (pos < t_rows.size)
    inside[inside] &= np.isclose(t_rows[pos[inside]], tw[inside], rtol=0, atol=1e-12)
    for a in _AXES:
        if f"{a}_m" in wr:
            cols[a][pos[inside]] = wr[f"{a}_m"].to_numpy()[inside]
    for v in names:
        if v == ref:
            continue
        wv = world[v]
        tv = wv["t_s"].to_numpy() - t0[v]
        post = tv >= -1e-9 * max(1.0, abs(t0[v]))      # never a point from before t = 0
        for a in _AXES:
            if f"{a}_m" not in wv:
                continue
            vals = _interp_gapless(t_rows, tv[post], wv[f"{a}_m"].to_numpy()[post],
                                   2.5 * steps[v])
            missing = ~np.isfinite(cols[a])
            cols[a][missing] = vals[missing]
    data = pd.DataFrame({"frame": reference_frames(tracks[ref].data, t0[ref], t_rows),
                         "t_s": t_rows, "x_m": cols["x"], "y_m": cols["y"], "z_m": cols["z"]})
    measured = np.isfinite(data[["x_m", "y_m", "z_m"]].to_numpy()).any(axis=1)
    return data[measured].reset_index(drop=True)
