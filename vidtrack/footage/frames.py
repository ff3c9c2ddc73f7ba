"""Frame sources: one small interface over videos, image folders and Phantom .cine files.

Every source is a lazy sequence of grey 2-D numpy frames with a time base:

>>> from vidtrack.footage.frames import open_source                      # doctest: +SKIP
>>> with open_source("run42/front.avi", fps=1200) as src:        # doctest: +SKIP
...     print(len(src), src.shape, src.dtype, src.bit_depth, src.fps)
...     for i, frame in enumerate(src):                           # streams, one frame at a time
...         t = src.time_s(i)

Indices and times
-----------------
``source[i]`` and ``source.time_s(i)`` use *source indices* ``0 .. len(source) - 1``.
With ``frames=(a, b)`` the source covers the file's frames ``a .. b - 1``;
``source.frame_numbers[i]`` is the 0-based index of source frame ``i`` in the file
(``a + i``). Times are in seconds relative to the file's first frame (file frame 0),
so a range does not shift the clock.

The time base (which rate gives the times) is, in order of precedence:

1. per-image time stamps of a .cine file (unless ``use_time_stamps=False``);
2. ``fps``, the CAPTURE rate given by the user (``scene.toml`` ``views.<v>.fps``):
   exported high-speed videos usually carry a playback rate (30 fps) in the container;
3. the rate the container claims (video: its frame rate; .cine: the setup FrameRate).

An image folder has no rate of its own: without ``fps`` its times are unknown and
``time_s`` raises :class:`~vidtrack.errors.SourceError`.

Colour
------
Colour frames are converted to grey with OpenCV's ``cvtColor`` (ITU-R BT.601 luma,
``0.299 R + 0.587 G + 0.114 B``), keeping the dtype (8-bit stays 8-bit, 16-bit stays
16-bit). Grey frames that a container stores as three equal channels come back
unchanged.

A video whose decoder gives its luma plane directly (full-range YUV, as MJPEG's) is
read as that plane, without the conversion to BGR and back: about 30 % less decoding
time. That path is taken only when, on frame 0, the luma plane equals the grey of the
decoded BGR frame to within one grey level (the two differ only by rounding, and by
clipping in strongly saturated colours); otherwise (limited-range YUV as MPEG-4's,
packed RGB, any decoder that does not give the plane) the BGR frame is converted.
"""

import os
import re
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vidtrack.errors import SourceError, VidtrackError

__all__ = [
    "EXPORT_FORMATS",
    "FrameExport",
    "FrameSource",
    "ImageFolderSource",
    "VideoSource",
    "IMAGE_SUFFIXES",
    "export_frames",
    "natural_key",
    "open_source",
    "to_grey",
]

#: File name endings an image folder source reads (case-insensitive).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")

#: Largest forward gap that random access in a video bridges by decoding on rather
#: than seeking.
_VIDEO_SKIP_MAX = 48


def _cv2():
    """Import OpenCV with its own and FFmpeg's log chatter off (one-line errors)."""
    os.environ.setdefault("OPENCV_LOG_LEVEL", "ERROR")
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")
    import cv2

    # the variables act only on the first import (calibration may have imported cv2)
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
    return cv2


def natural_key(name):
    """Sort key that orders the digit runs of a name by value: ``img2`` before ``img10``.

    Parameters
    ----------
    name : str or os.PathLike
        A file name (only the final component is used for paths).

    Returns
    -------
    tuple
        Alternating lower-cased text and integer parts, comparable between names.
    """
    text = Path(name).name if isinstance(name, os.PathLike) else str(name)
    parts = re.split(r"(\d+)", text)
    return tuple(int(p) if k % 2 else p.lower() for k, p in enumerate(parts)) + (text,)


def to_grey(image):
    """Return ``image`` as a 2-D grey array of the same dtype (BT.601 luma for colour).

    Parameters
    ----------
    image : numpy.ndarray
        ``(rows, cols)``, ``(rows, cols, 1)``, BGR ``(rows, cols, 3)`` or BGRA
        ``(rows, cols, 4)`` as OpenCV returns them.

    Returns
    -------
    numpy.ndarray
        ``(rows, cols)``.
    """
    if image.ndim == 2:
        return image
    if image.ndim == 3 and image.shape[2] == 1:
        return image[:, :, 0]
    cv2 = _cv2()
    if image.ndim == 3 and image.shape[2] == 3:
        return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    if image.ndim == 3 and image.shape[2] == 4:
        return cv2.cvtColor(image, cv2.COLOR_BGRA2GRAY)
    raise SourceError(f"cannot convert an image of shape {image.shape} to grey")


