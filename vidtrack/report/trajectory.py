"""Each view in its own pixels for report.html: the whole track over one full frame, and
the residuals in pixels.

- **The trajectory** (:func:`trajectory_image`): one frame of the view's footage near the
  middle of the flight (the unflagged, measured frame nearest the middle of the fit's
  time span), in colour, with every measured point of the view drawn over it as a small
  ring in its flag colour, the fitted path (:mod:`vidtrack.report.view_path`) as a white
  line, the view's origin, axes and ruler, and the shown frame's own point, fitted point
  and banner as the overlay draws them (:func:`vidtrack.report.overlay.draw_frame`,
  :func:`~vidtrack.report.overlay.draw_marks`). A steadied view's points and path are
  moved by the shown frame's camera shift, where that frame shows them. Only that frame
  is read (``source[i]``).
- **The residuals in pixels** (:func:`pixel_residuals`): each unflagged measured point
  minus the fitted path at the same frame, ``du_px``, ``dv_px`` (column, row), for every
  view with pixel points, footage or not (points digitized elsewhere too).
"""

from dataclasses import dataclass

import numpy as np

__all__ = ["PixelResiduals", "pixel_residuals", "pick_trajectory_frame", "trajectory_image",
           "trajectory_html", "footage_html", "read_ahead", "POINT_RADIUS_PX",
           "TRAJECTORY_WIDTH_PX", "MAX_TRAJECTORY_SCALE"]

#: The drawn frame's width (image px) the footage is scaled to, at most
#: :data:`MAX_TRAJECTORY_SCALE` times its own size (a 400 px wide view is drawn 800 wide,
#: a 1024 px one 800).
TRAJECTORY_WIDTH_PX = 800
MAX_TRAJECTORY_SCALE = 2.0
#: The ring of each measured point (image px): small, so that neighbouring frames' rings
#: stay apart where the straw moves a few pixels a frame.
POINT_RADIUS_PX = 2.5


@dataclass(frozen=True, eq=False)
class PixelResiduals:
    """One view's residuals in pixels: unflagged measured points minus the fitted path.

    Attributes
    ----------
    view : str
    frame : numpy.ndarray
        The file's frame index of each point (int).
    t_s : numpy.ndarray
        The fit's time of each point (s since the release).
    du_px, dv_px : numpy.ndarray
        Measured minus fitted, column and row (px).
    """

    view: str
    frame: np.ndarray
    t_s: np.ndarray
    du_px: np.ndarray
    dv_px: np.ndarray

    @property
    def points(self):
        """The number of points."""
        return int(self.frame.size)

    @property
    def rms_u_px(self):
        """RMS of ``du_px`` (NaN without points)."""
        return _rms(self.du_px)

    @property
    def rms_v_px(self):
        """RMS of ``dv_px`` (NaN without points)."""
        return _rms(self.dv_px)

    @property
    def rms_px(self):
        """RMS distance from the path, ``sqrt(mean(du² + dv²))`` (NaN without points)."""
        return float(np.hypot(self.rms_u_px, self.rms_v_px))


def _rms(x):
    return float(np.sqrt(np.mean(np.square(x)))) if np.size(x) else float("nan")


def pixel_residuals(tracks, paths):
    """Each view's residuals in pixels against its fitted path.

    Parameters
    ----------
    tracks : dict of str to mapping
        Each view's track columns (tracks.h5: ``frame``, ``t_s``, ``u_px``, ``v_px``,
        ``flags``), where a still camera sees the points.
    paths : dict of str to vidtrack.report.view_path.ViewPath
        The fitted path in each view; a view without one has no residuals.

    Returns
    -------
    dict of str to PixelResiduals
        Views with a path, in the order of ``tracks``: their unflagged, measured points
        where the path is drawn (the flight, t = 0 .. its last measured time).
    """
    out = {}
    for name, d in tracks.items():
        if name not in paths:
            continue
        frame = np.asarray(d["frame"], dtype=np.int64)
        uv = np.column_stack([np.asarray(d["u_px"], dtype=np.float64),
                              np.asarray(d["v_px"], dtype=np.float64)])
        path = paths[name]
        t_view = np.asarray(d["t_s"], dtype=np.float64)
        t = path.world_time(frame, t_view)
        fitted = path.pixels_at(t)
        ok = ((np.asarray(d["flags"]) == 0) & np.all(np.isfinite(uv), axis=1)
              & np.all(np.isfinite(fitted), axis=1))
        res = uv[ok] - fitted[ok]
        out[name] = PixelResiduals(view=name, frame=frame[ok], t_s=t[ok], du_px=res[:, 0],
                                   dv_px=res[:, 1])
    return out


