"""Tracking one view: background, detection, linking, the flight's choice, measurement
and flags -> a per-frame ``Track``.

``from vidtrack.track import track, Track, TrackFlag, flag_names`` (each loaded on first
use: the package stays light, as ``import vidtrack`` imports it).
"""

from vidtrack import _lazy

_EXPORTS = {
    "vidtrack.track.tracker": ("track", "Track"),
    "vidtrack.track._flags": ("TrackFlag", "flag_names"),
}
__getattr__, __dir__, __all__ = _lazy.lazy_exports(__name__, _EXPORTS)