def _check_fps(fps, what="fps"):
    if fps is None:
        return None
    try:
        value = float(fps)
    except (TypeError, ValueError):
        raise SourceError(f"{what} must be a number of frames per second, got {fps!r}") from None
    if not np.isfinite(value) or value <= 0:
        raise SourceError(f"{what} must be a finite number > 0 (frames/s), got {fps!r}")
    return value


def _check_range(frames):
    """``(a, b)`` as ints (``b`` None: to the end), or None; SourceError if malformed."""
    if frames is None:
        return None
    try:
        a, b = frames
    except (TypeError, ValueError):
        raise SourceError(f"frames must be a pair [a, b] (half-open, 0-based), got {frames!r}") \
            from None
    for v in (a, b):
        if v is None and v is b:
            continue
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
            raise SourceError(f"frames must be two integers [a, b], got {frames!r}")
    if a < 0 or (b is not None and b <= a):
        raise SourceError(f"frames must be [a, b] with 0 <= a < b, got [{a}, {b}]")
    return int(a), (None if b is None else int(b))


class FrameSource:
    """A lazy sequence of grey frames with a time base (the interface of every source).

    Subclasses read a file format; users get one from :func:`open_source`.

    Attributes
    ----------
    path : pathlib.Path
        The file or folder read.
    shape : tuple of int
        ``(rows, cols)`` of every frame.
    dtype : numpy.dtype
        ``uint8`` or ``uint16``.
    bit_depth : int
        Significant bits per pixel (8 for videos; 8 or 16 for image files; a .cine's
        RealBPP, e.g. 10, 12 or 14 in 16-bit words).
    fps : float or None
        Capture rate in frames/s: the given ``fps``, else for a .cine with time stamps
        the rate they show, else the container's. When a .cine's time stamps are used,
        the times come from them, not from ``fps``.
    fps_container : float or None
        The rate the file claims (video container rate, .cine setup FrameRate); None
        for image folders.
    time_source : str
        ``"time stamps"``, ``"fps"`` (given) or ``"container"``; ``"none"`` when no rate
        is known.
    notes : tuple of str
        Things noticed while opening (e.g. unusable time stamps).

    Notes
    -----
    ``source[i]`` returns a new array the caller may modify; iteration streams one
    frame at a time, so memory does not grow with the length of the footage.
    """

    #: Short name of the format, used in messages and ``to_dict``.
    kind = "frames"

    def __init__(self, path, *, fps=None):
        self.path = Path(path)
        self._fps_given = _check_fps(fps)
        self._closed = False
        self._start = 0
        self._stop = 0
        self._times_cache = None
        self.notes = ()

    # -- hooks for subclasses -------------------------------------------------------
    def _read_file_frame(self, k):  # pragma: no cover - abstract
        raise TypeError(f"{type(self).__name__} does not read frames")

    def _iter_file(self, start, stop):
        for k in range(start, stop):
            yield self._read_file_frame(k)

    def _file_times_s(self, ks):
        """Times (s, relative to file frame 0) of file frames ``ks``; None if unknown."""
        fps = self.fps
        if fps is None:
            return None
        return np.asarray(ks, dtype=np.float64) / fps

    def _native_fps(self):
        return self.fps_container

    def _close(self):
        pass

    # -- set-up used by subclasses --------------------------------------------------
    def _set_range(self, n_file, frames):
        """Restrict the source to the half-open file range ``frames`` (slice semantics)."""
        if n_file <= 0:
            raise SourceError(f"{self.path}: no frames in this {self.kind}")
        rng = _check_range(frames)
        if rng is None:
            self._start, self._stop = 0, n_file
            return
        a, b = rng
        b = n_file if b is None else b
        if a >= n_file:
            raise SourceError(f"{self.path}: frames [{a}, {b}] selects nothing: the {self.kind} "
                              f"has {n_file} frames (0..{n_file - 1})")
        if b > n_file:
            self.notes += (f"frames [{a}, {b}] runs past the last frame; using [{a}, {n_file}]",)
        self._start, self._stop = a, min(b, n_file)

    # -- the interface --------------------------------------------------------------
    def __len__(self):
        return self._stop - self._start

    def len(self):
        """Number of frames (same as ``len(source)``)."""
        return len(self)

    @property
    def shape(self):
        return self._shape

    @property
    def dtype(self):
        return self._dtype

    @property
    def bit_depth(self):
        return self._bit_depth

    @property
    def fps_given(self):
        """The capture rate given when the source was opened (frames/s), or None."""
        return self._fps_given

    @property
    def fps_container(self):
        return getattr(self, "_fps_container", None)

    @property
    def fps(self):
        if self._fps_given is not None:
            return self._fps_given
        return self._native_fps()

    @property
    def time_source(self):
        if self._fps_given is not None:
            return "fps"
        return "container" if self._native_fps() is not None else "none"

    @property
    def frame_numbers(self):
        """0-based file index of every source frame (``a .. b - 1`` for a range)."""
        return np.arange(self._start, self._stop)

    @property
    def times_s(self):
        """Time (s) of every source frame, relative to the file's first frame."""
        if self._times_cache is None:
            times = self._file_times_s(self.frame_numbers)
            if times is None:
                raise SourceError(
                    f"{self.path}: no frame rate is known for this {self.kind}; give the capture "
                    "rate (scene.toml views.<view>.fps, or --fps)")
            times = np.asarray(times, dtype=np.float64)
            times.flags.writeable = False
            self._times_cache = times
        return self._times_cache

    def time_s(self, i):
        """Time (s) of source frame ``i``, relative to the file's first frame."""
        return float(self.times_s[self._index(i)])

    def _index(self, i):
        if isinstance(i, (bool, np.bool_)) or not isinstance(i, (int, np.integer)):
            raise TypeError(f"frame index must be an integer, got {type(i).__name__}")
        n = len(self)
        j = int(i) + n if i < 0 else int(i)
        if not 0 <= j < n:
            raise IndexError(f"frame index {i} out of range for {n} frames")
        return j

    def _check_open(self):
        if self._closed:
            raise SourceError(f"{self.path}: the source is closed")

    def __getitem__(self, i):
        j = self._index(i)
        self._check_open()
        return self._read_file_frame(self._start + j)

    def __iter__(self):
        self._check_open()
        yield from self._iter_file(self._start, self._stop)

    def close(self):
        """Release the file handles; further reads raise SourceError."""
        if not self._closed:
            self._closed = True
            self._close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def to_dict(self):
        """What the source is and its time base, as JSON-ready values."""
        return {
            "kind": self.kind,
            "path": str(self.path),
            "frames": len(self),
            "range": [self._start, self._stop],
            "shape": list(self.shape),
            "dtype": str(self.dtype),
            "bit_depth": self.bit_depth,
            "fps": self.fps,
            "fps_container": self.fps_container,
            "time_source": self.time_source,
            "notes": list(self.notes),
        }

    def __repr__(self):
        return (f"<{type(self).__name__} {str(self.path)!r}: {len(self)} frames "
                f"{self.shape[0]}x{self.shape[1]} {self.dtype} ({self.bit_depth} bit), "
                f"fps={self.fps} ({self.time_source})>")


