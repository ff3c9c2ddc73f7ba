"""The per-frame flags of a track: :class:`TrackFlag` and its bits as plain ints (the
table is in :mod:`vidtrack.track.tracker`, which exports them).

A track's ``flags`` column holds the bits as integers (int32 in tracks.h5 and a plain
number in tracks.csv); :class:`TrackFlag` reads such a value back as names:

>>> TrackFlag(12)
<TrackFlag.MERGED|LOST: 12>
>>> TrackFlag.LOST in TrackFlag(12)
True

The tracker's own code uses the module's int constants (``BORDER``, ...): numpy keeps an
int32 array int32 under ``|`` with a plain int, not with an int subclass.

Internal to :mod:`vidtrack.track`; users reach :class:`TrackFlag` as
``vidtrack.TrackFlag``.
"""

import enum

__all__ = ["TrackFlag", "FLAGS", "BORDER", "BLADE", "MERGED", "LOST", "PREDICTED",
           "PRE_RELEASE", "OUTLIER", "APPEARANCE", "EXCLUDED"]


class TrackFlag(enum.IntFlag):
    """Why a frame of a track is not used for the fit (bits of the ``flags`` column).

    An :class:`enum.IntFlag`: a member is an int, combines with ``|``, tests with
    ``in``, and masks a numpy array or a pandas column as the int it is
    (``track.data["flags"] & TrackFlag.LOST``). A frame is usable when its flags are 0.
    """

    #: The straw touches the image border (partly out of view).
    BORDER = 1
    #: The straw overlaps the blade region.
    BLADE = 2
    #: The straw's blob merged with or touches another moving blob.
    MERGED = 4
    #: Not found in this frame (u, v are NaN).
    LOST = 8
    #: Gap bridged: u, v interpolated from the clean neighbours.
    PREDICTED = 16
    #: Before the detected release (still on the blade).
    PRE_RELEASE = 32
    #: Off the smooth path of its clean neighbours.
    OUTLIER = 64
    #: Unlike the object's clean frames (part of it hidden, or possibly unseen).
    APPEARANCE = 128
    #: In a range of the scene's ``exclude_frames``: never fitted.
    EXCLUDED = 256

    # A flag value is not iterable (the class is: ``list(TrackFlag)``): pandas takes an
    # iterable operand for a sequence and refuses ``column & TrackFlag.LOST``.
    __iter__ = None


BORDER = TrackFlag.BORDER.value
BLADE = TrackFlag.BLADE.value
MERGED = TrackFlag.MERGED.value
LOST = TrackFlag.LOST.value
PREDICTED = TrackFlag.PREDICTED.value
PRE_RELEASE = TrackFlag.PRE_RELEASE.value
OUTLIER = TrackFlag.OUTLIER.value
APPEARANCE = TrackFlag.APPEARANCE.value
EXCLUDED = TrackFlag.EXCLUDED.value

#: Flag names by bit value (plain ints, lower case).
FLAGS = {flag.value: flag.name.lower() for flag in TrackFlag}
