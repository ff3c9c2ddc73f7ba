"""The opener: :func:`open_source` opens footage as a frame source, choosing the reader
by what the path is (a folder: images; ``.cine``: Phantom; any other file: a video).

The .cine reader is imported only when a .cine file is opened.
"""

from pathlib import Path

from vidtrack.errors import SourceError
from vidtrack.footage.base import _check_channel, _check_fps, _check_range
from vidtrack.footage.images import ImageFolderSource
from vidtrack.footage.video import VideoSource

__all__ = ["open_source"]


def open_source(path, *, fps=None, frames=None, use_time_stamps=True, channel="luma"):
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
    channel : str, optional
        The grey image the frames are (``scene.toml`` ``views.<view>.channel``):
        ``"luma"`` (default, BT.601 luma of colour footage), ``"red"``, ``"green"``,
        ``"blue"`` (that channel of colour footage), or ``"auto"``: the one in which
        moving things stand out most, chosen on opening from frames spread over the
        range and named in ``source.notes`` (:mod:`vidtrack.footage.channel`).

    Returns
    -------
    FrameSource
        A :class:`~vidtrack.footage.video.VideoSource`,
        :class:`~vidtrack.footage.images.ImageFolderSource` or
        :class:`vidtrack.footage.cine.CineSource`; use it as a context manager.

    Raises
    ------
    SourceError
        Missing path, unreadable or truncated footage (the message names the frame),
        a bad ``fps``, ``frames`` or ``channel``, nothing left after the range, or a
        colour channel of grey footage.
    """
    path = Path(path)
    _check_fps(fps)
    _check_range(frames)
    _check_channel(channel)
    if not path.exists():
        raise SourceError(f"{path}: no such file or folder")
    if path.is_dir():
        return ImageFolderSource(path, fps=fps, frames=frames, channel=channel)
    if path.suffix.lower() == ".cine":
        from vidtrack.footage.cine import CineSource

        return CineSource(path, fps=fps, frames=frames, use_time_stamps=use_time_stamps,
                          channel=channel)
    return VideoSource(path, fps=fps, frames=frames, channel=channel)
