"""H.264 MP4 that browsers play inline, through the ffmpeg inside the imageio-ffmpeg wheel.

One small writer: BGR frames in (streamed down a pipe, memory flat in the video's
length), an MP4 out with H.264 (libx264), 4:2:0 chroma (``yuv420p``, which browsers and
slide software need), its index at the front (``-movflags +faststart``: it plays while
it loads). 4:2:0 needs even sizes: an odd width or height gets one more column or row,
black, on the right or at the bottom.

The binary is imageio-ffmpeg's (:func:`imageio_ffmpeg.get_ffmpeg_exe`), never a system
ffmpeg. The pipe is driven here rather than through :func:`imageio_ffmpeg.write_frames`
(same binary, same arguments) because that generator neither reports ffmpeg's exit
status nor keeps its messages: a disk that fills while the index is moved to the front
would otherwise leave a broken file unnoticed, and ffmpeg's own lines would reach the
user's terminal.
"""

import contextlib
import errno
import os
import subprocess
import tempfile
from fractions import Fraction

import numpy as np

__all__ = ["H264Writer", "ffmpeg_exe", "even_size", "CRF", "PRESET"]

#: x264's constant rate factor (0 lossless .. 51 worst; 18 is visually lossless): thin
#: coloured marks keep their colour through 4:2:0.
CRF = 18
#: x264's speed/size trade-off.
PRESET = "veryfast"
_DISK_FULL_TEXTS = ("no space left on device", "disk quota exceeded")


def ffmpeg_exe():
    """The ffmpeg binary of the imageio-ffmpeg wheel, or None when it has none here."""
    try:
        import imageio_ffmpeg

        return imageio_ffmpeg.get_ffmpeg_exe()
    except (ImportError, RuntimeError):
        return None


def even_size(size):
    """``(width, height)`` rounded up to even numbers (4:2:0 chroma needs them)."""
    return (int(size[0]) + int(size[0]) % 2, int(size[1]) + int(size[1]) % 2)


class H264Writer:
    """Write BGR frames of one size to an H.264 MP4 (``path``, any name: ``-f mp4``).

    Parameters
    ----------
    path : pathlib.Path
        The file to write (a temporary name; the caller renames it).
    size : (int, int)
        Width and height of the frames given to :meth:`write` (px).
    fps : float
        Playback rate of the file (frames/s, > 0).
    exe : str, optional
        The ffmpeg binary (default :func:`ffmpeg_exe`).

    Raises
    ------
    OSError
        From :meth:`write` or :meth:`close` when ffmpeg failed; ``errno.ENOSPC`` when
        it says the device or the quota is full (``vidtrack._atomic.atomic_path`` turns
        that into a one-line DiskFullError).
    """

    def __init__(self, path, size, fps, *, exe=None):
        self.path = path
        self.size = (int(size[0]), int(size[1]))
        self.out_size = even_size(self.size)
        exe = exe or ffmpeg_exe()
        if exe is None:
            raise OSError("the imageio-ffmpeg wheel has no ffmpeg binary for this platform")
        rate = Fraction(float(fps)).limit_denominator(100_000)
        cmd = [exe, "-hide_banner", "-loglevel", "error", "-y",
               "-f", "rawvideo", "-pix_fmt", "bgr24", "-s", f"{self.size[0]}x{self.size[1]}",
               "-r", str(rate), "-i", "pipe:0", "-an"]
        if self.out_size != self.size:
            cmd += ["-vf", f"pad={self.out_size[0]}:{self.out_size[1]}"]
        cmd += ["-c:v", "libx264", "-preset", PRESET, "-crf", str(CRF),
                "-pix_fmt", "yuv420p", "-movflags", "+faststart", "-f", "mp4", str(path)]
        self._err = tempfile.TemporaryFile()
        self._proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                                      stderr=self._err)
        self.frames = 0

    def write(self, img):
        """Append one BGR frame (``(height, width, 3)`` uint8)."""
        img = np.ascontiguousarray(img, dtype=np.uint8)
        if img.shape != (self.size[1], self.size[0], 3):
            raise ValueError(f"frame of shape {img.shape}; expected "
                             f"{(self.size[1], self.size[0], 3)}")
        try:
            self._proc.stdin.write(memoryview(img).cast("B"))
        except OSError:          # ffmpeg stopped (a full disk, a bad file): say why
            self._finish()
            raise self._failure() from None
        self.frames += 1

    def _finish(self):
        with contextlib.suppress(OSError):
            self._proc.stdin.close()
        return self._proc.wait()

    def _failure(self):
        self._err.seek(0)
        text = self._err.read().decode("utf-8", "replace").strip()
        last = text.splitlines()[-1] if text else f"exit status {self._proc.returncode}"
        if any(t in text.lower() for t in _DISK_FULL_TEXTS):
            return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self.path))
        return OSError(f"ffmpeg could not write {self.path}: {last}")

    def close(self):
        """Finish the file (ffmpeg writes the index and moves it to the front)."""
        try:
            if self._finish() != 0:
                raise self._failure()
        finally:
            self._err.close()

    def abort(self):
        """Stop ffmpeg without finishing the file (after an error or an interrupt)."""
        if self._proc.poll() is None:
            self._proc.kill()
        with contextlib.suppress(OSError):
            self._proc.stdin.close()
        self._proc.wait()
        with contextlib.suppress(OSError):
            self._err.close()
