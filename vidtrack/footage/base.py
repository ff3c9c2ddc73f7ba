"""Frame sources: the interface every reader implements, and the helpers they share.

Every source is a lazy sequence of grey 2-D numpy frames with a time base:

>>> from vidtrack.footage import open_source                     # doctest: +SKIP
>>> with open_source("run42/front.avi", fps=1200) as src:        # doctest: +SKIP
...     print(len(src), src.shape, src.dtype, src.bit_depth, src.fps)
...     for i, frame in enumerate(src):                           # streams, one frame at a time
...         t = src.time_s(i)

The readers are :class:`~vidtrack.footage.video.VideoSource`,
:class:`~vidtrack.footage.images.ImageFolderSource` and
:class:`~vidtrack.footage.cine.CineSource`; :func:`~vidtrack.footage.sources.open_source`
chooses one by what the path is.

Indices and times
-----------------
``source[i]`` and ``source.time_s(i)`` use *source indices* ``0 .. len(source) - 1``.
With ``frames=(a, b)`` the source covers the file's frames ``a .. b - 1``;
``source.frame_numbers[i]`` is the 0-based index of source frame ``i`` in the file
(``a + i``). Times are in seconds relative to the file's first frame (file frame 0),
so a range does not shift the clock.

Slices
------
A slice, a sequence of indices or a boolean mask gives a :class:`SourceView`, as PIMS
does: ``source[10:20]``, ``source[::2]``, ``source[-50:]``, ``source[[3, 7]]``. Nothing is
decoded until a frame is read; the view keeps the file's numbering and clock
(``view.frame_numbers``, ``view.times_s``), slices again, and goes wherever a source
goes (``track(source[100:400])``). It reads through its source, so it is usable while
the source is open. A slice selects as a list's slice does (bounds past either end
clipped); a slice's view holds its start, stop and step, not a number per frame.

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
unchanged. A video may instead be read as its decoder's luma plane (see
:mod:`vidtrack.footage.video`). With ``channel`` (``scene.toml`` ``views.<v>.channel``)
a source gives one colour channel instead, or its chroma (``max(R, G, B) - min(R, G, B)``,
how far a pixel is from grey, whatever its hue), or the channel chosen by ``"auto"``
(:mod:`vidtrack.footage.channel`).
"""

import os
import re
from pathlib import Path

import numpy as np

from vidtrack.errors import SourceError

__all__ = ["CHANNEL_INDEX", "COLOUR_ONLY", "FrameSource", "SourceView", "natural_key",
           "to_grey"]


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


#: Index of each colour channel in OpenCV's BGR (and BGRA) order.
CHANNEL_INDEX = {"blue": 0, "green": 1, "red": 2}
#: The grey images of a colour frame other than its luma.
COLOUR_ONLY = ("red", "green", "blue", "chroma")


def to_grey(image, channel="luma"):
    """Return ``image`` as a 2-D grey array of the same dtype (BT.601 luma for colour).

    Parameters
    ----------
    image : numpy.ndarray
        ``(rows, cols)``, ``(rows, cols, 1)``, BGR ``(rows, cols, 3)`` or BGRA
        ``(rows, cols, 4)`` as OpenCV returns them.
    channel : str, optional
        ``"luma"`` (default: BT.601 luma of colour, grey returned as it is), or
        ``"red"``, ``"green"``, ``"blue"``: that channel of a colour image;
        ``"chroma"``: ``max(R, G, B) - min(R, G, B)`` of a colour image (0 for grey, the
        most for a saturated colour of any hue).

    Returns
    -------
    numpy.ndarray
        ``(rows, cols)``.

    Raises
    ------
    SourceError
        A colour channel of a grey image, an unknown ``channel``, or a shape that is not
        an image.
    """
    if channel != "luma":
        if channel not in COLOUR_ONLY:
            raise SourceError(f"channel must be luma, {', '.join(COLOUR_ONLY)}, got {channel!r}")
        if image.ndim == 3 and image.shape[2] in (3, 4):
            if channel == "chroma":
                bgr = image[:, :, :3]
                return bgr.max(axis=2) - bgr.min(axis=2)
            return image[:, :, CHANNEL_INDEX[channel]].copy()
        what = "chroma" if channel == "chroma" else f"{channel} channel"
        raise SourceError(f"cannot take the {what} of an image of shape "
                          f"{image.shape}: it is not colour")
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
    from vidtrack.scene.model import FPS_RANGE

    if not FPS_RANGE[0] <= value <= FPS_RANGE[1]:
        raise SourceError(f"{what} must be between {FPS_RANGE[0]:g} and {FPS_RANGE[1]:g} "
                          f"frames/s (a capture rate), got {fps!r}")
    return value


