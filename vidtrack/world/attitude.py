"""The straw's attitude: its 3-D axis per frame and the rate it turns at.

A rod's image is a line: from the rod's two ends where the tracker gives them
(:data:`vidtrack.track.tracker.END_COLUMNS`, the flight tracker's bar), else the major
axis of its second moments (``angle_rad``) where its image is elongated enough (a
capsule fitted to its moments at least :data:`MIN_ELONGATION` times as long as it is
wide). Each view's line and the view's direction of sight span a plane that holds the
rod's axis; two views' planes meet in it (:func:`axis_from_planes`):

- an orthographic view (``front``: X, Y; ``top``: X, Z) looks along the axis it does not
  see, so its plane holds that axis and the line carried into the world by the view's
  mapping (:func:`orthogonal_attitude`);
- a calibrated camera's line back-projects to a plane through its centre
  (:func:`vidtrack.world.rod_centroid.axis_from_lines`).

Where fewer than two views give a line (a rod end on to a view has no angle there) or
their planes are less than :data:`MIN_PLANE_ANGLE_DEG` apart, the axis is NaN: it is not
measured. The axis has no sense (a rod's ends look alike); it is given with one sense
along the flight, turning by less than a right angle from row to row.

The rate the axis turns at (:func:`turn_rate`, ``spin_rad_s``) is the angle between the
axes a few rows before and after a row over the time between them. It is the rate of the
tumbling the paper's model lumps into k; a turn of the straw about its own axis is not
seen. For a rod spinning at ``w`` about a fixed axis at an angle ``a`` to the rod it is
``w sin a``.

The world track's columns (:data:`ATTITUDE_COLUMNS`): ``axis_x``, ``axis_y``, ``axis_z``
(the unit axis in the throw's frame, dimensionless) and ``spin_rad_s``.
"""

import numpy as np

from vidtrack.world.rod_centroid import MIN_PLANE_ANGLE_DEG, axis_from_planes

__all__ = ["ATTITUDE_COLUMNS", "ATTITUDE_MEANINGS", "MIN_ELONGATION", "MIN_PLANE_ANGLE_DEG",
           "TURN_HALF_WINDOW_ROWS", "image_angle", "elongated", "axis_from_planes",
           "orthogonal_attitude", "attitude_columns", "turn_rate", "attitude_summary"]

#: The world track's attitude columns, appended after its others.
ATTITUDE_COLUMNS = ("axis_x", "axis_y", "axis_z", "spin_rad_s")
#: What each attitude column holds, with its unit (tracks.h5's dataset attributes).
ATTITUDE_MEANINGS = {
    "axis_x": ("1", "the straw's unit axis in the throw frame, X component; NaN where "
                    "fewer than two views give its image's line"),
    "axis_y": ("1", "the straw's unit axis, Y component (see axis_x)"),
    "axis_z": ("1", "the straw's unit axis, Z component (see axis_x)"),
    "spin_rad_s": ("rad/s", "the rate the straw's axis turns at (its tumbling; a turn "
                            "about its own axis is not seen)"),
}
#: A view's image counts as a line when the capsule its moments fit is at least this many
#: times as long (between its caps' centres) as it is wide.
MIN_ELONGATION = 1.5
#: The turn rate is taken between the rows this many measured rows before and after.
TURN_HALF_WINDOW_ROWS = 8
#: ... or half as many, and so on down to one, until the axis turns by less than this
#: from row to row along the window (degrees, summed): a rod has no sense, so a turn
#: near a right angle is ambiguous, and one all the way round looks like none.
MAX_WINDOW_TURN_DEG = 60.0
#: The window may span at most this many times as many rows as it has measured rows
#: (gaps where the axis was not measured).
MAX_WINDOW_SPREAD = 2


def image_angle(data):
    """A track's image angle per row (rad, from +u towards +v, in (-pi/2, pi/2]): from
    the rod's two ends where the track has them, else ``angle_rad``.

    Parameters
    ----------
    data : pandas.DataFrame
        :attr:`vidtrack.track.tracker.Track.data`.

    Returns
    -------
    numpy.ndarray, shape (N,)
    """
    from vidtrack.track.tracker import END_COLUMNS

    angle = data["angle_rad"].to_numpy(dtype=np.float64).copy()
    if all(c in data for c in END_COLUMNS):
        e = data[list(END_COLUMNS)].to_numpy(dtype=np.float64)
        du, dv = e[:, 2] - e[:, 0], e[:, 3] - e[:, 1]
        ok = np.isfinite(du) & np.isfinite(dv) & (np.hypot(du, dv) > 0)
        ends = np.arctan2(dv[ok], du[ok])
        ends = np.where(ends > np.pi / 2, ends - np.pi, ends)
        angle[ok] = np.where(ends <= -np.pi / 2, ends + np.pi, ends)
    return angle


