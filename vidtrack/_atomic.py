"""Outputs appear whole or not at all: write to a temporary name, then rename."""

import contextlib
import os
import tempfile
from pathlib import Path


def _umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    On any exception (including KeyboardInterrupt) the temporary file is removed and
    ``path`` is left as it was.

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
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise


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
        that is a file; a file where a parent folder should be; a folder that cannot be
        written to. One line: the output, what is wrong, what was expected.
    """
    from vidtrack.errors import VidtrackError

    path = Path(path)
    label = label or str(path)
    for given in inputs:
        if given is not None and _same_file(path, Path(given)):
            raise VidtrackError(f"{label}: is the input {given}; inputs are never "
                                "overwritten, expected a different output path")
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
