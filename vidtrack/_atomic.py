"""Outputs appear whole or not at all: write to a temporary name, then rename."""

import contextlib
import errno
import os
import tempfile
from pathlib import Path

#: errno values that mean the device (or the user's quota) is full.
DISK_FULL_ERRNOS = (errno.ENOSPC, errno.EDQUOT)
#: How libraries that do not set errno (HDF5 through h5py) say it.
_DISK_FULL_TEXTS = ("no space left on device", "disk quota exceeded", "errno = 28")


def is_disk_full(exc):
    """True when ``exc`` (any exception) says the device or the quota is full."""
    if not isinstance(exc, OSError):
        return False
    if exc.errno in DISK_FULL_ERRNOS:
        return True
    return any(t in str(exc).lower() for t in _DISK_FULL_TEXTS)


def disk_full(exc, path=None):
    """The :class:`~vidtrack.errors.DiskFullError` for ``exc``, or None when ``exc`` is
    not a full disk.

    Parameters
    ----------
    exc : BaseException
        What writing raised (``OSError`` with ``errno.ENOSPC`` or ``EDQUOT``, or
        h5py's ``OSError`` whose text says so).
    path : str or os.PathLike, optional
        The output being written (default: the file the error names, if any).

    Returns
    -------
    DiskFullError or None
        One line: ``no space left on device writing out/tracks.h5; expected room for
        the outputs (free some space there or choose another output folder)``.

    Example
    -------
    >>> import errno
    >>> str(disk_full(OSError(errno.ENOSPC, "No space left on device"), "a.csv"))[:50]
    'no space left on device writing a.csv; expected ro'
    """
    from vidtrack.errors import DiskFullError

    if not is_disk_full(exc):
        return None
    where = path if path is not None else (getattr(exc, "filename", None) or "the outputs")
    what = ("disk quota exceeded" if getattr(exc, "errno", None) == errno.EDQUOT
            else "no space left on device")
    return DiskFullError(f"{what} writing {where}; expected room for the outputs (free "
                         "some space there or choose another output folder)")


def _umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    On any exception (including KeyboardInterrupt) the temporary file is removed and
    ``path`` is left as it was; a full disk is raised as a
    :class:`~vidtrack.errors.DiskFullError` naming ``path`` (:func:`disk_full`).

    Example
    -------
    >>> with atomic_path("out/tracks.h5") as tmp:      # doctest: +SKIP
    ...     write_hdf5(tmp)
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent)
    os.close(fd)
    tmp = Path(tmp)
    os.chmod(tmp, 0o666 & ~_umask())        # mkstemp makes 0600; outputs are ordinary files
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException as exc:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        full = disk_full(exc, path)
        if full is not None:
            raise full from exc
        raise


#: Free space (bytes) under which a device is taken as full after a write that cannot
#: report its errors (OpenCV's VideoWriter drops them): the file is then checked.
NEARLY_FULL_BYTES = 1 << 20


@contextlib.contextmanager
def _quiet_stderr():
    """File descriptor 2 sent to /dev/null for a while (C libraries' own prints)."""
    import sys

    with contextlib.suppress(OSError, ValueError):
        sys.stderr.flush()
    saved = os.dup(2)
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(null)


def check_video_written(path, frames, final):
    """Raise if OpenCV's VideoWriter silently lost frames of ``path`` to a full disk.

    OpenCV's ``VideoWriter`` reports no write errors: on a full device it leaves a
    truncated file. When the device holding ``path`` has less than
    :data:`NEARLY_FULL_BYTES` free after the writer was released, the file is opened
    again and must hold ``frames`` frames.

    Parameters
    ----------
    path : pathlib.Path
        The video just written (a temporary name).
    frames : int
        The frames written to it.
    final : str or os.PathLike
        The output's name, for the message.

    Raises
    ------
    DiskFullError
        The device is full and the file does not hold every frame.
    """
    st = os.statvfs(Path(path).parent)
    if st.f_bavail * st.f_frsize >= NEARLY_FULL_BYTES:
        return
    import cv2

    with _quiet_stderr():       # OpenCV's parsers print about a truncated file
        cap = cv2.VideoCapture(str(path))
        try:
            got = int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) if cap.isOpened() else 0
        finally:
            cap.release()
    if got != frames:
        raise disk_full(OSError(errno.ENOSPC, os.strerror(errno.ENOSPC)), final)


def write_text(path, text):
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def write_bytes(path, data):
    """Write ``data`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def _same_file(a, b):
    """True when ``a`` and ``b`` name the same file (through links, ``..``, case)."""
    try:
        if a.exists() and b.exists():
            return os.path.samefile(a, b)
        return a.resolve() == b.resolve()
    except OSError:
        return False


def _nearest_existing(path):
    """``path`` or its nearest ancestor that exists."""
    path = Path(os.path.abspath(path))
    while not path.exists() and not path.is_symlink() and path != path.parent:
        path = path.parent
    return path


def _probe_writable(folder, label):
    """Create and remove a temporary file in ``folder``; a VidtrackError if that fails."""
    from vidtrack.errors import VidtrackError

    try:
        fd, tmp = tempfile.mkstemp(prefix=".vidtrack-probe-", dir=folder)
    except OSError as exc:
        raise VidtrackError(f"{label}: cannot write in {folder} "
                            f"({exc.strerror or exc}); expected a folder you can write "
                            "to") from None
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(tmp)


def check_output(path, *, inputs=(), label=None, folder=False):
    """Refuse an output path before any work: it must not be an input, nor unwritable.

    Call it before reading or computing anything, so that a bad output path costs
    nothing and leaves nothing behind. Nothing is created (a probe file is made and
    removed again in the folder that would receive the output).

    Parameters
    ----------
    path : str or os.PathLike
        The output file (or, with ``folder``, the output folder).
    inputs : iterable of path or None
        The command's input files and folders; ``path`` must not be one of them.
    label : str, optional
        How the output is named in messages (``"--report out.html"``; default the
        path itself).
    folder : bool
        ``path`` is a folder to create or write into (else a file to create or replace).

    Raises
    ------
    VidtrackError
        ``path`` is one of ``inputs``; a file output that is a folder or a folder output
        that is a file or a link that leads nowhere; a file where a parent folder should
        be; a folder that cannot be written to. One line: the output, what is wrong,
        what was expected.
    """
    from vidtrack.errors import VidtrackError

    path = Path(path)
    label = label or str(path)
    for given in inputs:
        if given is not None and _same_file(path, Path(given)):
            raise VidtrackError(f"{label}: is the input {given}; inputs are never "
                                "overwritten, expected a different output path")
    if folder and path.is_symlink() and not path.exists():
        raise VidtrackError(f"{label}: is a link to {os.readlink(path)}, which does not "
                            "exist; expected a folder (new or existing) to write into")
    if folder and path.exists() and not path.is_dir():
        raise VidtrackError(f"{label}: exists and is not a folder; expected a folder "
                            "(new or existing) to write into")
    if not folder and path.is_dir():
        raise VidtrackError(f"{label}: is a folder; expected a file name")
    parent = _nearest_existing(path.parent)
    if not parent.is_dir():
        raise VidtrackError(f"{label}: {parent} is a file, not a folder; expected a path "
                            "whose parent folders are folders")
    _probe_writable(parent, label)
    if folder and path.is_dir():
        _probe_writable(path, label)
