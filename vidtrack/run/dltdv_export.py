"""The run's points in DLTdv's layout, to go back to the tools labs know.

Beside tracks.h5, two CSV files as DLTdv (5-8) exports them, for one point:

- ``xypts.csv``: columns ``pt1_cam{C}_X, pt1_cam{C}_Y`` for camera C = 1, 2, ... (the
  scene's views in order), one row per frame from frame 0 of the views' files, NaN where
  the view has no usable point. The pixels are in each view's own convention: a
  calibrated view's ``pixel_origin`` (DLTdv's is bottom-left), vidtrack's image
  convention (top-left) for the orthogonal views.
- ``xyzpts.csv``: ``pt1_X, pt1_Y, pt1_Z`` (m), one row per row of the world track: the
  calibration's frame for calibrated cameras (as DLTdv would triangulate), the world
  frame of the orthogonal views otherwise; NaN where not measured or flagged.

The views' names, in camera order, are in ``xypts_cameras.txt`` beside them.
"""

from pathlib import Path

import numpy as np
import pandas as pd

from vidtrack._atomic import atomic_path

__all__ = ["write_dltdv", "XYPTS_CSV", "XYZPTS_CSV"]

XYPTS_CSV = "xypts.csv"
XYZPTS_CSV = "xyzpts.csv"
_CAMERAS_TXT = "xypts_cameras.txt"


def _write(path, table):
    with atomic_path(path) as tmp:
        table.to_csv(tmp, index=False, na_rep="NaN", lineterminator="\n")
    return Path(path)


def write_dltdv(folder, tracks, world, *, cameras=None):
    """Write ``xypts.csv``, ``xyzpts.csv`` and ``xypts_cameras.txt`` into ``folder``.

    Parameters
    ----------
    folder : str or os.PathLike
    tracks : dict of str to vidtrack.track.tracker.Track
        The views in camera order.
    world : vidtrack.world.world_track.WorldTrack
    cameras : dict of str to calibration.projective.ProjectiveCamera, optional
        Calibrated views' cameras: their pixels are written in the camera's convention
        (tracked footage's rows flipped for a bottom-left camera).

    Returns
    -------
    list of pathlib.Path
    """
    folder = Path(folder)
    names = list(tracks)
    last = max(int(tr.data["frame"].max()) for tr in tracks.values()) if tracks else -1
    table = {}
    for c, name in enumerate(names, start=1):
        tr = tracks[name]
        d = tr.data
        uv = np.full((last + 1, 2), np.nan)
        ok = tr.usable
        pts = d[["u_px", "v_px"]].to_numpy(float)[ok]
        cam = (cameras or {}).get(name)
        if cam is not None and cam.pixel_origin == "bottom-left" and tr.frame_shape[0] > 0:
            pts = cam.from_image_pixels(pts, tr.frame_shape[0])
        uv[d["frame"].to_numpy()[ok]] = pts
        table[f"pt1_cam{c}_X"] = uv[:, 0]
        table[f"pt1_cam{c}_Y"] = uv[:, 1]
    written = [_write(folder / XYPTS_CSV, pd.DataFrame(table))]
    d = world.data
    if world.calibrated:    # the calibration's frame, flagged rows left out
        keep = d["flags"].to_numpy() == 0
        xyz = np.where(keep[:, None], d[["X_m", "Y_m", "Z_m"]].to_numpy(float), np.nan)
    else:
        xyz = d[["x_m", "y_m", "z_m"]].to_numpy(float)
    written.append(_write(folder / XYZPTS_CSV,
                          pd.DataFrame({"pt1_X": xyz[:, 0], "pt1_Y": xyz[:, 1],
                                        "pt1_Z": xyz[:, 2]})))
    with atomic_path(folder / _CAMERAS_TXT) as tmp:
        Path(tmp).write_text("".join(f"cam{c} = {n}\n" for c, n in enumerate(names, 1)))
    written.append(folder / _CAMERAS_TXT)
    return written
