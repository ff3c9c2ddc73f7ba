"""The footage with what vidtrack measured and fitted drawn on it (``vidtrack overlay``).

Every frame of a view, in colour, with:

- the **measured centroid** (tracks.h5 ``u_px, v_px``) as a ring in the colour of the
  frame's flags (:data:`FLAG_COLOURS`: green when unflagged, else the colour of the
  lowest flag bit set, the first name in ``flag_names``);
- the **fitted path** (:mod:`vidtrack.report.view_path`) as a white line over the flight
  and the frame's fitted point as a small white cross;
- the **trail**: the measured points of the last ``trail`` frames before this one as
  pale yellow dots (:data:`TRAIL_COLOUR`) that fade with age;
- the **scene** where the view gives it (``front``/``top`` views: ``origin_px``, ``axes``
  and ``ruler`` of scene.toml) in pale blue (:data:`SCENE_COLOUR`): the origin O as a
  circled cross, each world axis as an arrow from O toward its positive direction
  labelled with its name, the ruler as a line between its ends with end ticks and its
  length;
- a dark banner in the top-left corner (the bottom-left one where it would hide the
  measured point and that one does not; the marks are drawn over it): the view, the
  frame number and its time, and the flag names in the flag colour (``ok`` when
  unflagged, ``not tracked`` for a frame outside the view's ``frames`` range).

The trail and the scene are pale (low saturation) so that the ring keeps the only
saturated colour near the object. The same drawing is used for the contact sheet of
report.html (:mod:`vidtrack.report.contact_sheet`). Frames are read, drawn and written
one at a time: memory does not grow with the length of the footage. The video is H.264
MP4 (:mod:`vidtrack.report._h264`), which browsers play inline.
"""

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["FLAG_COLOURS", "OK_COLOUR", "PATH_COLOUR", "TRAIL_COLOUR", "SCENE_COLOUR",
           "flag_colour", "flag_text", "to_bgr8", "draw_frame", "draw_marks", "draw_rings",
           "draw_trail", "draw_banner", "SceneMarks", "scene_marks", "draw_scene", "write_overlay",
           "OverlayResult", "MAX_SCALE", "MIN_SCALE", "MAX_EVERY", "TRAIL_FRAMES", "MAX_TRAIL"]

#: Colour (B, G, R) of an unflagged frame's marker.
OK_COLOUR = (0, 255, 0)
#: Colour of each flag bit (tracker flags, docs/tracker.md), by bit value.
FLAG_COLOURS = {
    1: (0, 140, 255),      # border: orange
    2: (0, 0, 255),        # blade: red
    4: (255, 0, 255),      # merged: magenta
    8: (0, 255, 255),      # lost: yellow (no marker: nothing measured)
    16: (0, 255, 255),     # predicted: yellow
    32: (255, 128, 0),     # pre_release: azure
    64: (128, 0, 255),     # outlier: pink
    128: (255, 255, 0),    # appearance: cyan
}
#: Colour of the fitted path and the frame's fitted point.
PATH_COLOUR = (255, 255, 255)
#: Colour of the trail of earlier measured points (pale yellow).
TRAIL_COLOUR = (150, 235, 255)
#: Colour of the scene: origin, axes, ruler (pale blue).
SCENE_COLOUR = (255, 215, 160)
#: Opacity of the newest trail point; it falls linearly to 0 over the trail.
TRAIL_OPACITY = 0.9
#: Frames of trail by default, and at most.
TRAIL_FRAMES, MAX_TRAIL = 30, 100_000
_GREY = (160, 160, 160)
_SHIFT = 4                 # sub-pixel drawing: coordinates in 1/16 px
_ONE = 1 << _SHIFT
#: Bounds of the options a user types.
MIN_SCALE, MAX_SCALE = 0.1, 4.0
MAX_EVERY = 100_000


def flag_colour(flags):
    """The marker colour of a frame's flag bits (lowest bit set wins; 0: green)."""
    flags = int(flags)
    if flags == 0:
        return OK_COLOUR
    low = flags & -flags
    return FLAG_COLOURS.get(low, _GREY)


def flag_text(flags):
    """The flag names as tracks.csv writes them (``MERGED|PRE_RELEASE``), ``ok`` for 0."""
    from vidtrack.track.tracker import FLAGS

    flags = int(flags)
    if flags == 0:
        return "ok"
    names = [FLAGS.get(b, f"bit{b}").upper() for b in sorted(FLAGS) if flags & b]
    rest = flags & ~sum(FLAGS)
    if rest:
        names.append(f"0x{rest:x}")
    return "|".join(names)