def elongated(length_px, area_px):
    """True where a capsule fitted to an image's moments (``length_px``, ``area_px``) is
    at least :data:`MIN_ELONGATION` times as long as it is wide: its angle is a line's."""
    from vidtrack.world.rod_centroid import capsule_from_moments

    ell, rho = capsule_from_moments(length_px, area_px)
    with np.errstate(invalid="ignore"):
        return ell >= MIN_ELONGATION * 2.0 * rho


def _lines(data, has_ends):
    """Unit image directions (N, 2) of a track's rows; NaN where the row gives no line:
    the ends where the tracker fitted them, else an elongated image's moments."""
    from vidtrack.track.tracker import END_COLUMNS

    theta = image_angle(data)
    ok = elongated(data["length_px"].to_numpy(dtype=np.float64),
                   data["area_px"].to_numpy(dtype=np.float64))
    if has_ends:
        ok |= np.all(np.isfinite(data[list(END_COLUMNS)].to_numpy(dtype=np.float64)), axis=1)
    ok &= np.isfinite(theta)
    out = np.column_stack([np.cos(theta), np.sin(theta)])
    out[~ok] = np.nan
    return out


def _one_sense(axis):
    """The axes (in place) turned to one sense along the rows: each measured row's within
    a right angle of the measured row before it."""
    have = np.flatnonzero(np.all(np.isfinite(axis), axis=1))
    if have.size < 2:
        return axis
    dots = np.einsum("ni,ni->n", axis[have[1:]], axis[have[:-1]])
    flips = np.concatenate([[1.0], np.cumprod(np.where(dots < 0, -1.0, 1.0))])
    axis[have] *= flips[:, None]
    return axis


def turn_rate(axis, t_s, *, half_window=TURN_HALF_WINDOW_ROWS):
    """The rate (rad/s) the axis turns at, per row.

    Parameters
    ----------
    axis : array_like, shape (N, 3)
        Unit axes (NaN where not measured), either sense.
    t_s : array_like, shape (N,)
        The rows' times (s), increasing.
    half_window : int
        Measured rows on each side of a row the rate is taken over.

    Returns
    -------
    numpy.ndarray, shape (N,)
        The angle between the axes ``k`` measured rows before and after the row over the
        time between them (``k`` from ``half_window`` halved until the axis turns by less
        than :data:`MAX_WINDOW_TURN_DEG` along the rows between them; fewer at the ends
        of the flight); NaN where
        the row's axis is not measured or no window fits (a gap spreads it more than
        :data:`MAX_WINDOW_SPREAD` times).
    """
    axis = _one_sense(np.array(axis, dtype=np.float64))
    t = np.asarray(t_s, dtype=np.float64)
    out = np.full(len(t), np.nan)
    have = np.flatnonzero(np.all(np.isfinite(axis), axis=1))
    if have.size < 2:
        return out
    m = have.size
    pos = np.arange(m)
    todo = np.ones(m, dtype=bool)
    # the path turned along the measured rows: a window that turns by less than a right
    # angle from row to row but all the way round over the window is not taken
    steps = np.arccos(np.clip(np.einsum("ni,ni->n", axis[have[1:]], axis[have[:-1]]),
                              -1.0, 1.0))
    path = np.concatenate([[0.0], np.cumsum(steps)])
    k = max(int(half_window), 1)
    while True:
        pa, pb = np.clip(pos - k, 0, m - 1), np.clip(pos + k, 0, m - 1)
        a, b = have[pa], have[pb]
        dt = t[b] - t[a]
        cos = np.clip(np.einsum("ni,ni->n", axis[a], axis[b]), -1.0, 1.0)
        turn = np.arccos(cos)
        ok = (todo & (dt > 0) & (np.degrees(path[pb] - path[pa]) < MAX_WINDOW_TURN_DEG)
              & (b - a <= MAX_WINDOW_SPREAD * (pb - pa)))
        out[have[ok]] = turn[ok] / dt[ok]
        todo &= ~ok
        if k == 1 or not todo.any():
            return out
        k //= 2


