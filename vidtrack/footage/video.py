"""Videos through OpenCV: :class:`VideoSource` reads any file an OpenCV/FFmpeg backend
decodes (AVI, MP4, MKV, MOV, ...) as a :class:`~vidtrack.footage.base.FrameSource`.

A video whose decoder gives its luma plane directly (full-range YUV, as MJPEG's) is
read as that plane, without the conversion to BGR and back: about 30 % less decoding
time. That path is taken only when, on frame 0, the luma plane equals the grey of the
decoded BGR frame to within one grey level (the two differ only by rounding, and by
clipping in strongly saturated colours); otherwise (limited-range YUV as MPEG-4's,
packed RGB, any decoder that does not give the plane) the BGR frame is converted.
The luma plane is read only when the frames are luma: with a colour ``channel`` the
BGR frame is decoded (and ``"auto"`` decodes BGR to choose; when it chooses luma the
plane is then used as for ``"luma"``).
"""

import numpy as np

from vidtrack.errors import SourceError
from vidtrack.footage.base import FrameSource, _cv2, to_grey

__all__ = ["VideoSource"]

#: Largest forward gap that random access in a video bridges by decoding on rather
#: than seeking.
_VIDEO_SKIP_MAX = 48


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
    channel : str, optional
        ``"luma"`` (default), ``"red"``, ``"green"``, ``"blue"`` or ``"auto"``
        (:mod:`vidtrack.footage.channel`).

    Raises
    ------
    SourceError
        The file cannot be opened as a video, or its first frame cannot be decoded; a
        colour channel of a grey video.

    Notes
    -----
    Frames are 8-bit (OpenCV decodes to 8-bit BGR), converted to grey (or to the
    ``channel`` given). Iteration reads
    sequentially with its own decoder. Random access decodes forward for short
    forward jumps and seeks otherwise; the first seek is checked against sequential
    decoding (a one-time cost proportional to the frame index) and, if the container
    seeks inexactly, every later access decodes sequentially from the start or the
    current position instead. The frame count is the container's; a frame inside it
    that cannot be decoded (a truncated file) raises SourceError naming its index.
    """

    kind = "video"

    def __init__(self, path, *, fps=None, frames=None, channel="luma"):
        super().__init__(path, fps=fps, channel=channel)
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
        if channel == "luma":
            self._use_luma_plane(grey)
        self._shape = tuple(grey.shape)
        self._dtype = grey.dtype
        self._bit_depth = 8 * grey.dtype.itemsize
        if n <= 0:
            n = self._count_frames()
            self.notes += ("the container does not state a frame count; frames were counted",)
        self._n_file = n
        self._seek_exact = None
        self._set_range(n, frames)
        try:
            self._settle_channel()
        except BaseException:
            self._cap.release()
            raise
        if channel == "auto" and self.channel == "luma":
            self._use_luma_plane(grey)

    def _use_luma_plane(self, grey):
        """Read the decoder's luma plane from here on if it gives one equal to ``grey``
        (frame 0 decoded to BGR and converted); the capture is then past frame 0."""
        raw = self._luma_capture(grey)
        if raw is not None:            # every capture from here on gives the plane
            self._cap.release()
            self._cap, self._luma, self._cursor = raw, True, 1

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
        grey = image[:self._shape[0]] if self._luma else self._grey(image)
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
        """Frame ``k`` decoded on from where the capture stands (from the start when ``k``
        lies behind it), then sought to on the same capture and compared; the verdict on
        seeking is remembered. Decoding on costs the frames since the capture's position,
        not every frame from the start."""
        truth = self._read_sequential(k)
        try:
            sought = self._read_seek(k)
        except SourceError:
            sought = None
        self._seek_exact = sought is not None and np.array_equal(sought, truth)
        if not self._seek_exact:
            self._cursor = 10 ** 12      # where the seek left the capture is not known
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
