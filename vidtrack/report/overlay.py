"""The footage with what vidtrack measured and fitted drawn on it (``vidtrack overlay``).

Every frame of a view, in colour, with:

- the **measured centroid** (tracks.h5 ``u_px, v_px``) as a ring in the colour of the
  frame's flags (:data:`FLAG_COLOURS`: green when unflagged, else the colour of the
  lowest flag bit set, the first name in ``flag_names``);
- the **fitted path** (:mod:`vidtrack.report.view_path`) as a white line over the flight
  and the frame's fitted point as a small white cross;
- a dark banner in the top-left corner: the view, the frame number and its time, and
  the flag names in the flag colour (``ok`` when unflagged, ``not tracked`` for a
  frame outside the view's ``frames`` range).

The same drawing is used for the contact sheet of report.html
(:mod:`vidtrack.report.contact_sheet`). Frames are read, drawn and written one at a
time: memory does not grow with the length of the footage.
"""

import contextlib
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["FLAG_COLOURS", "OK_COLOUR", "PATH_COLOUR", "flag_colour", "flag_text",
           "to_bgr8", "draw_marks", "draw_banner", "write_overlay", "OverlayResult",
           "MAX_SCALE", "MIN_SCALE", "MAX_EVERY"]

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
        radius = max(5.0, min(h, w) / 40.0)
    if path is not None and len(path) >= 2:
        pts = np.round(_to_image(path, scale, offset) * _ONE).astype(np.int64)
        cv2.polylines(img, [pts.astype(np.int32).reshape(-1, 1, 2)], False, PATH_COLOUR, 1,
                      cv2.LINE_AA, _SHIFT)
    if fitted is not None and np.all(np.isfinite(fitted)):
        c = _to_image(fitted, scale, offset)
        arm = 0.6 * radius
        for d in ((arm, 0), (0, arm)):
            cv2.line(img, _pt(c - d), _pt(c + d), PATH_COLOUR, 1, cv2.LINE_AA, _SHIFT)
    if measured is not None and np.all(np.isfinite(measured)):
        c = _to_image(measured, scale, offset)
        cv2.circle(img, _pt(c), int(round(radius * _ONE)), flag_colour(flags), 2,
                   cv2.LINE_AA, _SHIFT)


def draw_banner(img, lines, colours):
    """Text lines on a dark banner in the top-left corner (the size follows the image)."""
    import cv2

    h, w = img.shape[:2]
    fs = float(np.clip(w / 900.0, 0.33, 1.0))
    th = max(1, int(round(fs * 1.6)))
    sizes = [cv2.getTextSize(t, cv2.FONT_HERSHEY_SIMPLEX, fs, th) for t in lines]
    line_h = max(s[0][1] + s[1] for s in sizes) + 4
    width = max(s[0][0] for s in sizes) + 8
    cv2.rectangle(img, (0, 0), (min(w - 1, width), min(h - 1, line_h * len(lines) + 2)),
                  (0, 0, 0), -1)
    for k, (text, colour) in enumerate(zip(lines, colours)):
        cv2.putText(img, text, (4, (k + 1) * line_h - 3), cv2.FONT_HERSHEY_SIMPLEX, fs,
                    colour, th, cv2.LINE_AA)


@dataclass(frozen=True)
class OverlayResult:
    """What :func:`write_overlay` wrote."""

    path: Path
    frames: int
    size: tuple
    codec: str
    seconds: float
    note: str | None = None


def _writer(cv2, path, codec, fps, size):
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*codec), float(fps), size)
    if w.isOpened():
        return w
    w.release()
    with contextlib.suppress(OSError):
        os.unlink(path)
    return None


def _pick_codec(cv2, folder, fps, size):
    """("mp4v", ".mp4") when OpenCV can write it here, else ("MJPG", ".avi")."""
    import tempfile

    for codec, ext in (("mp4v", ".mp4"), ("MJPG", ".avi")):
        fd, probe = tempfile.mkstemp(prefix=".overlay-probe-", suffix=ext, dir=folder)
        os.close(fd)
        w = _writer(cv2, probe, codec, fps, size)
        if w is not None:
            w.release()
        with contextlib.suppress(OSError):
            os.unlink(probe)
        if w is not None:
            return codec, ext
    from vidtrack.errors import VidtrackError

    raise VidtrackError(f"{folder}: OpenCV cannot write a video here (neither mp4v .mp4 nor "
                        "MJPG .avi opened); expected an OpenCV with FFmpeg video writing")


def write_overlay(source, out_dir, view, track, path=None, *, every=1, scale=1.0,
                  fps_out=None, quiet=True):
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
    quiet : bool
        No progress bar.

    Returns
    -------
    OverlayResult
        The file is written whole or not at all: under a temporary name, renamed at the
        end. When OpenCV cannot write mp4v, an MJPG ``.avi`` instead (``note`` says so).
    """
    import cv2

    from vidtrack._atomic import atomic_path, check_video_written
    from vidtrack._progress import progress

    t_start = time.perf_counter()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    rows, cols = source.shape[:2]
    size = (max(1, int(round(cols * scale))), max(1, int(round(rows * scale))))
    fps_out = fps_out or source.fps_container or 30.0
    codec, ext = _pick_codec(cv2, out_dir, fps_out, size)
    note = None if codec == "mp4v" else (
        f"OpenCV cannot write mp4v (.mp4) here: wrote MJPG {ext} instead")
    final = out_dir / f"overlay_{view}{ext}"
    frames = np.asarray(track["frame"], dtype=np.int64)
    row_of = {int(f): k for k, f in enumerate(frames)}
    u = np.asarray(track["u_px"], dtype=np.float64)
    v = np.asarray(track["v_px"], dtype=np.float64)
    fl = np.asarray(track["flags"], dtype=np.int64)
    shifts = camera_shifts(track, len(frames))
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
        work = tmp.with_name(tmp.name + ext)
        writer = _writer(cv2, work, codec, fps_out, size)
        try:
            if writer is None:
                raise OSError(f"{work}: the video writer did not open")
            for i, frame in enumerate(source):
                if i % every:
                    continue
                img = to_bgr8(frame, source.bit_depth, scale)
                f = int(numbers[i])
                k = row_of.get(f)
                flags = int(fl[k]) if k is not None else 0
                sh = shifts[k] if k is not None else np.zeros(2)
                draw_marks(img, measured=None if k is None else (u[k] + sh[0], v[k] + sh[1]),
                           flags=flags, path=None if polyline is None else polyline + sh,
                           fitted=None if fitted is None else fitted[i] + sh, scale=scale)
                status = flag_text(flags) if k is not None else "not tracked"
                colour = flag_colour(flags) if k is not None else _GREY
                draw_banner(img, [f"{view}  frame {f}  t {times[i]:.5f} s", status],
                            [(255, 255, 255), colour])
                writer.write(img)
                written += 1
                bar.update()
            writer.release()
            writer = None
            check_video_written(work, written, final)
            os.replace(work, tmp)
        finally:
            bar.close()
            if writer is not None:
                writer.release()
            with contextlib.suppress(OSError):
                os.unlink(work)
    return OverlayResult(path=final, frames=written, size=size, codec=codec,
                         seconds=time.perf_counter() - t_start, note=note)