# ---------------------------------------------------------------------------------------
# Videos through OpenCV
# ---------------------------------------------------------------------------------------
class VideoSource(FrameSource):
    """A video file any OpenCV/FFmpeg backend reads (AVI, MP4, MKV, MOV, ...).

    Parameters
    ----------
    path : str or os.PathLike
        The video file.
    fps : float, optional
        Capture rate in frames/s; wins over the container's rate.
    frames : (int, int), optional
        Half-open range of 0-based file frame indices.

    Raises
    ------
    SourceError
        The file cannot be opened as a video, or its first frame cannot be decoded.

    Notes
    -----
    Frames are 8-bit (OpenCV decodes to 8-bit BGR), converted to grey. Iteration reads
    sequentially with its own decoder. Random access decodes forward for short
    forward jumps and seeks otherwise; the first seek is checked against sequential
    decoding (a one-time cost proportional to the frame index) and, if the container
    seeks inexactly, every later access decodes sequentially from the start or the
    current position instead. The frame count is the container's; a frame inside it
    that cannot be decoded (a truncated file) raises SourceError naming its index.
    """

    kind = "video"

    def __init__(self, path, *, fps=None, frames=None):
        super().__init__(path, fps=fps)
        cv2 = _cv2()
        self._luma = False
        self._cap = self._open_capture()
        n = self._cap.get(cv2.CAP_PROP_FRAME_COUNT)
        n = int(round(n)) if np.isfinite(n) else 0
        cfps = self._cap.get(cv2.CAP_PROP_FPS)
        self._fps_container = float(cfps) if np.isfinite(cfps) and cfps > 0 else None
        ok, image = self._cap.read()
        if not ok or image is None:
            self._cap.release()
            raise SourceError(f"{self.path}: frame 0 could not be decoded (empty, truncated or "
                              "unsupported video)")
        self._cursor = 1
        grey = to_grey(image)
        raw = self._luma_capture(grey)
        if raw is not None:            # every capture from here on gives the plane
            self._cap.release()
            self._cap, self._luma = raw, True
        self._shape = tuple(grey.shape)
        self._dtype = grey.dtype
        self._bit_depth = 8 * grey.dtype.itemsize
        if n <= 0:
            n = self._count_frames()
            self.notes += ("the container does not state a frame count; frames were counted",)
        self._n_file = n
        self._seek_exact = None
        self._set_range(n, frames)

    def _open_capture(self):
        cv2 = _cv2()
        if not self.path.exists():
            raise SourceError(f"{self.path}: no such file")
        if not self.path.is_file():
            raise SourceError(f"{self.path}: not a file")
        cap = cv2.VideoCapture(str(self.path), cv2.CAP_FFMPEG)
        if not cap.isOpened():
            cap = cv2.VideoCapture(str(self.path))
        if not cap.isOpened():
            raise SourceError(f"{self.path}: cannot be opened as a video (not a video file, "
                              "or a container/codec this OpenCV cannot read)")
        if self._luma:
            cap.set(cv2.CAP_PROP_CONVERT_RGB, 0)
        return cap

    def _luma_capture(self, grey):
        """A capture giving raw frames, past frame 0, if the decoder's raw frame 0 is its
        luma plane, equal to ``grey`` (frame 0 decoded to BGR and converted) to +-1;
        else None."""
        cv2 = _cv2()
        if grey.dtype != np.uint8:
            return None
        cap = self._open_capture()
        ok, raw = cap.read() if cap.set(cv2.CAP_PROP_CONVERT_RGB, 0) else (False, None)
        rows, cols = grey.shape
        if (ok and raw is not None and raw.dtype == np.uint8 and raw.ndim == 2
                and raw.shape[1] == cols and raw.shape[0] >= rows
                and int(cv2.absdiff(raw[:rows], grey).max()) <= 1):
            return cap
        cap.release()
        return None

    def _count_frames(self):
        cap = self._open_capture()
        try:
            n = 0
            while cap.grab():
                n += 1
            return n
        finally:
            cap.release()

    def _decode(self, cap, k):
        ok, image = cap.read()
        if not ok or image is None:
            raise SourceError(
                f"{self.path}: frame {k} could not be decoded (the container says "
                f"{self._n_file} frames; the file is truncated or corrupt)")
        grey = image[:self._shape[0]] if self._luma else to_grey(image)
        if grey.shape != self._shape or grey.dtype != self._dtype:
            raise SourceError(f"{self.path}: frame {k} is {grey.shape} {grey.dtype}, frame 0 "
                              f"was {self._shape} {self._dtype}")
        return grey

    def _skip(self, cap, start, stop):
        """Decode past frames ``start .. stop - 1`` on the way to frame ``stop``."""
        for k in range(start, stop):
            if not cap.grab():
                raise SourceError(
                    f"{self.path}: frame {stop} could not be read: frame {k} could not be "
                    f"decoded (the container says {self._n_file} frames; the file is truncated "
                    "or corrupt)")

    def _read_sequential(self, k):
        """Frame ``k`` by decoding from the current position (or from the start)."""
        if k < self._cursor:
            self._cap.release()
            self._cap = self._open_capture()
            self._cursor = 0
        self._skip(self._cap, self._cursor, k)
        self._cursor = k
        frame = self._decode(self._cap, k)
        self._cursor = k + 1
        return frame

    def _read_seek(self, k):
        cv2 = _cv2()
        self._cap.set(cv2.CAP_PROP_POS_FRAMES, k)
        try:
            frame = self._decode(self._cap, k)
        except SourceError:
            self._cursor = 10 ** 12  # position unknown: reopen on the next access
            raise
        self._cursor = k + 1
        return frame

    def _read_file_frame(self, k):
        if self._cursor <= k <= self._cursor + _VIDEO_SKIP_MAX:
            return self._read_sequential(k)
        if self._seek_exact is None:
            return self._check_seek(k)
        if self._seek_exact:
            return self._read_seek(k)
        return self._read_sequential(k)

    def _check_seek(self, k):
        """Seek to ``k`` once and compare with sequential decoding; remember the verdict."""
        try:
            sought = self._read_seek(k)
        except SourceError:
            sought = None
        cap = self._open_capture()
        try:
            self._skip(cap, 0, k)
            truth = self._decode(cap, k)
        finally:
            cap.release()
        self._seek_exact = sought is not None and np.array_equal(sought, truth)
        if not self._seek_exact:
            self.notes += ("seeking in this video is not frame-exact; random access decodes "
                           "sequentially",)
        return truth

    def _iter_file(self, start, stop):
        cap = self._open_capture()
        try:
            if start > 0:
                if self._seek_exact is None and start > _VIDEO_SKIP_MAX:
                    self._read_file_frame(start)  # settles whether seeking is exact
                if self._seek_exact and start > _VIDEO_SKIP_MAX:
                    cv2 = _cv2()
                    cap.set(cv2.CAP_PROP_POS_FRAMES, start)
                else:
                    self._skip(cap, 0, start)
            for k in range(start, stop):
                if self._closed:
                    raise SourceError(f"{self.path}: the source was closed while iterating")
                yield self._decode(cap, k)
        finally:
            cap.release()

    def _close(self):
        self._cap.release()


