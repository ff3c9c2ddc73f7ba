"""Points digitized in other tools, read as a view's track (no tracking is run).

A view may give, instead of footage, the pixels a person or another program placed:

- a DLTdv xypts CSV (DLTdv5-8's export: columns ``pt{P}_cam{C}_X``, ``pt{P}_cam{C}_Y``, one
  row per frame from the first frame of the video, NaN where the point was not
  digitized), with the camera and the point chosen;
- Tracker's exported data table (Open Source Physics Tracker: an optional first line
  with the track's name, then a header ``t x y`` and one row per step, tab- or
  comma-separated): the coordinates must be image pixels (Tracker's coordinate system
  set to the image's pixels), the time ``t`` in s is turned into frames with the view's
  ``fps``;
- a plain CSV with columns ``frame, u_px, v_px`` (``t_s`` optional, ignored: time is
  ``frame / fps``).

Coordinates are taken in the view's ``pixel_origin`` convention, the one its camera
model uses (DLTdv's files and coefficients are both ``"bottom-left"``).
"""

import csv
import io
import re
from pathlib import Path

import numpy as np

from vidtrack.errors import SceneError
from vidtrack.scene.cameras import POINT_FORMATS
from vidtrack.track.tracker import TRACK_COLUMNS, Track

__all__ = ["read_points", "sniff_format", "POINT_FORMATS"]

_XYPTS = re.compile(r"^pt(\d+)_cam(\d+)_([XY])$")


def _text(path, where):
    try:
        raw = Path(path).read_bytes()
    except OSError as exc:
        raise SceneError(f"{where}: cannot read {path}: {exc.strerror or exc}") from None
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise SceneError(f"{where}: {path} is not UTF-8 text") from None


def _number(cell, where, row, col):
    cell = cell.strip()
    if cell == "" or cell.lower() == "nan":
        return np.nan
    try:
        value = float(cell)
    except ValueError:
        raise SceneError(f"{where}: row {row}, column {col!r}: expected a number, got "
                         f"{cell!r}") from None
    if not np.isfinite(value):
        raise SceneError(f"{where}: row {row}, column {col!r}: {cell!r} is not finite")
    return value


def _rows(text, where):
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if not lines:
        raise SceneError(f"{where}: the file is empty")
    dialect = "excel-tab" if "\t" in lines[0] or (len(lines) > 1 and "\t" in lines[1]) \
        else "excel"
    return [r for r in csv.reader(io.StringIO("\n".join(lines)), dialect) if any(r)]


def _dltdv(text, where, camera, point):
    rows = _rows(text, where)
    header = [h.strip() for h in rows[0]]
    cols = {}
    for i, name in enumerate(header):
        m = _XYPTS.match(name)
        if m:
            cols[(int(m.group(1)), int(m.group(2)), m.group(3))] = i
    if not cols:
        raise SceneError(f"{where}: not a DLTdv xypts file (expected columns like "
                         f"pt1_cam1_X, pt1_cam1_Y), got {', '.join(header[:4])}...")
    points = sorted({p for p, _, _ in cols})
    cameras = sorted({c for _, c, _ in cols})
    if camera not in cameras or point not in points:
        raise SceneError(f"{where}: the file has points {points} and cameras {cameras}; "
                         f"asked for point {point} of camera {camera}")
    ix, iy = cols[(point, camera, "X")], cols[(point, camera, "Y")]
    uv = np.array([[_number(r[ix], where, k + 2, header[ix]),
                    _number(r[iy], where, k + 2, header[iy])] for k, r in enumerate(rows[1:])])
    return np.arange(len(uv)), uv.reshape(-1, 2)


def _tracker(text, where, fps):
    rows = _rows(text, where)
    if len(rows[0]) == 1 and len(rows) > 1:          # the track's name
        rows = rows[1:]
    header = [h.strip().lower() for h in rows[0]]
    try:
        it, ix, iy = header.index("t"), header.index("x"), header.index("y")
    except ValueError:
        raise SceneError(f"{where}: a Tracker data table needs columns t, x, y; got "
                         f"{', '.join(header)}") from None
    data = np.array([[_number(r[i], where, k + 2, header[i]) for i in (it, ix, iy)]
                     for k, r in enumerate(rows[1:])]).reshape(-1, 3)
    data = data[np.isfinite(data[:, 0])]
    frames = np.rint(data[:, 0] * fps).astype(int)
    if len(frames) and np.max(np.abs(data[:, 0] * fps - frames)) > 0.05:
        raise SceneError(f"{where}: the table's times are not on the frames of fps = "
                         f"{fps:g} (t * fps is not a whole number): is fps the capture rate "
                         "Tracker used?")
    return frames, data[:, 1:]