def to_bgr8(frame, bit_depth=8, scale=1.0):
    """A grey frame (8 or 16 bit) as an 8-bit BGR image, resized by ``scale``."""
    import cv2

    if frame.dtype != np.uint8:
        full = float(2 ** int(bit_depth) - 1) if bit_depth else float(np.iinfo(frame.dtype).max)
        frame = np.clip(frame.astype(np.float32) * (255.0 / full), 0, 255).astype(np.uint8)
    if scale != 1.0:
        h, w = frame.shape[:2]
        size = (max(1, int(round(w * scale))), max(1, int(round(h * scale))))
        frame = cv2.resize(frame, size, interpolation=cv2.INTER_AREA if scale < 1
                           else cv2.INTER_LINEAR)
    if frame.ndim == 2:
        frame = cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR)
    return frame


def _to_image(uv, scale, offset=(0.0, 0.0)):
    """Frame pixels (u, v) -> drawn image pixels: pixel centres scale about -0.5."""
    uv = np.asarray(uv, dtype=np.float64)
    return (uv - np.asarray(offset) + 0.5) * scale - 0.5


def ring_radius(img):
    """A measured point's ring radius on ``img`` (image pixels): a 40th of its smaller
    side, at least 5."""
    return max(5.0, min(img.shape[:2]) / 40.0)


def _pt(uv):
    return (int(round(uv[0] * _ONE)), int(round(uv[1] * _ONE)))


def camera_shifts(track, n):
    """A steadied view's camera shift per row, ``(n, 2)`` px (zeros where the camera
    did not shake, or a frame's shift is unknown): tracks.h5 keeps a steadied view's
    points and fitted path where a still camera sees them, and the footage as shot shows
    them moved by it."""
    from vidtrack.track.tracker import CAMERA_COLUMNS

    if not all(c in track for c in CAMERA_COLUMNS):
        return np.zeros((n, 2))
    sh = np.column_stack([np.asarray(track[c], dtype=np.float64) for c in CAMERA_COLUMNS])
    return np.where(np.isfinite(sh), sh, 0.0)


def draw_marks(img, *, measured, flags, path=None, fitted=None, scale=1.0,
               offset=(0.0, 0.0), radius=None):
    """Draw the fitted path, the fitted point and the measured point on ``img``.

    Parameters
    ----------
    img : numpy.ndarray
        BGR image, drawn in place.
    measured : (u, v) or None
        The measured centroid in frame pixels (NaN or None: nothing measured).
    flags : int
        The frame's flag bits (the marker's colour).
    path : (M, 2) array or None
        The fitted path in frame pixels.
    fitted : (u, v) or None
        The frame's fitted point in frame pixels.
    scale, offset
        Frame pixels -> image pixels: ``(uv - offset + 0.5) * scale - 0.5`` (a crop's
        corner and zoom, or the overlay's ``--scale``).
    radius : float, optional
        The ring's radius in image pixels (default from the image size).
    """
    import cv2

    h, w = img.shape[:2]
    if radius is None:
        radius = ring_radius(img)
    if path is not None and len(path) >= 2:
        pts = np.round(_to_image(path, scale, offset) * _ONE).astype(np.int64)
        cv2.polylines(img, [pts.astype(np.int32).reshape(-1, 1, 2)], False, PATH_COLOUR, 1,
                      cv2.LINE_AA, _SHIFT)
    if fitted is not None and np.all(np.isfinite(fitted)):
        c = _to_image(fitted, scale, offset)
        arm = 0.6 * radius
        for d in ((arm, 0), (0, arm)):
            cv2.line(img, _pt(c - d), _pt(c + d), PATH_COLOUR, 1, cv2.LINE_AA, _SHIFT)
    if measured is not None:
        draw_rings(img, [measured], [flags], scale=scale, offset=offset, radius=radius)


