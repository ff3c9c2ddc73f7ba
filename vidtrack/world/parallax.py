"""Perspective in the orthogonal rig: each view's scale corrected by the other view's depth.

A ``front`` or ``top`` camera at a finite distance d from the plane where its scale was
measured (the plane through the world origin parallel to the image: Z = 0 for
``front``, Y = 0 for ``top``) sees a point that is ``depth`` metres nearer to it larger,
by d / (d - depth), about the principal point. The view cannot measure that depth
itself, but the other view can: the front view's depth is Z, which the top view sees,
and the top view's depth is Y, which the front view sees (the sign from the view's
``axes``: the camera looks along u x v, :attr:`calibration.views.ViewMapping.toward_camera`).

:func:`correct_parallax` runs after the views are on one clock: for every usable point of
a view with ``camera_distance_m`` the other view's depth coordinate is interpolated at
its time and the point's world coordinates are scaled about the principal point's foot
on the plane (:meth:`calibration.views.ViewMapping.pixel_to_world_at_depth`). Each view's
depth comes from the other, corrected in turn, so the correction is iterated until no
coordinate moves by more than a nanometre (a few to a dozen passes).
The principal point is the calibration's (cx, cy) when the view has a camera
calibration, else the image centre.

Without ``camera_distance_m`` nothing is corrected, and nothing is said here: whether
that matters for k depends on the fit, and :mod:`vidtrack.run.perspective` works it out
(a note only when k could move by a standard error).
"""

import numpy as np

__all__ = ["correct_parallax", "corrected_points", "PASSES"]

#: Most passes of the correction (each view's depth comes from the other, corrected in
#: turn); it stops when no coordinate moves by more than ``_CONVERGED_M``.
PASSES = 30
_CONVERGED_M = 1e-9
#: How far (in the other view's frames) its depth is extrapolated beyond its first and
#: last usable point, from a quadratic through its nearest points; farther points of the
#: corrected view are dropped (their depth is unknown).
_EXTRAPOLATE_FRAMES = 10
_EXTRAPOLATE_POINTS = 15


def _depth_at(t_new, t, depth, step):
    """The other view's depth at ``t_new``: linear between its points, a quadratic through
    its nearest points a few frames beyond its ends, NaN farther."""
    out = np.full(t_new.shape, np.nan)
    ok = np.isfinite(depth) & np.isfinite(t)
    t, depth = t[ok], depth[ok]
    if t.size < 2:
        return out
    order = np.argsort(t)
    t, depth = t[order], depth[order]
    inside = (t_new >= t[0]) & (t_new <= t[-1])
    out[inside] = np.interp(t_new[inside], t, depth)
    reach = _EXTRAPOLATE_FRAMES * step
    for sel, part in (((t_new < t[0]) & (t_new >= t[0] - reach), slice(0, _EXTRAPOLATE_POINTS)),
                      ((t_new > t[-1]) & (t_new <= t[-1] + reach),
                       slice(-_EXTRAPOLATE_POINTS, None))):
        if not sel.any():
            continue
        tt, dd = t[part], depth[part]
        deg = min(2, tt.size - 1)
        coef = np.polyfit(tt - tt.mean(), dd, deg)
        out[sel] = np.polyval(coef, t_new[sel] - tt.mean())
    return out


def _principal(track, mapping):
    """The principal point: the calibration's, else the centre of the track's frames."""
    if mapping.principal_px is not None:
        return tuple(mapping.principal_px), "the calibration's"
    shape = getattr(track, "frame_shape", None)
    if not shape or len(shape) < 2:
        return None, None
    rows, cols = int(shape[0]), int(shape[1])
    return (0.5 * (cols - 1), 0.5 * (rows - 1)), "the image centre"


def _percent(x):
    return f"{100.0 * x:+.2g} %" if abs(x) < 0.1 else f"{100.0 * x:+.3g} %"