def _plain(text, where):
    rows = _rows(text, where)
    header = [h.strip() for h in rows[0]]
    missing = [c for c in ("frame", "u_px", "v_px") if c not in header]
    if missing:
        raise SceneError(f"{where}: a points CSV needs columns frame, u_px, v_px; "
                         f"{', '.join(missing)} missing (got {', '.join(header)})")
    i_f, i_u, i_v = (header.index(c) for c in ("frame", "u_px", "v_px"))
    frames, uv = [], []
    for k, r in enumerate(rows[1:]):
        f = _number(r[i_f], where, k + 2, "frame")
        if not (np.isfinite(f) and f == int(f) and f >= 0):
            raise SceneError(f"{where}: row {k + 2}: frame must be a whole number >= 0, "
                             f"got {r[i_f]!r}")
        frames.append(int(f))
        uv.append((_number(r[i_u], where, k + 2, "u_px"), _number(r[i_v], where, k + 2, "v_px")))
    return np.array(frames, dtype=int), np.array(uv, dtype=float).reshape(-1, 2)


def sniff_format(path):
    """The format of a points file from its first lines, or None when it is none of them."""
    try:
        with open(path, encoding="utf-8-sig", errors="replace") as f:
            head = [f.readline() for _ in range(2)]
    except OSError:
        return None
    cells = [[c.strip().lower() for c in re.split(r"[,\t]", ln)] for ln in head]
    if cells and any(_XYPTS.match(c) for c in re.split(r"[,\t]", head[0].strip())):
        return "dltdv"
    if cells and {"frame", "u_px", "v_px"} <= set(cells[0]):
        return "csv"
    for row in cells:
        if {"t", "x", "y"} <= set(row):
            return "tracker"
    return None


def read_points(path, *, fps, fmt=None, camera=1, point=1, view=None):
    """Read a view's points digitized elsewhere as a :class:`~vidtrack.track.tracker.Track`.

    Parameters
    ----------
    path : str or pathlib.Path
        The file.
    fps : float
        The view's capture rate (frames/s): time is ``frame / fps``.
    fmt : {"dltdv", "tracker", "csv"} or None
        The file's format (see the module); None: recognised from its first lines.
    camera, point : int
        DLTdv only: which camera's columns and which point (1-based, as DLTdv numbers them).
    view : str or None
        The view's name (for messages and the track).

    Returns
    -------
    Track
        One row per frame from the first to the last frame the file mentions; frames
        without a point have NaN pixels (and are not usable). ``area_px``,
        ``angle_rad`` and ``length_px`` are NaN: nothing is measured but the point.

    Raises
    ------
    SceneError
        An unreadable file, a format it does not match, a frame twice, no point at all.
    """
    import pandas as pd

    where = f"view {view}: points {Path(path).name}" if view else f"points {Path(path).name}"
    if fmt is None and Path(path).is_file():
        fmt = sniff_format(path)
        if fmt is None:
            raise SceneError(f"{where}: not a DLTdv xypts file, a Tracker data table or a CSV "
                             "with frame, u_px, v_px; say which with points.format")
    fmt = fmt or "csv"
    if fmt not in POINT_FORMATS:
        raise SceneError(f"{where}: format must be one of {', '.join(POINT_FORMATS)}, "
                         f"got {fmt!r}")
    if not (np.isfinite(fps) and fps > 0):
        raise SceneError(f"{where}: fps must be > 0, got {fps!r}")
    text = _text(path, where)
    if fmt == "dltdv":
        frames, uv = _dltdv(text, where, int(camera), int(point))
    elif fmt == "tracker":
        frames, uv = _tracker(text, where, float(fps))
    else:
        frames, uv = _plain(text, where)
    if len(frames) and len(np.unique(frames)) != len(frames):
        dup = frames[np.flatnonzero(np.diff(np.sort(frames)) == 0)[0]]
        raise SceneError(f"{where}: frame {dup} appears twice")
    seen = np.all(np.isfinite(uv), axis=1)
    if not seen.any():
        raise SceneError(f"{where}: no frame has a point (every row is empty or NaN)")
    if (frames < 0).any():
        raise SceneError(f"{where}: frames must be >= 0 (t >= 0), got {int(frames.min())}")
    first, last = 0, int(frames.max())
    all_frames = np.arange(first, last + 1)
    full = np.full((len(all_frames), 2), np.nan)
    full[frames - first] = uv
    nan = np.full(len(all_frames), np.nan)
    data = pd.DataFrame({"frame": all_frames, "t_s": all_frames / float(fps),
                         "u_px": full[:, 0], "v_px": full[:, 1], "area_px": nan,
                         "angle_rad": nan, "length_px": nan,
                         "flags": np.zeros(len(all_frames), dtype=np.int64)},
                        columns=list(TRACK_COLUMNS))
    note = f"points digitized elsewhere ({fmt}: {Path(path).name}), {int(seen.sum())} frames"
    return Track(data=data, view=view, release_frame=None, release_note=note,
                 release_t_s=None, fps=float(fps), frame_shape=(0, 0), noise_sigma=np.nan,
                 k_sigma=np.nan, straw_level=np.nan, scatter_px=np.nan, notes=(note,))
