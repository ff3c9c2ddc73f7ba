"""Exporting frames to image files: :func:`export_frames` writes a source's frames as
numbered png, jpg or tiff files plus ``frames.csv`` (frame index, time, file).
"""

import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vidtrack.errors import VidtrackError
from vidtrack.footage.base import _cv2
from vidtrack.footage.images import ImageFolderSource

__all__ = ["EXPORT_FORMATS", "FrameExport", "export_frames"]

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
        Where the times come from (see :attr:`~vidtrack.footage.base.FrameSource.time_source`).
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


def _earlier_files(out):
    """The image files an earlier export's ``frames.csv`` in ``out`` lists (names only).

    Only plain names an export writes (``frame_000123.png``, ``.jpg``, ``.tiff``) count;
    a missing or unreadable ``frames.csv`` lists nothing.
    """
    import csv
    import re

    path = Path(out) / "frames.csv"
    if not path.is_file():
        return []
    pattern = re.compile(r"frame_\d+(" + "|".join(re.escape(e) for e in
                                                 EXPORT_FORMATS.values()) + r")")
    try:
        with open(path, encoding="utf-8", newline="") as f:
            rows = list(csv.DictReader(f))
    except (OSError, UnicodeDecodeError, csv.Error):
        return []
    return [r["file"] for r in rows
            if isinstance(r.get("file"), str) and pattern.fullmatch(r["file"])]


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
    Nothing is written unless every frame could be read, encoded and written: the
    images go to a hidden staging folder inside ``out`` and are moved in at the end; ``frames.csv``
    is written (atomically) last, so its presence means the export is complete.
    When ``out`` holds an earlier export, the images its ``frames.csv`` listed that the
    new one does not are removed after the new ones are in place (so no stale frame
    sits beside the new ``frames.csv``); other files in ``out`` are left alone.
    """
    import contextlib
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
    from vidtrack._atomic import check_output

    check_output(out, inputs=[source.path], folder=True)
    if isinstance(source, ImageFolderSource) and _inside(out, source.path):
        raise VidtrackError(f"{out}: the output folder must not be inside the input image folder "
                            f"{source.path} (inputs are never modified)")
    picks = range(0, len(source), int(every))
    times = source.times_s  # raises SourceError now, before anything is written
    numbers = source.frame_numbers
    ending = EXPORT_FORMATS[fmt]
    width = max(6, len(str(int(numbers[-1]))))
    names = [f"frame_{int(numbers[i]):0{width}d}{ending}" for i in picks]

    created = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    # staged inside out (the same device even when out is a mount point); the staging
    # folder of an export that was killed (its process gone) is removed first
    for leftover in _leftovers(out):
        shutil.rmtree(leftover, ignore_errors=True)
    stage = Path(tempfile.mkdtemp(prefix=f".frames-{os.getpid()}-", suffix=".part", dir=out))
    moved = []
    try:
        frames = iter(source) if every == 1 else (source[i] for i in picks)
        for name, frame in progress(zip(names, frames), total=len(names), desc="frames",
                                    quiet=quiet, unit="frame"):
            ok, data = cv2.imencode(ending, frame)
            if not ok:
                raise VidtrackError(f"{name}: OpenCV could not encode a {frame.dtype} frame as "
                                    f"{fmt}")
            _write_image(data, stage / name, out / name)
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(["frame", "t_s", "file"])
        for i, name in zip(picks, names):
            writer.writerow([int(numbers[i]), repr(float(times[i])), name])
        earlier = _earlier_files(out)
        for name in names:
            os.replace(stage / name, out / name)
            moved.append(name)
        write_text(out / "frames.csv", buf.getvalue())
        stage.rmdir()
        kept = set(names)
        for name in earlier:
            if name not in kept and (out / name).is_file():
                (out / name).unlink()
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        if moved:       # an export half in place is no export: its frames.csv goes too
            for name in moved + ["frames.csv"]:
                with contextlib.suppress(OSError):
                    (out / name).unlink()
        if created:
            shutil.rmtree(out, ignore_errors=True)
        raise
    return FrameExport(out=out, files=tuple(names),
                       frame_numbers=tuple(int(numbers[i]) for i in picks),
                       times_s=tuple(float(times[i]) for i in picks), format=fmt,
                       dtype=str(source.dtype), bit_depth=source.bit_depth,
                       time_source=source.time_source)


def _write_image(data, path, final):
    """Write encoded image bytes; a full disk as DiskFullError naming ``final``."""
    from vidtrack._atomic import disk_full

    try:
        with open(path, "wb") as f:
            f.write(data.tobytes())
    except OSError as exc:
        full = disk_full(exc, final)
        if full is not None:
            raise full from exc
        raise


_STAGE_NAME = re.compile(r"\.frames-(\d+)-[a-z0-9_]{8}\.part")


def _leftovers(out):
    """Staging folders in ``out`` of exports whose process is gone (killed)."""
    found = []
    for p in out.iterdir():
        m = _STAGE_NAME.fullmatch(p.name)
        if m and p.is_dir() and not p.is_symlink():
            try:
                os.kill(int(m.group(1)), 0)
            except ProcessLookupError:
                found.append(p)
            except OSError:
                pass
    return found