def pick_trajectory_frame(track, path=None):
    """The row of ``track`` to show the trajectory over: the unflagged, measured frame
    whose time is nearest the middle of the flight (of the fit's t = 0 .. its last
    measured time with a ``path``, else of the unflagged frames); any measured frame if
    none is unflagged, else the middle row. None for an empty track."""
    frame = np.asarray(track["frame"])
    if frame.size == 0:
        return None
    seen = np.isfinite(np.asarray(track["u_px"], dtype=np.float64))
    ok = seen & (np.asarray(track["flags"]) == 0)
    t = np.asarray(track["t_s"], dtype=np.float64)
    if path is not None:
        t = path.world_time(frame, t)
        flight = ok & (t >= 0) & (t <= path.t_end_s)
        ok = flight if flight.any() else ok
    rows = np.flatnonzero(ok if ok.any() else seen)
    if rows.size == 0:
        return frame.size // 2
    middle = 0.5 * (np.nanmin(t[rows]) + np.nanmax(t[rows]))
    return int(rows[np.nanargmin(np.abs(t[rows] - middle))])


def trajectory_image(frame, track, row, *, path=None, scene=None, view="", bit_depth=8):
    """The whole track drawn over one full frame of a view's footage.

    Parameters
    ----------
    frame : numpy.ndarray
        The footage's frame at ``track``'s ``row`` (grey, 8 or 16 bit, as read).
    track : mapping of str to array
        The view's track columns (``frame``, ``t_s``, ``u_px``, ``v_px``, ``flags``; a
        steadied view's camera shift).
    row : int
        The row of ``track`` that ``frame`` is (:func:`pick_trajectory_frame`).
    path : vidtrack.report.view_path.ViewPath, optional
        The fitted path (None: not drawn).
    scene : vidtrack.report.overlay.SceneMarks, optional
        The view's origin, axes and ruler.
    view : str
        The view's name (the banner).
    bit_depth : int
        The footage's bits per pixel.

    Returns
    -------
    (numpy.ndarray, float)
        The drawn BGR image and its scale: frame pixel (u, v) is image pixel
        ``((u + 0.5) * scale - 0.5, (v + 0.5) * scale - 0.5)``.
    """
    from vidtrack.report.overlay import camera_shifts, draw_frame, draw_rings, to_bgr8

    cols = frame.shape[1]
    scale = float(min(MAX_TRAJECTORY_SCALE, TRAJECTORY_WIDTH_PX / max(cols, 1)))
    img = to_bgr8(frame, bit_depth, scale)
    n = len(np.asarray(track["frame"]))
    sh = camera_shifts(track, n)[row]
    uv = np.column_stack([np.asarray(track["u_px"], dtype=np.float64),
                          np.asarray(track["v_px"], dtype=np.float64)])
    flags = np.asarray(track["flags"], dtype=np.int64)
    others = np.arange(len(uv)) != row
    draw_rings(img, uv[others] + sh, flags[others], scale=scale, radius=POINT_RADIUS_PX)
    frame_no = int(np.asarray(track["frame"])[row])
    t_s = float(np.asarray(track["t_s"], dtype=np.float64)[row])
    polyline = fitted = None
    if path is not None:
        polyline = path.polyline()
        fitted = path.at_frames([frame_no], [t_s])[0]
    measured = uv[row] + sh if np.all(np.isfinite(uv[row])) else None
    draw_frame(img, view=view, frame=frame_no, time_s=t_s, flags=int(flags[row]),
               measured=measured, shift=sh, path=polyline, fitted=fitted, scene=scene,
               scale=scale)
    return img, scale


def trajectory_html(sources, tracks, paths, *, scenes=None):
    """The trajectory images of the views with footage, as ``<img>`` tags.

    Parameters
    ----------
    sources : dict of str to FrameSource
        The views with footage, opened on the whole file (index = file frame).
    tracks, paths
        As for :func:`pixel_residuals`.
    scenes : dict of str to SceneMarks, optional
        Each view's origin, axes and ruler.

    Returns
    -------
    (list of str, list of str)
        An ``<img>`` per view shown, and notes (frames that could not be read).
    """
    from vidtrack.report import _html

    imgs, notes = [], []
    for name, src in sources.items():
        d = tracks[name]
        row = pick_trajectory_frame(d, paths.get(name))
        if row is None:
            continue
        frame_no = int(np.asarray(d["frame"])[row])
        if not 0 <= frame_no < len(src):
            notes.append(f"{name} frame {frame_no}: not in the footage ({len(src)} frames)")
            continue
        img, _ = trajectory_image(src[frame_no], d, row, path=paths.get(name),
                                  scene=(scenes or {}).get(name), view=name,
                                  bit_depth=src.bit_depth)
        imgs.append(_html.img(_html.encode_png(img), alt=f"trajectory {name}"))
    return imgs, notes