# ---------------------------------------------------------------------------------------
# Image folders
# ---------------------------------------------------------------------------------------
def _sniff_png(head):
    if head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        return None
    cols, rows = struct.unpack(">II", head[16:24])
    return rows, cols, (16 if head[24] == 16 else 8)


def _sniff_bmp(head):
    if head[:2] != b"BM" or len(head) < 30:
        return None
    cols, rows = struct.unpack("<ii", head[18:26])
    return abs(rows), abs(cols), 8


def _sniff_jpeg(f):
    f.seek(0)
    if f.read(2) != b"\xff\xd8":
        return None
    while True:
        b = f.read(1)
        while b and b != b"\xff":
            b = f.read(1)
        while b == b"\xff":
            b = f.read(1)
        if not b:
            return None
        marker = b[0]
        if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:
            continue
        raw = f.read(2)
        if len(raw) < 2:
            return None
        (length,) = struct.unpack(">H", raw)
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            seg = f.read(5)
            if len(seg) < 5:
                return None
            precision, rows, cols = struct.unpack(">BHH", seg)
            return (rows, cols, 8) if precision == 8 else None
        f.seek(length - 2, 1)


def _sniff_tiff(f):
    f.seek(0)
    head = f.read(8)
    if head[:4] == b"II*\x00":
        e = "<"
    elif head[:4] == b"MM\x00*":
        e = ">"
    else:
        return None
    (ifd,) = struct.unpack(e + "I", head[4:8])
    f.seek(ifd)
    raw = f.read(2)
    if len(raw) < 2:
        return None
    (count,) = struct.unpack(e + "H", raw)
    tags = {}
    for _ in range(count):
        entry = f.read(12)
        if len(entry) < 12:
            return None
        tag, typ, n = struct.unpack(e + "HHI", entry[:8])
        if typ == 3:  # SHORT: the first of possibly several values
            tags[tag] = (struct.unpack(e + "H", entry[8:10])[0], n)
        elif typ == 4:  # LONG
            tags[tag] = (struct.unpack(e + "I", entry[8:12])[0], n)
    if 256 not in tags or 257 not in tags:
        return None
    bits, nbits = tags.get(258, (1, 1))
    if nbits > 2:  # several samples with a pointer to their sizes: let the decoder tell
        return None
    fmt = tags.get(339, (1, 1))[0]  # SampleFormat: 1 unsigned integer
    if fmt != 1 or bits not in (1, 2, 4, 8, 16):
        return None
    return tags[257][0], tags[256][0], (16 if bits == 16 else 8)


