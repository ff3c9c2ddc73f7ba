"""Footage: frame sources (videos, image folders, Phantom .cine), the time base, frame export.

- ``base``: :class:`FrameSource` (the interface of every source), :func:`to_grey`,
  :func:`natural_key`;
- ``video``: :class:`VideoSource` (any file OpenCV/FFmpeg decodes);
- ``images``: :class:`ImageFolderSource` (a folder of png/jpg/tif/bmp files);
- ``cine``: :class:`CineSource` and :func:`write_cine` (Phantom .cine files);
- ``sources``: :func:`open_source`, which picks the reader by what the path is;
- ``timebase``: checks of a source's time base (time stamps, rates, duplicated frames);
- ``export``: :func:`export_frames` (frames to numbered image files plus ``frames.csv``).

The names below are loaded from their modules on first use (PEP 562), so importing one
module of the package (``vidtrack.footage.timebase``, say) does not load the others.
None of them loads OpenCV before it reads or writes a frame.
"""

_EXPORTS = {
    "vidtrack.footage.base": ("FrameSource", "natural_key", "to_grey"),
    "vidtrack.footage.video": ("VideoSource",),
    "vidtrack.footage.images": ("ImageFolderSource", "IMAGE_SUFFIXES"),
    "vidtrack.footage.cine": ("CineSource", "write_cine"),
    "vidtrack.footage.sources": ("open_source",),
    "vidtrack.footage.export": ("export_frames", "FrameExport", "EXPORT_FORMATS"),
}
_MODULE_OF = {name: module for module, names in _EXPORTS.items() for name in names}

__all__ = list(_MODULE_OF)


def __getattr__(name):
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module 'vidtrack.footage' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_MODULE_OF))