def _check_channel(channel):
    from vidtrack.scene.model import CHANNELS

    if not (isinstance(channel, str) and channel in CHANNELS):
        raise SourceError(f"channel must be one of {', '.join(CHANNELS)}, got {channel!r}")
    return channel


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

    Subclasses read a file format; users get one from :func:`~vidtrack.footage.sources.open_source`.

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
        Things noticed while opening (e.g. unusable time stamps, the channel
        ``"auto"`` chose and why).
    channel : str
        The grey image the frames are: ``"luma"``, ``"red"``, ``"green"``, ``"blue"``
        or ``"chroma"`` (what ``"auto"`` chose, when it was given).
    channel_scores : dict or None
        With ``"auto"`` on colour footage: each candidate's score (how strongly moving
        things stand out, :func:`vidtrack.footage.channel.settle_channel`).

    Notes
    -----
    ``source[i]`` returns a new array the caller may modify; iteration streams one
    frame at a time, so memory does not grow with the length of the footage.
    """

    #: Short name of the format, used in messages and ``to_dict``.
    kind = "frames"

    def __init__(self, path, *, fps=None, channel="luma"):
        self.path = Path(path)
        self._fps_given = _check_fps(fps)
        self._channel_given = _check_channel(channel)
        self._channel = "luma"        # while opening; settled by _settle_channel
        self._raw = None
        self.channel_scores = None
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

    # -- the channel ------------------------------------------------------------------
    def _grey(self, image):
        """A decoded frame as the source gives it: the grey image of its channel (the
        readers pass every decoded frame through here)."""
        if self._raw is not None:
            self._raw.append(image)
        return to_grey(image, self._channel)

    def _raw_frame(self, k):
        """File frame ``k`` as decoded, before it is made grey (for the channel checks)."""
        self._raw = []
        try:
            self._read_file_frame(k)
            return self._raw[-1]
        finally:
            self._raw = None

    def _settle_channel(self):
        """Settle the channel given, once the source is set up (readers call it last):
        a colour channel of grey footage is refused, ``"auto"`` chooses one."""
        if self._channel_given == "luma":
            return
        from vidtrack.footage.channel import settle_channel

        self._channel, self.channel_scores, notes = settle_channel(self, self._channel_given,
                                                                   to_grey)
        self.notes += notes

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
    def channel(self):
        return self._channel

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
            self._times_cache = self._times_of(self.frame_numbers)
        return self._times_cache

    def _times_of(self, ks):
        """Times (s) of file frames ``ks`` as a read-only array; SourceError if unknown."""
        times = self._file_times_s(ks)
        if times is None:
            raise SourceError(
                f"{self.path}: no frame rate is known for this {self.kind}; give the capture "
                "rate (scene.toml views.<view>.fps, or --fps)")
        times = np.asarray(times, dtype=np.float64)
        times.flags.writeable = False
        return times

    def time_s(self, i):
        """Time (s) of source frame ``i``, relative to the file's first frame."""
        return float(self.times_s[self._index(i)])

    def _index(self, i):
        return _index(i, len(self))

    def _check_open(self):
        if self._closed:
            raise SourceError(f"{self.path}: the source is closed")

    def __getitem__(self, key):
        """Frame ``key`` (an int, negative from the end), or with a slice or a sequence of
        ints (or a boolean mask) a :class:`SourceView` of those frames, decoded only when
        read."""
        if isinstance(key, (int, np.integer)) and not isinstance(key, (bool, np.bool_)):
            j = self._index(key)
            self._check_open()
            return self._read_file_frame(self._start + j)
        return SourceView(self, _select(range(self._start, self._stop), key))

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
            "channel": self.channel,
            "notes": list(self.notes),
        }

    def __repr__(self):
        return (f"<{type(self).__name__} {str(self.path)!r}: {len(self)} frames "
                f"{self.shape[0]}x{self.shape[1]} {self.dtype} ({self.bit_depth} bit), "
                f"fps={self.fps} ({self.time_source})>")


def _index(i, n):
    """Source index ``i`` (negative: from the end) of ``n`` frames as 0 .. n - 1."""
    if isinstance(i, (bool, np.bool_)) or not isinstance(i, (int, np.integer)):
        raise TypeError(f"frame index must be an integer, got {type(i).__name__}")
    j = int(i) + n if i < 0 else int(i)
    if not 0 <= j < n:
        raise IndexError(f"frame index {i} out of range for {n} frames")
    return j


def _positions(key, n):
    """The source indices (an int array) that a slice, a sequence of ints or a boolean
    mask of length ``n`` selects; IndexError or TypeError as a sequence gives them."""
    if isinstance(key, slice):
        return np.arange(n)[key]
    if isinstance(key, (str, bytes)) or not hasattr(key, "__len__"):
        raise TypeError("frame index must be an integer, a slice, a sequence of integers or "
                        f"a boolean mask, got {type(key).__name__}")
    idx = np.asarray(key)
    if idx.ndim != 1:
        raise IndexError(f"frame indices must be one-dimensional, got shape {idx.shape}")
    if idx.dtype == bool:
        if idx.size != n:
            raise IndexError(f"a boolean mask of {idx.size} values for {n} frames")
        return np.flatnonzero(idx)
    if idx.size == 0:
        return idx.astype(np.int64)
    if not np.issubdtype(idx.dtype, np.integer):
        raise TypeError(f"frame indices must be integers, got {idx.dtype}")
    bad = (idx < -n) | (idx >= n)
    if bad.any():
        raise IndexError(f"frame index {int(idx[bad][0])} out of range for {n} frames")
    return np.where(idx < 0, idx + n, idx).astype(np.int64)