def attitude_columns(axis, t_s):
    """The world track's attitude columns (:data:`ATTITUDE_COLUMNS`) from the axes per
    row (throw frame; NaN where not measured) and the rows' times."""
    axis = _one_sense(np.array(axis, dtype=np.float64))
    rate = turn_rate(axis, t_s)
    return {"axis_x": axis[:, 0], "axis_y": axis[:, 1], "axis_z": axis[:, 2],
            "spin_rad_s": rate}


def attitude_summary(data):
    """The attitude in numbers (fit.json's ``world.attitude``), or None where the world
    track has no attitude columns: ``rows_measured`` (rows with an axis), ``rows``, and
    the median and quartiles of ``spin_rad_s`` (None where never measured)."""
    if not all(c in data for c in ATTITUDE_COLUMNS):
        return None
    axis = data[list(ATTITUDE_COLUMNS[:3])].to_numpy(dtype=np.float64)
    rate = data["spin_rad_s"].to_numpy(dtype=np.float64)
    rate = rate[np.isfinite(rate)]
    q = np.percentile(rate, [25, 50, 75]) if rate.size else [None] * 3
    return {"rows": int(len(data)),
            "rows_measured": int(np.all(np.isfinite(axis), axis=1).sum()),
            "spin_rad_s_median": None if q[1] is None else float(q[1]),
            "spin_rad_s_quartiles": None if q[0] is None else [float(q[0]), float(q[2])]}


def _view_normals(track, mapping, t_rows, t0_s, step_s):
    """One orthographic view's planes (unit normals, world frame) at the world rows."""
    from vidtrack.track.tracker import END_COLUMNS
    from vidtrack.world.resample import interp_gapless

    d = track.data[track.usable]
    n = len(t_rows)
    if len(d) < 2:
        return np.full((n, 3), np.nan)
    lines = _lines(d, all(c in d for c in END_COLUMNS))
    uv = d[["u_px", "v_px"]].to_numpy(dtype=np.float64)
    step = np.where(np.isfinite(lines), lines, 0.0)
    # the line carried into the world plane the view sees: a pixel on either side
    world = mapping.pixel_to_world(uv + 0.5 * step) - mapping.pixel_to_world(uv - 0.5 * step)
    phi = np.arctan2(world[:, 1], world[:, 0])
    ok = np.all(np.isfinite(lines), axis=1) & np.isfinite(phi)
    # between frames as a doubled angle (a line has no sense), never across gaps
    t = d["t_s"].to_numpy(dtype=np.float64)[ok] - t0_s
    c2 = interp_gapless(t_rows, t, np.cos(2 * phi[ok]), 2.5 * step_s)
    s2 = interp_gapless(t_rows, t, np.sin(2 * phi[ok]), 2.5 * step_s)
    half = 0.5 * np.arctan2(s2, c2)
    axes = ["xyz".index(a) for a in mapping.world_axes]
    line3 = np.zeros((n, 3))
    line3[:, axes[0]] = np.cos(half)
    line3[:, axes[1]] = np.sin(half)
    sight = np.zeros(3)
    sight[3 - sum(axes)] = 1.0                      # the axis the view looks along
    normal = np.cross(sight, line3)
    normal[~np.isfinite(half)] = np.nan
    return normal


def orthogonal_attitude(world, mappings):
    """The attitude columns of an orthogonal world track (front and top views).

    Parameters
    ----------
    world : vidtrack.world.world_track.WorldTrack
        ``kind = "orthogonal"``, with its views' tracks (:attr:`WorldTrack.tracks`) and
        clocks (:attr:`WorldTrack.t0_s`).
    mappings : dict of str to calibration.ViewMapping
        The views' mappings as merged (:meth:`WorldTrack.mappings`).

    Returns
    -------
    dict of str to numpy.ndarray
        :data:`ATTITUDE_COLUMNS`, one value per row of ``world.data``; NaN throughout with
        one view.
    """
    from vidtrack.world.resample import frame_step

    t_rows = world.data["t_s"].to_numpy(dtype=np.float64)
    names = [v for v in ("front", "top") if v in (world.tracks or {})]
    normals = np.stack([_view_normals(world.tracks[v], mappings[v], t_rows, world.t0_s[v],
                                      frame_step(world.tracks[v])) for v in names], axis=1) \
        if names else np.full((len(t_rows), 0, 3), np.nan)
    axis, _ = axis_from_planes(normals)
    return attitude_columns(axis, t_rows)