def draw_rings(img, points, flags, *, scale=1.0, offset=(0.0, 0.0), radius=None):
    """Draw measured points as rings in their flag colours, in order, as
    :func:`draw_marks` draws a frame's measured point.

    Parameters
    ----------
    img : numpy.ndarray
        BGR image, drawn in place.
    points : (N, 2) array
        Measured points in frame pixels (rows with NaN: nothing drawn).
    flags : (N,) array of int
        Each point's flag bits (its ring's colour).
    scale, offset, radius
        As for :func:`draw_marks`.
    """
    import cv2

    if radius is None:
        radius = ring_radius(img)
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    ok = np.all(np.isfinite(pts), axis=1)
    # all at once, rounded as _pt rounds one (half to even)
    centres = np.rint(_to_image(pts[ok], scale, offset) * _ONE).astype(np.int64)
    r = int(round(radius * _ONE))
    for (x, y), bits in zip(centres.tolist(), np.asarray(flags)[ok].tolist()):
        cv2.circle(img, (x, y), r, flag_colour(bits), 2, cv2.LINE_AA, _SHIFT)


def draw_trail(img, points, *, scale=1.0, offset=(0.0, 0.0), radius=None):
    """Draw the trail: earlier measured points as dots that fade with age.

    Parameters
    ----------
    img : numpy.ndarray
        BGR image, drawn in place.
    points : (N, 2) array
        Measured points in frame pixels, oldest first (NaN rows: nothing measured in
        that frame, nothing drawn). The newest is drawn with opacity
        :data:`TRAIL_OPACITY`, the i-th newest with ``TRAIL_OPACITY * (1 - i / N)``;
        where dots overlap the newest one's opacity holds (they do not add up).
    scale, offset
        As for :func:`draw_marks`.
    radius : float, optional
        The dots' radius in image pixels (default 0.4 of the ring's, at least 2).
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    n = len(pts)
    if n == 0:
        return
    h, w = img.shape[:2]
    if radius is None:
        radius = max(2.0, ring_radius(img) / 2.5)
    uv = _to_image(pts, scale, offset)
    ok = np.all(np.isfinite(uv), axis=1)
    if not ok.any():
        return
    alpha = TRAIL_OPACITY * np.arange(1, n + 1) / n
    uv, alpha = uv[ok], alpha[ok]
    r = int(np.ceil(radius))
    a0, b0 = np.maximum(np.floor(uv.min(axis=0)).astype(int) - r, 0)
    a1 = min(int(np.ceil(uv[:, 0].max())) + r + 1, w)
    b1 = min(int(np.ceil(uv[:, 1].max())) + r + 1, h)
    if a0 >= a1 or b0 >= b1:
        return
    # one opacity layer, each pixel the opacity of the newest dot over it: overlapping
    # dots do not add up, so the fade shows however close the points are
    layer = np.zeros((b1 - b0, a1 - a0), dtype=np.float32)
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    for (cu, cv), a in zip(uv, alpha):
        iu, iv = int(round(cu)), int(round(cv))
        disc = (xx + iu - cu) ** 2 + (yy + iv - cv) ** 2 <= radius * radius
        c0, r0 = iu - r - a0, iv - r - b0
        lo_c, lo_r = max(c0, 0), max(r0, 0)
        hi_c, hi_r = min(c0 + 2 * r + 1, a1 - a0), min(r0 + 2 * r + 1, b1 - b0)
        if lo_c >= hi_c or lo_r >= hi_r:
            continue
        sub = disc[lo_r - r0:hi_r - r0, lo_c - c0:hi_c - c0]
        view = layer[lo_r:hi_r, lo_c:hi_c]
        np.maximum(view, np.where(sub, np.float32(a), np.float32(0)), out=view)
    patch = img[b0:b1, a0:a1].astype(np.float32)
    colour = np.asarray(TRAIL_COLOUR, dtype=np.float32)
    a = layer[..., None]
    img[b0:b1, a0:a1] = (patch * (1.0 - a) + colour * a + 0.5).astype(np.uint8)


@dataclass(frozen=True)
class SceneMarks:
    """The scene of one view in frame pixels, as :func:`draw_scene` draws it.

    Attributes
    ----------
    origin : (float, float)
        The world origin O (scene.toml ``origin_px``).
    axes : tuple of (str, (float, float))
        Each world axis the view sees: its name (``"X"``) and the pixel its arrow from
        O points to (the positive direction, :data:`AXIS_ARROW` of the frame's shorter
        side long, through the view's mapping).
    ruler : ((float, float), (float, float), str) or None
        The ruler's ends and its label (``"0.5 m"``).
    """

    origin: tuple
    axes: tuple = ()
    ruler: tuple | None = None


#: An axis arrow's length as a fraction of the frame's shorter side.
AXIS_ARROW = 0.2


def scene_marks(view, frame_shape):
    """The origin, axes and ruler of ``view`` (a scene.toml view) in its pixels.

    Parameters
    ----------
    view : vidtrack.scene.ViewSpec
        A ``front``/``top`` view (``origin_px``, ``axes``, ``ruler``, the mapping).
    frame_shape : (rows, cols)

    Returns
    -------
    SceneMarks or None
        None for a view that gives no origin (a calibrated camera).
    """
    origin = getattr(view, "origin_px", None)
    if origin is None or not hasattr(view, "mapping"):
        return None
    mapping = view.mapping()
    length_m = AXIS_ARROW * min(frame_shape[:2]) * mapping.m_per_px
    axes = []
    for k, name in enumerate(mapping.world_axes):
        w = np.zeros(2)
        w[k] = length_m
        tip = mapping.world_to_pixel(w)
        axes.append((name.upper(), (float(tip[0]), float(tip[1]))))
    ruler = None
    if getattr(view, "ruler", None) is not None:
        r = view.ruler
        ruler = (tuple(map(float, r.from_px)), tuple(map(float, r.to_px)),
                 f"{r.length_m:.3g} m")
    return SceneMarks(origin=tuple(map(float, origin)), axes=tuple(axes), ruler=ruler)


def _label(img, text, at, colour, fs):
    import cv2

    cv2.putText(img, text, (int(round(at[0])), int(round(at[1]))), cv2.FONT_HERSHEY_SIMPLEX,
                fs, colour, 1, cv2.LINE_AA)


def draw_scene(img, marks, *, scale=1.0, offset=(0.0, 0.0)):
    """Draw a view's scene (:class:`SceneMarks`) on ``img`` in :data:`SCENE_COLOUR`.

    The origin O as a circled cross, each axis as an arrow from O labelled with its name
    at the tip, the ruler as a line with end ticks and its length beside the middle.
    ``scale, offset`` as for :func:`draw_marks`; ``marks`` None draws nothing.
    """
    import cv2

    if marks is None:
        return
    h, w = img.shape[:2]
    size = ring_radius(img)
    fs = float(np.clip(min(h, w) / 500.0, 0.3, 0.8))
    o = _to_image(marks.origin, scale, offset)
    cv2.circle(img, _pt(o), int(round(size * _ONE)), SCENE_COLOUR, 1, cv2.LINE_AA, _SHIFT)
    for d in ((size, 0.0), (0.0, size)):
        cv2.line(img, _pt(o - d), _pt(o + d), SCENE_COLOUR, 1, cv2.LINE_AA, _SHIFT)
    for name, tip in marks.axes:
        t = _to_image(tip, scale, offset)
        if not np.all(np.isfinite(t)):
            continue
        cv2.arrowedLine(img, _pt(o), _pt(t), SCENE_COLOUR, 1, cv2.LINE_AA, _SHIFT, 0.12)
        _label(img, name, t + np.sign(t - o) * 4 + (-4, 4), SCENE_COLOUR, fs)
    if marks.ruler is not None:
        a, b = (_to_image(p, scale, offset) for p in marks.ruler[:2])
        cv2.line(img, _pt(a), _pt(b), SCENE_COLOUR, 1, cv2.LINE_AA, _SHIFT)
        along = b - a
        norm = np.hypot(*along)
        if norm > 0:
            across = np.array([-along[1], along[0]]) / norm * (size * 0.8)
            for p in (a, b):
                cv2.line(img, _pt(p - across), _pt(p + across), SCENE_COLOUR, 1, cv2.LINE_AA,
                         _SHIFT)
            (tw, _), _ = cv2.getTextSize(marks.ruler[2], cv2.FONT_HERSHEY_SIMPLEX, fs, 1)
            _label(img, marks.ruler[2], (a + b) / 2 - across * 1.5 - (tw / 2, 0),
                   SCENE_COLOUR, fs)


def draw_banner(img, lines, colours, avoid=None):
    """Text lines on a dark banner in the top-left corner (the size follows the image);
    in the bottom-left corner where the top-left one would cover ``avoid`` and that one
    does not: an image point with the radius about it that should stay in view, ``(u,
    v, r)`` (the measured point's ring)."""
    import cv2

    h, w = img.shape[:2]
    fs = float(np.clip(w / 900.0, 0.33, 1.0))
    th = max(1, int(round(fs * 1.6)))
    sizes = [cv2.getTextSize(t, cv2.FONT_HERSHEY_SIMPLEX, fs, th) for t in lines]
    line_h = max(s[0][1] + s[1] for s in sizes) + 4
    right = min(w - 1, max(s[0][0] for s in sizes) + 8)
    depth = min(h - 1, line_h * len(lines) + 2)
    top = 0
    if avoid is not None and np.all(np.isfinite(avoid)):
        u, v, r = avoid
        if u - r <= right and v - r <= depth and v + r < h - 1 - depth:
            top = h - 1 - depth
    cv2.rectangle(img, (0, top), (right, top + depth), (0, 0, 0), -1)
    for k, (text, colour) in enumerate(zip(lines, colours)):
        cv2.putText(img, text, (4, top + (k + 1) * line_h - 3), cv2.FONT_HERSHEY_SIMPLEX, fs,
                    colour, th, cv2.LINE_AA)


def draw_frame(img, *, view, frame, time_s, flags, measured=None, trail=None, shift=None,
               path=None, fitted=None, scene=None, scale=1.0, status=None):
    """Draw everything the overlay shows on one frame: scene, trail, banner and marks.

    Parameters
    ----------
    img : numpy.ndarray
        The frame as a BGR image (:func:`to_bgr8`, resized by ``scale``), drawn in place.
    view : str
    frame : int
        The frame's number in the file (the banner).
    time_s : float
        Its time (the banner).
    flags : int or None
        The frame's flag bits; None: the frame was not tracked.
    measured : (u, v), optional
        The measured point as the footage shows it (a steadied view's camera shift added).
    trail : (N, 2) array, optional
        Earlier measured points, oldest first (:func:`draw_trail`).
    shift : (du, dv), optional
        A steadied view's camera shift in this frame: the scene, the fitted path and
        point move with it.
    path, fitted : see :func:`draw_marks` (where a still camera sees them).
    scene : SceneMarks, optional
    scale : float
    status : str, optional
        The banner's second line (default: the flag names, ``not tracked``).
    """
    sh = np.zeros(2) if shift is None else np.asarray(shift, dtype=np.float64)
    draw_scene(img, scene, scale=scale, offset=-sh)
    if trail is not None:
        draw_trail(img, trail, scale=scale)
    if status is None:
        status = flag_text(flags) if flags is not None else "not tracked"
    colour = flag_colour(flags) if flags is not None else _GREY
    avoid = None
    if measured is not None:
        # (the banner where it leaves the measured point's ring in view, and the marks
        # drawn over it where no corner does: a small image)
        avoid = (*_to_image(measured, scale), ring_radius(img) + 2.0)
    draw_banner(img, [f"{view}  frame {frame}  t {time_s:.5f} s", status],
                [(255, 255, 255), colour], avoid=avoid)
    draw_marks(img, measured=measured, flags=flags or 0,
               path=None if path is None else path + sh,
               fitted=None if fitted is None else fitted + sh, scale=scale)


@dataclass(frozen=True)
class OverlayResult:
    """What :func:`write_overlay` wrote."""

    path: Path
    frames: int
    size: tuple
    codec: str
    seconds: float
    note: str | None = None


class _MjpgWriter:
    """OpenCV's MJPG .avi: only where the imageio-ffmpeg wheel has no ffmpeg binary."""

    def __init__(self, path, size, fps):
        import cv2

        self.path = path
        self.size = self.out_size = size
        self._cv2 = cv2
        self._w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), float(fps),
                                  size)
        if not self._w.isOpened():
            self._w.release()
            raise OSError(f"{path}: OpenCV's MJPG video writer did not open")
        self.frames = 0

    def write(self, img):
        self._w.write(img)
        self.frames += 1

    def close(self):
        self._w.release()
        from vidtrack._atomic import check_video_written

        check_video_written(self.path, self.frames, self.path)

    def abort(self):
        self._w.release()