def footage_html(scene, folder, tracks, paths):
    """The report's sections drawn on the footage: the trajectory over a full frame of
    each view (:func:`trajectory_html`), then the contact sheet
    (:func:`vidtrack.report.contact_sheet.contact_sheet_html`), the footage opened once
    and the frames both show read once, in increasing order (:func:`read_ahead`).

    Parameters
    ----------
    scene : vidtrack.scene.Scene
    folder : path
        The throw's folder (the run's for a run of one throw).
    tracks : dict of str to mapping
        The merged tracks' columns per view.
    paths : dict of str to vidtrack.report.view_path.ViewPath

    Returns
    -------
    str
        HTML; a run without footage gets a line saying why instead of the images.
    """
    from vidtrack.report import _html
    from vidtrack.report.contact_sheet import contact_sheet_html, open_views
    from vidtrack.report.overlay import scene_marks

    head = "<h2>Trajectory over a full frame</h2>"
    opened, missing = open_views(scene, folder, tracks)
    try:
        if opened:
            opened = read_ahead(opened, _shown_frames(opened, tracks, paths))
            marks = {n: scene_marks(scene.views[n], s.shape) for n, s in opened.items()}
            imgs, notes = trajectory_html(opened, tracks, paths, scenes=marks)
            part = [head, "<p>One frame of each view near the middle of the flight with "
                    "every measured point of the view drawn over it: small rings, green "
                    "when unflagged, else the colour of the first flag named (as in the "
                    "contact sheet); white line: the fitted path; the frame's own point as "
                    "a large ring with its fitted point as a white cross; the origin, axes "
                    "and ruler in pale blue.</p>"] + imgs
            part += [f'<p class="note">{_html.esc(n)}</p>' for n in notes]
        else:
            part = [head, f'<p class="note">No footage to show: '
                          f'{_html.esc("; ".join(missing))}.</p>']
        sheet = contact_sheet_html(scene, folder, tracks, paths, sources=opened,
                                   missing=missing)
    finally:
        for s in opened.values():
            s.close()
    return "".join(part) + sheet


def _shown_frames(sources, tracks, paths):
    """{view: file frames} that :func:`footage_html` shows of each view with footage:
    the trajectory's frame and the contact sheet's."""
    from vidtrack.report.contact_sheet import pick_frames

    shown = {n: d for n, d in tracks.items() if n in sources}
    out = {n: [] for n in shown}
    for name, d in shown.items():
        row = pick_trajectory_frame(d, paths.get(name))
        if row is not None:
            out[name].append(int(np.asarray(d["frame"])[row]))
    for name, row, _ in pick_frames(shown, paths):
        out[name].append(int(np.asarray(shown[name]["frame"])[row]))
    return out


class _ReadAhead:
    """A view's footage with some frames read already: ``src[i]`` gives those without
    reading them again; the rest, ``len`` and the attributes are the source's."""

    def __init__(self, source, frames):
        self._source = source
        self._frames = frames

    def __getattr__(self, name):
        return getattr(self._source, name)

    def __len__(self):
        return len(self._source)

    def __getitem__(self, i):
        return self._frames[i] if i in self._frames else self._source[i]


def read_ahead(sources, frames):
    """Each view's ``frames`` read once, in increasing order, and the views' footage
    giving them without reading them again.

    A video decodes on from where it stands (to a frame a few ahead) or seeks; the first
    read decodes from the start to check that seeking is exact. Read in increasing order,
    the earliest frame shown is that first read, not a frame in the middle of the flight.

    Parameters
    ----------
    sources : dict of str to FrameSource
        The views with footage, opened on the whole file (the caller closes them).
    frames : dict of str to list of int
        File frames of each view to read; those outside the footage are left to the
        caller (who says so).

    Returns
    -------
    dict of str to FrameSource-like
        ``src[i]``, ``len(src)`` and the attributes (``bit_depth``, ``shape``) of each
        view's footage.
    """
    out = {}
    for name, src in sources.items():
        wanted = sorted({k for k in frames.get(name, ()) if 0 <= k < len(src)})
        out[name] = _ReadAhead(src, {k: src[k] for k in wanted})
    return out