def _sniff_image(path):
    """``(rows, cols, bits)`` from an image file's header without decoding it, or None."""
    try:
        with open(path, "rb") as f:
            head = f.read(32)
            for sniff in (_sniff_png, _sniff_bmp):
                got = sniff(head)
                if got is not None:
                    return got
            if head[:2] == b"\xff\xd8":
                return _sniff_jpeg(f)
            if head[:4] in (b"II*\x00", b"MM\x00*"):
                return _sniff_tiff(f)
    except (OSError, struct.error):
        return None
    return None


class ImageFolderSource(FrameSource):
    """A folder of images (png, jpg, tif, bmp), one frame per file in natural order.

    Parameters
    ----------
    path : str or os.PathLike
        The folder. Files ending in :data:`IMAGE_SUFFIXES` are frames; other files,
        hidden files and subfolders are ignored. Names sort naturally (``2`` before
        ``10``).
    fps : float, optional
        Capture rate in frames/s (an image folder has no rate of its own).
    frames : (int, int), optional
        Half-open range of 0-based indices into the sorted file list.

    Raises
    ------
    SourceError
        The folder has no images, an image cannot be decoded, or the images differ in
        size or dtype (the message names the first offending file and the first file).

    Notes
    -----
    Files are read with ``IMREAD_UNCHANGED``: 16-bit png/tif stay ``uint16``
    (``bit_depth`` 16), 8-bit stay ``uint8``; colour is converted to grey. Sizes and
    bit depths are checked for every file when the folder is opened, from the file
    headers (png, bmp, jpeg, tiff; a file whose header says nothing clear is decoded).
    Only ``uint8`` and ``uint16`` images are accepted.
    """

    kind = "image folder"

    def __init__(self, path, *, fps=None, frames=None):
        super().__init__(path, fps=fps)
        if not self.path.is_dir():
            raise SourceError(f"{self.path}: no such folder")
        files = [p for p in self.path.iterdir()
                 if p.suffix.lower() in IMAGE_SUFFIXES and not p.name.startswith(".")
                 and p.is_file()]
        if not files:
            raise SourceError(f"{self.path}: no images ({', '.join(IMAGE_SUFFIXES)}) in the folder")
        self._files = sorted(files, key=natural_key)
        first = self._decode(self._files[0])
        self._shape, self._dtype = first.shape, first.dtype
        self._bit_depth = 8 * first.dtype.itemsize
        self._fps_container = None
        self._check_all()
        self._set_range(len(self._files), frames)

    @property
    def files(self):
        """The image files of the source frames, in order."""
        return self._files[self._start:self._stop]

    def _decode(self, path):
        cv2 = _cv2()
        try:
            data = np.fromfile(path, dtype=np.uint8)
        except OSError as exc:
            raise SourceError(f"{path}: cannot be read ({exc.strerror})") from None
        image = cv2.imdecode(data, cv2.IMREAD_UNCHANGED) if data.size else None
        if image is None:
            raise SourceError(f"{path}: cannot be decoded as an image (empty, truncated or "
                              "not an image)")
        if image.dtype not in (np.uint8, np.uint16):
            raise SourceError(f"{path}: {image.dtype} pixels are not supported; expected 8- or "
                              "16-bit unsigned integer images")
        return to_grey(image)

    def _mismatch(self, path, shape, dtype):
        first = self._files[0]
        return SourceError(
            f"{path}: image is {shape[1]}x{shape[0]} {np.dtype(dtype)}, but {first.name} "
            f"(the first image) is {self._shape[1]}x{self._shape[0]} {self._dtype}: an image "
            "folder needs one size and bit depth")

    def _check_all(self):
        bits0 = 8 * self._dtype.itemsize
        sniff0 = _sniff_image(self._files[0])
        trust = sniff0 == (self._shape[0], self._shape[1], bits0)
        for path in self._files[1:]:
            got = _sniff_image(path) if trust else None
            if got is None:
                image = self._decode(path)
                got = (image.shape[0], image.shape[1], 8 * image.dtype.itemsize)
            if got != (self._shape[0], self._shape[1], bits0):
                raise self._mismatch(path, got[:2], np.uint8 if got[2] == 8 else np.uint16)

    def _read_file_frame(self, k):
        path = self._files[k]
        image = self._decode(path)
        if image.shape != self._shape or image.dtype != self._dtype:
            raise self._mismatch(path, image.shape, image.dtype)
        return image

    def to_dict(self):
        out = super().to_dict()
        out["first_file"] = self.files[0].name
        return out