def _select(frames, key):
    """The file frames of ``frames`` (a range or an int array) that ``key`` selects: a
    slice of a range is a range (its size does not grow with its length), anything else
    an int array."""
    if not isinstance(frames, range):
        return frames[_positions(key, len(frames))]
    if isinstance(key, slice):
        return frames[key]
    return frames.start + frames.step * _positions(key, len(frames))


class SourceView:
    """Some frames of a :class:`FrameSource`, chosen by a slice or indices, read lazily.

    What ``source[10:20]`` (or ``source[::2]``, ``source[[3, 7]]``, a boolean mask)
    returns: a sequence of grey frames like its source, decoding a frame only when it is
    read, in the file's numbering and on the file's clock. Slicing a view gives a view
    of the same source.

    Attributes
    ----------
    source : FrameSource
        The source read (it must stay open while the view is read).
    frame_numbers : numpy.ndarray
        0-based file index of each frame of the view, in the view's order.
    path, shape, dtype, bit_depth, fps, fps_given, fps_container, time_source, channel, kind
        As the source's.

    Examples
    --------
    >>> with open_source("run42/front.avi", fps=1200) as src:     # doctest: +SKIP
    ...     clip = src[100:400:2]       # nothing decoded yet
    ...     first = clip[0]             # file frame 100
    ...     clip.frame_numbers[:3], clip.times_s[:3]
    (array([100, 102, 104]), array([0.0833, 0.085 , 0.0867]))
    """

    def __init__(self, source, frame_numbers):
        self.source = source
        if isinstance(frame_numbers, range):
            # a slice's frames as a range: a view's size does not grow with its length
            frames = frame_numbers
        else:
            frames = np.array(frame_numbers, dtype=np.int64)
            frames.flags.writeable = False
        self._frames = frames
        self._times_cache = None

    # -- as the source ------------------------------------------------------------------
    path = property(lambda self: self.source.path)
    kind = property(lambda self: self.source.kind)
    shape = property(lambda self: self.source.shape)
    dtype = property(lambda self: self.source.dtype)
    bit_depth = property(lambda self: self.source.bit_depth)
    channel = property(lambda self: self.source.channel)
    fps = property(lambda self: self.source.fps)
    fps_given = property(lambda self: self.source.fps_given)
    fps_container = property(lambda self: self.source.fps_container)
    time_source = property(lambda self: self.source.time_source)
    notes = property(lambda self: self.source.notes)

    # -- the frames ----------------------------------------------------------------------
    def __len__(self):
        return len(self._frames)

    def len(self):
        """Number of frames (same as ``len(view)``)."""
        return len(self)

    @property
    def frame_numbers(self):
        """0-based file index of every frame of the view (a read-only int64 array)."""
        frames = self._frames
        if isinstance(frames, range):
            frames = np.arange(frames.start, frames.stop, frames.step, dtype=np.int64)
            frames.flags.writeable = False
        return frames

    @property
    def times_s(self):
        """Time (s) of every frame of the view, relative to the file's first frame."""
        if self._times_cache is None:
            self._times_cache = self.source._times_of(self.frame_numbers)
        return self._times_cache

    def time_s(self, i):
        """Time (s) of frame ``i`` of the view, relative to the file's first frame."""
        return float(self.times_s[_index(i, len(self))])

    def __getitem__(self, key):
        if isinstance(key, (int, np.integer)) and not isinstance(key, (bool, np.bool_)):
            k = self._frames[_index(key, len(self))]
            self.source._check_open()
            return self.source._read_file_frame(int(k))
        return SourceView(self.source, _select(self._frames, key))

    def __iter__(self):
        self.source._check_open()
        frames = self._frames
        if isinstance(frames, range):
            consecutive = frames.step == 1
        else:
            consecutive = bool(np.all(np.diff(frames) == 1))
        if len(frames) > 1 and consecutive:
            # a run of consecutive frames: decoded as the source streams its own
            yield from self.source._iter_file(int(frames[0]), int(frames[-1]) + 1)
            return
        for k in frames:
            self.source._check_open()
            yield self.source._read_file_frame(int(k))

    def to_dict(self):
        """The source's :meth:`FrameSource.to_dict`, with the view's frame count and its
        ``frame_numbers``."""
        return {**self.source.to_dict(), "frames": len(self),
                "frame_numbers": [int(k) for k in self._frames]}

    def __repr__(self):
        frames = self._frames
        if len(frames) > 6:
            shown = [int(k) for k in frames[:3]] + ["..."] + [int(k) for k in frames[-2:]]
        else:
            shown = [int(k) for k in frames]
        return (f"<SourceView of {type(self.source).__name__} {str(self.path)!r}: "
                f"{len(self)} frames, file frames [{', '.join(map(str, shown))}]>")
