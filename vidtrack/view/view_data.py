"""A view's per-run state as the page draws it, read once per change of the run.

:func:`view_data` reads what does not change from one frame to the next: the view's
corrections in ``scene.toml`` (``exclude_frames``, the ``manual_points`` file, the
``target``), its tracks with the camera shifts put back (the footage as shot), and the
fitted path's polyline. :class:`RunView.reload` builds one :class:`ViewData` a view, so
a frame asked for does only that frame's work (:meth:`ViewData.row`).
"""

from dataclasses import dataclass, field

import numpy as np

from vidtrack.errors import SceneError

__all__ = ["ViewData", "view_data", "EMPTY"]


@dataclass(frozen=True)
class ViewData:
    """One view's corrections, tracks and fitted path, ready to draw any frame.

    Attributes
    ----------
    excluded : frozenset of int
        The frames ``exclude_frames`` takes out.
    manual : dict
        ``{frame: (u, v)}``: the points placed by hand (the ``manual_points`` file).
    target : dict or None
        scene.toml's ``target``: ``{"frame": F, "at_px": [u, v]}``.
    frames : numpy.ndarray or None
        The tracked frame numbers (None: the view is not tracked).
    uv : (N, 2) numpy.ndarray or None
        The measured points as the footage shows them (camera shifts put back).
    shifts : (N, 2) numpy.ndarray or None
        The camera shift of each row (zeros for a still camera).
    table : pandas.DataFrame or None
        The view's tracks as tracks.h5 holds them (flags, reason).
    rows : dict
        ``{frame: row}``: the row of ``table`` of each tracked frame.
    path : vidtrack.report.view_path.ViewPath or None
        The fitted path in the view.
    polyline : (M, 2) numpy.ndarray or None
        The fitted path over the flight.
    """

    excluded: frozenset = frozenset()
    manual: dict = field(default_factory=dict)
    target: dict | None = None
    frames: np.ndarray | None = None
    uv: np.ndarray | None = None
    shifts: np.ndarray | None = None
    table: object = None
    rows: dict = field(default_factory=dict)
    path: object = None
    polyline: np.ndarray | None = None

    def row(self, frame):
        """The track's row index of ``frame``, or None where it was not tracked."""
        return self.rows.get(frame)


#: A view with nothing read yet (no corrections, no tracks, no path).
EMPTY = ViewData()


def _excluded(raw):
    out = set()
    for r in raw.get("exclude_frames") or ():
        if isinstance(r, list) and len(r) == 2 and all(isinstance(x, int) for x in r):
            out.update(range(r[0], r[1]))
    return frozenset(out)


def _target(raw):
    """``{"frame": F, "at_px": [u, v]}`` of the view's ``target``; None when it is not
    set or not of that form (the loader's message is the scene's error then)."""
    t = raw.get("target")
    if not isinstance(t, dict):
        return None
    frame, at = t.get("frame"), t.get("at_px")
    if (isinstance(frame, bool) or not isinstance(frame, int) or not isinstance(at, list)
            or len(at) != 2 or not all(isinstance(x, (int, float)) for x in at)):
        return None
    return {"frame": frame, "at_px": [float(x) for x in at]}


def _manual(folder, scene_path, name, raw):
    """``{frame: (u, v)}`` of the view's manual points file; empty when none is named or
    it does not load (the loader's message is the scene's error then)."""
    from vidtrack.scene.corrections import manual_points_file, read_manual_points

    text = raw.get("manual_points")
    if not isinstance(text, str):
        return {}
    try:
        points = read_manual_points(manual_points_file(folder, text), label=str(scene_path),
                                    key=f"views.{name}.manual_points", text=text)
    except SceneError:
        return {}
    return {f: (u, v) for f, u, v in zip(points.frames, points.u_px, points.v_px)}


def view_data(folder, scene_path, name, raw, track=None, path=None):
    """The :class:`ViewData` of view ``name``.

    Parameters
    ----------
    folder : pathlib.Path
        The run folder (the manual points file is resolved from it).
    scene_path : pathlib.Path
        The run's scene.toml (messages name it).
    name : str
        The view.
    raw : dict
        The view's table of scene.toml, as read by ``tomllib`` (may be incomplete).
    track : pandas.DataFrame or None
        The view's tracks (tracks.h5), None when not fitted.
    path : vidtrack.report.view_path.ViewPath or None
        The fitted path in the view.

    Returns
    -------
    ViewData
    """
    from vidtrack.report.overlay import camera_shifts

    raw = raw if isinstance(raw, dict) else {}
    tracked = {}
    if track is not None:
        frames = track["frame"].to_numpy()
        shifts = camera_shifts(track, len(frames))
        uv = np.column_stack([track["u_px"].to_numpy(), track["v_px"].to_numpy()]) + shifts
        rows = {}
        for i, f in enumerate(frames.tolist()):
            rows.setdefault(int(f), i)      # the first row of a frame, as before
        tracked = dict(frames=frames, uv=uv, shifts=shifts, table=track, rows=rows)
    return ViewData(excluded=_excluded(raw), manual=_manual(folder, scene_path, name, raw),
                    target=_target(raw), path=path,
                    polyline=path.polyline() if path is not None else None, **tracked)