# ---------------------------------------------------------------------------------------
# The opener
# ---------------------------------------------------------------------------------------
def open_source(path, *, fps=None, frames=None, use_time_stamps=True):
    """Open footage as a :class:`FrameSource`, choosing the reader by what ``path`` is.

    Parameters
    ----------
    path : str or os.PathLike
        A folder (image folder), a ``.cine`` file (Phantom), or any other file (a video
        read through OpenCV).
    fps : float, optional
        The CAPTURE rate in frames/s (``scene.toml`` ``views.<view>.fps``). It wins over
        a container's rate (exported high-speed videos say 30 fps). For a .cine with
        per-image time stamps the stamps give the times; ``fps`` is then the nominal
        rate they are checked against (see :mod:`vidtrack.footage.timebase`).
    frames : (int, int), optional
        Half-open range ``[a, b)`` of 0-based file frame indices; ``b`` None means to the
        end, ``b`` past the end is clipped (noted in ``source.notes``).
    use_time_stamps : bool, optional
        False ignores a .cine's time stamps and times frames by ``fps`` (or the setup
        FrameRate).

    Returns
    -------
    FrameSource
        A :class:`VideoSource`, :class:`ImageFolderSource` or
        :class:`vidtrack.footage.cine.CineSource`; use it as a context manager.

    Raises
    ------
    SourceError
        Missing path, unreadable or truncated footage (the message names the frame),
        a bad ``fps`` or ``frames``, or nothing left after the range.
    """
    path = Path(path)
    _check_fps(fps)
    _check_range(frames)
    if not path.exists():
        raise SourceError(f"{path}: no such file or folder")
    if path.is_dir():
        return ImageFolderSource(path, fps=fps, frames=frames)
    if path.suffix.lower() == ".cine":
        from vidtrack.footage.cine import CineSource

        return CineSource(path, fps=fps, frames=frames, use_time_stamps=use_time_stamps)
    return VideoSource(path, fps=fps, frames=frames)


