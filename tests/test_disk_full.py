"""A full disk said as one line naming the output (vidtrack._atomic.disk_full).

The command line's handling of a real full disk (a small tmpfs) is in the rows
``*-full-disk`` of tests/test_hostile_inputs.py; here the translation itself.
"""

import errno

import pytest

from vidtrack._atomic import atomic_path, disk_full, is_disk_full
from vidtrack.errors import DiskFullError, VidtrackError


def test_enospc_names_the_output():
    exc = disk_full(OSError(errno.ENOSPC, "No space left on device"), "out/tracks.h5")
    assert isinstance(exc, DiskFullError) and isinstance(exc, VidtrackError)
    assert str(exc).startswith("no space left on device writing out/tracks.h5; expected")
    assert "\n" not in str(exc)


def test_quota_is_said_as_a_quota():
    exc = disk_full(OSError(errno.EDQUOT, "Disk quota exceeded"), "a.csv")
    assert str(exc).startswith("disk quota exceeded writing a.csv")


def test_the_errors_own_file_name_when_no_path_is_given():
    exc = disk_full(OSError(errno.ENOSPC, "No space left on device", "x/y.png"))
    assert "writing x/y.png;" in str(exc)


def test_hdf5_text_without_errno_is_a_full_disk():
    text = ("Can't write data (file write failed: ..., errno = 28, error message = "
            "'No space left on device', ...)")
    assert is_disk_full(OSError(text))


@pytest.mark.parametrize("exc", [OSError(errno.EACCES, "Permission denied"),
                                 OSError(errno.EIO, "I/O error"), ValueError("28"),
                                 KeyboardInterrupt()])
def test_other_errors_are_not_a_full_disk(exc):
    assert disk_full(exc, "a") is None


def test_atomic_path_raises_disk_full_and_leaves_nothing(tmp_path):
    target = tmp_path / "out.csv"
    with pytest.raises(DiskFullError, match=r"writing .*out\.csv"):
        with atomic_path(target) as tmp:
            tmp.write_text("partial")
            raise OSError(errno.ENOSPC, "No space left on device")
    assert list(tmp_path.iterdir()) == []