def _open_writer(work, size, fps):
    """(writer, codec): H.264 through imageio-ffmpeg's ffmpeg, else OpenCV's MJPG."""
    from vidtrack.report._h264 import H264Writer, ffmpeg_exe

    exe = ffmpeg_exe()
    if exe is not None:
        return H264Writer(work, size, fps, exe=exe), "h264"
    return _MjpgWriter(work, size, fps), "MJPG"


def _trail_rows(frames, k, n):
    """Rows of the ``n`` frames before row ``k`` (the track's frames in order)."""
    if k is None or n <= 0:
        return slice(0, 0)
    first = int(np.searchsorted(frames, frames[k] - n, side="left"))
    return slice(first, k)


def write_overlay(source, out_dir, view, track, path=None, *, every=1, scale=1.0,
                  fps_out=None, trail=TRAIL_FRAMES, scene=None, quiet=True):
    """Write ``<out_dir>/overlay_<view>.mp4``: ``source``'s frames with the marks drawn.

    Parameters
    ----------
    source : vidtrack.footage.FrameSource
        The view's footage (open; a ``frames`` range of it gives only those frames).
    out_dir : path
        The run's output folder.
    view : str
    track : mapping of str to array
        The view's track (tracks.h5): ``frame``, ``u_px``, ``v_px``, ``flags``.
    path : vidtrack.report.view_path.ViewPath, optional
        The fitted path in this view (None: not drawn).
    every : int
        Every N-th frame of the source (1: all).
    scale : float
        Output size / footage size.
    fps_out : float, optional
        Playback rate of the file (default: the rate the footage's container states,
        else 30).
    trail : int
        The trail: measured points of the last ``trail`` frames before each frame
        (0: none; :func:`draw_trail`).
    scene : SceneMarks, optional
        The view's origin, axes and ruler (:func:`scene_marks`; None: not drawn).
    quiet : bool
        No progress bar.

    Returns
    -------
    OverlayResult
        ``codec`` ``"h264"``: H.264 in MP4 (4:2:0, even sizes, index at the front;
        :mod:`vidtrack.report._h264`). The file is written whole or not at all: under a
        temporary name, renamed at the end; a full disk raises DiskFullError naming it.
        Where the imageio-ffmpeg wheel has no ffmpeg binary, an MJPG ``.avi`` written by
        OpenCV instead (``note`` says so).
    """
    from vidtrack._atomic import atomic_path
    from vidtrack._progress import progress
    from vidtrack.report._h264 import ffmpeg_exe

    t_start = time.perf_counter()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    rows, cols = source.shape[:2]
    size = (max(1, int(round(cols * scale))), max(1, int(round(rows * scale))))
    fps_out = fps_out or source.fps_container or 30.0
    ext = ".mp4" if ffmpeg_exe() is not None else ".avi"
    note = None if ext == ".mp4" else (
        "the imageio-ffmpeg wheel has no ffmpeg binary here: wrote OpenCV's MJPG .avi "
        "instead of H.264 .mp4")
    final = out_dir / f"overlay_{view}{ext}"
    order = np.argsort(np.asarray(track["frame"], dtype=np.int64), kind="stable")
    frames = np.asarray(track["frame"], dtype=np.int64)[order]
    row_of = {int(f): k for k, f in enumerate(frames)}
    u = np.asarray(track["u_px"], dtype=np.float64)[order]
    v = np.asarray(track["v_px"], dtype=np.float64)[order]
    fl = np.asarray(track["flags"], dtype=np.int64)[order]
    shifts = camera_shifts(track, len(frames))[order]
    uv_shown = np.column_stack([u, v]) + shifts
    numbers = source.frame_numbers
    times = source.times_s
    fitted = polyline = None
    if path is not None:
        fitted = path.at_frames(numbers, times)
        polyline = path.polyline()
    written = 0
    bar = progress(total=(len(source) + every - 1) // every, desc=f"overlay {view}",
                   quiet=quiet, unit="frame")
    with atomic_path(final) as tmp:
        writer, codec = _open_writer(tmp, size, fps_out)
        try:
            for i, frame in enumerate(source):
                if i % every:
                    continue
                img = to_bgr8(frame, source.bit_depth, scale)
                f = int(numbers[i])
                k = row_of.get(f)
                draw_frame(img, view=view, frame=f, time_s=times[i],
                           flags=None if k is None else int(fl[k]),
                           measured=None if k is None else uv_shown[k],
                           trail=uv_shown[_trail_rows(frames, k, trail)],
                           shift=None if k is None else shifts[k], path=polyline,
                           fitted=None if fitted is None else fitted[i], scene=scene,
                           scale=scale)
                writer.write(img)
                written += 1
                bar.update()
            writer.close()
        except BaseException:
            writer.abort()
            raise
        finally:
            bar.close()
    return OverlayResult(path=final, frames=written, size=tuple(writer.out_size),
                         codec=codec, seconds=time.perf_counter() - t_start, note=note)