# ---------------------------------------------------------------------------------------
# Exporting frames to image files
# ---------------------------------------------------------------------------------------
#: Image formats :func:`export_frames` writes: name -> file ending.
EXPORT_FORMATS = {"png": ".png", "jpg": ".jpg", "tiff": ".tiff"}


@dataclass(frozen=True)
class FrameExport:
    """What :func:`export_frames` wrote.

    Attributes
    ----------
    out : pathlib.Path
        The output folder.
    files : tuple of str
        The image files, in order (names inside ``out``).
    frame_numbers : tuple of int
        0-based file frame index of every image.
    times_s : tuple of float
        Time of every image in s, relative to the source file's first frame.
    format : str
        ``png``, ``jpg`` or ``tiff``.
    dtype : str
        Pixel type written (``uint8`` or ``uint16``).
    bit_depth : int
        Significant bits of the source, kept in the files as stored values.
    time_source : str
        Where the times come from (see :attr:`FrameSource.time_source`).
    """

    out: Path
    files: tuple
    frame_numbers: tuple
    times_s: tuple
    format: str
    dtype: str
    bit_depth: int
    time_source: str

    def to_dict(self):
        return {"out": str(self.out), "frames": len(self.files), "format": self.format,
                "dtype": self.dtype, "bit_depth": self.bit_depth,
                "time_source": self.time_source, "files": list(self.files),
                "frame_numbers": list(self.frame_numbers), "times_s": list(self.times_s)}


