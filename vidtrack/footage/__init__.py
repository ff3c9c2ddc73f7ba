"""Footage: frame sources (videos, image folders, Phantom .cine), the time base, frame export.

- ``base``: :class:`FrameSource` (the interface of every source), :class:`SourceView`
  (frames of a source chosen by a slice, read lazily), :func:`to_grey`,
  :func:`natural_key`;
- ``video``: :class:`VideoSource` (any file OpenCV/FFmpeg decodes);
- ``images``: :class:`ImageFolderSource` (a folder of png/jpg/tif/bmp files);
- ``cine``: :class:`CineSource` and :func:`write_cine` (Phantom .cine files);
- ``channel``: which grey image a source gives of colour footage (a colour channel,
  or the one ``"auto"`` chooses);
- ``sources``: :func:`open_source`, which picks the reader by what the path is;
- ``timebase``: checks of a source's time base (time stamps, rates, duplicated frames);
- ``export``: :func:`export_frames` (frames to numbered image files plus ``frames.csv``).

The names below are loaded from their modules on first use (PEP 562), so importing one
module of the package (``vidtrack.footage.timebase``, say) does not load the others.
None of them loads OpenCV before it reads or writes a frame.
"""

from vidtrack._lazy import lazy_exports

_EXPORTS = {
    "vidtrack.footage.base": ("FrameSource", "SourceView", "natural_key", "to_grey"),
    "vidtrack.footage.video": ("VideoSource",),
    "vidtrack.footage.images": ("ImageFolderSource", "IMAGE_SUFFIXES"),
    "vidtrack.footage.cine": ("CineSource", "write_cine"),
    "vidtrack.footage.sources": ("open_source",),
    "vidtrack.footage.export": ("export_frames", "FrameExport", "EXPORT_FORMATS"),
}
__getattr__, __dir__, _NAMES = lazy_exports(__name__, _EXPORTS)

__all__ = _NAMES
