"""The per-frame flags of a track: :class:`TrackFlag` and its bits as plain ints (the
table is in :mod:`vidtrack.track.tracker`, which exports them).

A track's ``flags`` column holds the bits as integers (int32 in tracks.h5 and a plain
number in tracks.csv); :class:`TrackFlag` reads such a value back as names:

>>> TrackFlag(12)
<TrackFlag.MERGED|LOST: 12>
>>> TrackFlag.LOST in TrackFlag(12)
True
>>> flag_names([0, 12, 36])
['', 'MERGED|LOST', 'MERGED|PRE_RELEASE']

The tracker's own code uses the module's int constants (``BORDER``, ...): numpy keeps an
int32 array int32 under ``|`` with a plain int, not with an int subclass.

Internal to :mod:`vidtrack.track`; users reach :class:`TrackFlag` and :func:`flag_names`
as ``vidtrack.TrackFlag`` and ``vidtrack.flag_names``.
"""

import enum

__all__ = ["TrackFlag", "flag_names", "FLAGS", "BORDER", "BLADE", "MERGED", "LOST", "PREDICTED",
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


def flag_names(values):
    """The names of the bits set in each value of a flags column, as tracks.csv spells them.

    Parameters
    ----------
    values : iterable of int
        Flags values: a track's ``flags`` column, an array or a list (whole-number floats,
        as pandas reads a column with gaps, are taken as their integer).

    Returns
    -------
    list of str
        One string per value: the names of its bits in bit order, ``|``-joined
        (``"MERGED|PRE_RELEASE"`` for 36), ``""`` for 0; a bit no flag has is written as
        its value (``"LOST|512"``).

    Raises
    ------
    ValueError
        A negative value, or one that is not a whole number.

    Examples
    --------
    >>> flag_names([0, 12, 36])
    ['', 'MERGED|LOST', 'MERGED|PRE_RELEASE']
    """
    cache = {}
    out = []
    for value in values:
        try:
            text = cache.get(value)
        except TypeError:                   # unhashable: not a number
            text = _names_of(value)
        if text is None:
            text = cache[value] = _names_of(value)
        out.append(text)
    return out


def _names_of(value):
    try:
        bits = int(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"a flags value must be a whole number >= 0, got {value!r}") from None
    if bits != value or bits < 0:
        raise ValueError(f"a flags value must be a whole number >= 0, got {value!r}")
    names = [flag.name for flag in TrackFlag if bits & flag.value]
    rest = bits & ~sum(FLAGS)
    if rest:
        names.append(str(rest))
    return "|".join(names)