def _inside(path, folder):
    path, folder = Path(path).resolve(), Path(folder).resolve()
    return path == folder or folder in path.parents


def export_frames(source, out, *, every=1, fmt="png", quiet=False):
    """Write the frames of a source as numbered image files plus ``frames.csv``.

    Parameters
    ----------
    source : FrameSource
        An open source (its range selects the frames).
    out : str or os.PathLike
        Output folder; created if missing. Files are ``frame_000123.png`` named by the
        0-based frame index in the source file, and ``frames.csv`` with columns
        ``frame`` (that index), ``t_s`` (time in s relative to the file's first frame)
        and ``file``.
    every : int, optional
        Keep every ``every``-th frame of the range (the first is kept).
    fmt : {"png", "jpg", "tiff"}, optional
        Image format. png and tiff keep 16-bit sources 16-bit (stored values
        unchanged: a 12-bit .cine gives values 0..4095 in 16-bit files).
    quiet : bool, optional
        No progress bar.

    Returns
    -------
    FrameExport

    Raises
    ------
    VidtrackError
        ``jpg`` for a 16-bit source (jpg holds 8 bits; nothing is scaled behind the
        user's back), a bad ``every`` or format, ``out`` inside an image-folder source,
        or ``out`` is a file.
    SourceError
        The source has no frame rate (an image folder without ``fps``), or a frame
        cannot be read (the message names it).

    Notes
    -----
    Nothing is written unless every frame could be read and encoded: the images go to
    a hidden staging folder beside ``out`` and are moved in at the end; ``frames.csv``
    is written (atomically) last, so its presence means the export is complete.
    Existing files in ``out`` with other names are left alone.
    """
    import csv
    import io
    import shutil
    import tempfile

    from vidtrack._atomic import write_text
    from vidtrack._progress import progress

    cv2 = _cv2()
    out = Path(out)
    if fmt not in EXPORT_FORMATS:
        raise VidtrackError(f"format must be one of {', '.join(EXPORT_FORMATS)}, got {fmt!r}")
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
        raise VidtrackError(f"every must be an integer >= 1, got {every!r}")
    if fmt == "jpg" and source.dtype != np.uint8:
        raise VidtrackError(
            f"{source.path}: jpg holds 8-bit pixels but this source has {source.dtype} pixels "
            f"({source.bit_depth} significant bits); use --format png or tiff to keep them")
    if out.exists() and not out.is_dir():
        raise VidtrackError(f"{out}: exists and is not a folder")
    if isinstance(source, ImageFolderSource) and _inside(out, source.path):
        raise VidtrackError(f"{out}: the output folder must not be inside the input image folder "
                            f"{source.path} (inputs are never modified)")
    picks = range(0, len(source), int(every))
    times = source.times_s  # raises SourceError now, before anything is written
    numbers = source.frame_numbers
    ending = EXPORT_FORMATS[fmt]
    width = max(6, len(str(int(numbers[-1]))))
    names = [f"frame_{int(numbers[i]):0{width}d}{ending}" for i in picks]

    out.parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".part", dir=out.parent))
    try:
        frames = iter(source) if every == 1 else (source[i] for i in picks)
        for name, frame in progress(zip(names, frames), total=len(names), desc="frames",
                                    quiet=quiet, unit="frame"):
            ok, data = cv2.imencode(ending, frame)
            if not ok:
                raise VidtrackError(f"{name}: OpenCV could not encode a {frame.dtype} frame as "
                                    f"{fmt}")
            data.tofile(stage / name)
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(["frame", "t_s", "file"])
        for i, name in zip(picks, names):
            writer.writerow([int(numbers[i]), repr(float(times[i])), name])
        out.mkdir(exist_ok=True)
        for name in names:
            os.replace(stage / name, out / name)
        write_text(out / "frames.csv", buf.getvalue())
        stage.rmdir()
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    return FrameExport(out=out, files=tuple(names),
                       frame_numbers=tuple(int(numbers[i]) for i in picks),
                       times_s=tuple(float(times[i]) for i in picks), format=fmt,
                       dtype=str(source.dtype), bit_depth=source.bit_depth,
                       time_source=source.time_source)
