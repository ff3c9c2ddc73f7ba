"""A person's corrections of a view's track: excluded frames and points placed by hand.

The scene's ``exclude_frames`` and ``manual_points`` (docs/scene.md, "Correcting the
tracker") are applied to a view's :class:`~vidtrack.track.tracker.Track` after tracking
(or after reading a view's digitized points) and before the views are merged or
triangulated, so tracks.h5 and tracks.csv show them:

- a frame inside an excluded range gets the flag EXCLUDED (bit 256): it is kept in the
  track but, as any flagged frame, never enters the world track or the fit;
- a manual point replaces the tracker's ``u_px, v_px`` in its frame, the frame's flags
  are cleared (0: usable), and the boolean column ``manual`` is True there. A manual
  frame the track has no row for (a view that gives points, or a frame outside what was
  tracked) is added as a row, its time ``frame / fps`` on the view's clock and its
  measurements (area, angle, length) NaN.

A track with reason codes (the flight tracker's ``reason`` column) says ``manual`` for a
manual point and adds ``excluded`` to an excluded frame's.

The design keeps "usable" what it always was, flags 0 and a finite position
(:attr:`Track.usable`): nothing that reads the flags needs to know about manual points.
Only a later stage can flag a manual point again: the merge flags every view's frames
before its t = 0 PRE_RELEASE (a point on the blade is not fitted, whoever placed it).
"""

import dataclasses

import numpy as np

from vidtrack.track.flag import REASON_COLUMN
from vidtrack.track.tracker import EXCLUDED

__all__ = ["apply_corrections", "MANUAL_COLUMN"]

#: The boolean column of a track with manual points.
MANUAL_COLUMN = "manual"


def apply_corrections(track, *, exclude_frames=(), manual=None):
    """The track with the scene's corrections applied.

    Parameters
    ----------
    track : vidtrack.track.tracker.Track
    exclude_frames : sequence of (int, int)
        Half-open ranges ``(first, end)`` of file frames to flag EXCLUDED.
    manual : vidtrack.scene.corrections.ManualPoints, optional
        Points placed by hand (``frames``, ``u_px``, ``v_px``), in the track's pixels.

    Returns
    -------
    vidtrack.track.tracker.Track
        A new Track (the input is not changed); the same object when there is nothing
        to apply.
    """
    if not exclude_frames and (manual is None or not len(manual)):
        return track
    import pandas as pd

    data = track.data.copy()
    if manual is not None and len(manual):
        have = set(data["frame"].to_numpy(dtype=np.int64).tolist())
        extra = [f for f in manual.frames if f not in have]
        if extra:
            fps = track.fps or 1.0
            rows = {c: np.full(len(extra), np.nan) for c in data.columns}
            rows["frame"] = np.asarray(extra, dtype=np.int64)
            rows["t_s"] = np.asarray(extra, dtype=np.float64) / fps
            rows["flags"] = np.zeros(len(extra), dtype=data["flags"].dtype)
            if MANUAL_COLUMN in data:
                rows[MANUAL_COLUMN] = np.zeros(len(extra), dtype=bool)
            data = pd.concat([data, pd.DataFrame(rows)[list(data.columns)]],
                             ignore_index=True)
            data = data.sort_values("frame", kind="stable").reset_index(drop=True)
            data["frame"] = data["frame"].astype(np.int64)
        frame_ix = data["frame"].to_numpy(dtype=np.int64)
        pos = {f: i for i, f in enumerate(frame_ix.tolist())}
        rows = np.asarray([pos[f] for f in manual.frames], dtype=np.int64)
        u = data["u_px"].to_numpy(dtype=np.float64).copy()
        v = data["v_px"].to_numpy(dtype=np.float64).copy()
        flags = data["flags"].to_numpy().copy()
        u[rows] = np.asarray(manual.u_px, dtype=np.float64)
        v[rows] = np.asarray(manual.v_px, dtype=np.float64)
        flags[rows] = 0
        mark = (data[MANUAL_COLUMN].to_numpy(dtype=bool).copy() if MANUAL_COLUMN in data
                else np.zeros(len(data), dtype=bool))
        mark[rows] = True
        data["u_px"], data["v_px"], data["flags"] = u, v, flags
        data[MANUAL_COLUMN] = mark
        if REASON_COLUMN in data:
            reason = data[REASON_COLUMN].astype(object).to_numpy().copy()
            reason[rows] = "manual"
            data[REASON_COLUMN] = reason
    if exclude_frames:
        frame_ix = data["frame"].to_numpy(dtype=np.int64)
        out = np.zeros(len(data), dtype=bool)
        for a, b in exclude_frames:
            out |= (frame_ix >= a) & (frame_ix < b)
        flags = data["flags"].to_numpy().copy()
        flags[out] |= EXCLUDED
        data["flags"] = flags
        if REASON_COLUMN in data:
            reason = data[REASON_COLUMN].astype(object).to_numpy().copy()
            reason[out] = [f"{r}+excluded" if r and r != "manual" else "excluded"
                           for r in reason[out]]
            data[REASON_COLUMN] = reason
        if MANUAL_COLUMN in data:          # an excluded frame is not a manual point
            mark = data[MANUAL_COLUMN].to_numpy(dtype=bool).copy()
            mark[out] = False
            data[MANUAL_COLUMN] = mark
    return dataclasses.replace(track, data=data)