def correct_parallax(world, tracks, mappings, t0, steps):
    """Correct the perspective of the views that give ``camera_distance_m``.

    Parameters
    ----------
    world : dict of str to pandas.DataFrame
        Each view's usable points (:func:`vidtrack.world.orthogonal.view_world`: columns
        ``frame``, ``t_s`` on the view's clock, one ``<axis>_m`` per world axis it sees).
    tracks : dict of str to vidtrack.track.tracker.Track
        The tracks those points came from (their usable rows, in order; the frame size).
    mappings : dict of str to calibration.ViewMapping
    t0 : dict of str to float
        Each view's t = 0 on its clock (the views on one clock).
    steps : dict of str to float
        Each view's frame interval (s).

    Returns
    -------
    (dict of str to pandas.DataFrame, list of str)
        The points with corrected coordinates (points whose depth is unknown dropped),
        and notes for the run's record: what was corrected and by how much (nothing for
        a view without ``camera_distance_m``).
    """
    names = [v for v in ("front", "top") if v in world]
    notes = []
    depth_of = {}                              # view -> (other view, axis, sign)
    for v in names:
        axis, sign = mappings[v].toward_camera
        other = next((o for o in names if o != v and f"{axis}_m" in world[o]), None)
        depth_of[v] = (other, axis, sign)
    corrected = [v for v in names if mappings[v].camera_distance_m is not None]
    if not corrected:
        return world, notes
    pixels, principal = {}, {}
    for v in list(corrected):
        other = depth_of[v][0]
        pp, pp_from = _principal(tracks[v], mappings[v])
        if other is None or pp is None:
            why = (f"no other view measures its depth ({depth_of[v][1].upper()})"
                   if other is None else "its principal point is unknown (no frame size)")
            notes.append(f"views.{v}.camera_distance_m is given but {why}: its perspective "
                         "is not corrected")
            corrected.remove(v)
            continue
        d = tracks[v].data[tracks[v].usable]
        pixels[v] = d[["u_px", "v_px"]].to_numpy(dtype=np.float64)
        principal[v] = (pp, pp_from)
    current = dict(world)
    depth_used = {}
    for _ in range(PASSES):
        moved = 0.0
        updated = dict(current)
        for v in corrected:
            other, axis, sign = depth_of[v]
            m = mappings[v]
            t_v = world[v]["t_s"].to_numpy(dtype=np.float64) - t0[v]
            t_o = current[other]["t_s"].to_numpy(dtype=np.float64) - t0[other]
            depth = sign * _depth_at(t_v, t_o,
                                     current[other][f"{axis}_m"].to_numpy(dtype=np.float64),
                                     steps[other])
            w = m.pixel_to_world_at_depth(pixels[v], depth, principal_px=principal[v][0])
            df = world[v].copy()
            for k, a in enumerate(m.world_axes):
                df[f"{a}_m"] = w[:, k]
            with np.errstate(invalid="ignore"):
                change = np.abs(w - current[v][[f"{a}_m" for a in m.world_axes]].to_numpy())
            if np.isfinite(change).any():
                moved = max(moved, float(np.nanmax(change)))
            updated[v] = df
            depth_used[v] = depth
        current = updated
        if moved <= _CONVERGED_M:
            break
    out = dict(world)
    for v in corrected:
        df = current[v]
        keep = np.all(np.isfinite(df[[f"{a}_m" for a in mappings[v].world_axes]].to_numpy()),
                      axis=1)
        out[v] = df[keep].reset_index(drop=True)
        other, axis, sign = depth_of[v]
        d = mappings[v].camera_distance_m
        depth = depth_used[v][keep]
        (pu, pv), pp_from = principal[v]
        dropped = int(np.count_nonzero(~keep))
        if depth.size:
            gain = d / (d - depth) - 1.0
            coord = sign * depth
            what = (f"{axis.upper()} = {coord.min():+.3f} .. {coord.max():+.3f} m from the "
                    f"{other} view, a scale change of {_percent(gain.min())} .. "
                    f"{_percent(gain.max())}")
        else:
            what = "no point with a known depth"
        notes.append(f"perspective corrected in the {v} view: camera {d:g} m from the plane "
                     f"{axis.upper()} = 0, principal point ({pu:.1f}, {pv:.1f}) px "
                     f"({pp_from}); {what}"
                     + (f"; {dropped} points beyond the {other} view's track dropped "
                        "(depth unknown)" if dropped else ""))
    return out, notes


def corrected_points(tracks, mappings, t0_s):
    """Each view's usable points in world metres, perspective corrected as the merge did.

    For checks that read a view's coordinates from its pixels (as
    :func:`vidtrack.run.checks.speed_ratio` does with ``mapping.pixel_to_world``): with
    ``camera_distance_m`` the plain mapping is off by the perspective the merge
    corrected.

    Parameters
    ----------
    tracks : dict of str to vidtrack.track.tracker.Track
        The merged tracks (:attr:`vidtrack.world.world_track.WorldTrack.tracks`).
    mappings : dict of str to calibration.ViewMapping
    t0_s : dict of str to float
        :attr:`vidtrack.world.world_track.WorldTrack.t0_s`.

    Returns
    -------
    dict of str to pandas.DataFrame
        Per view: ``frame``, ``t_s`` (the view's clock) and its world axes (m).
    """
    import pandas as pd

    world, steps = {}, {}
    names = [v for v in ("front", "top") if v in tracks and v in mappings]
    for v in names:
        d = tracks[v].data[tracks[v].usable]
        w = mappings[v].pixel_to_world(d[["u_px", "v_px"]].to_numpy(dtype=np.float64)) \
            if len(d) else np.empty((0, 2))
        cols = {"frame": d["frame"].to_numpy(), "t_s": d["t_s"].to_numpy(dtype=np.float64)}
        for k, a in enumerate(mappings[v].world_axes):
            cols[f"{a}_m"] = w[:, k]
        world[v] = pd.DataFrame(cols)
        t = tracks[v].data["t_s"].to_numpy(dtype=np.float64)
        dt = np.diff(t)
        dt = dt[dt > 0]
        steps[v] = float(np.median(dt)) if dt.size else 1.0
    if not all(v in t0_s for v in names):
        return world
    out, _ = correct_parallax(world, {v: tracks[v] for v in names},
                              {v: mappings[v] for v in names}, t0_s, steps)
    return out
