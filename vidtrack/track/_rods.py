"""Rules for a rod (a straw) followed by the tracker: its shape (how much of the
rectangle its moments describe it fills, its coverage beyond its band), the rod measured
alone on its own band when something is attached across it, and whether a blob, or a run
of them, is a rod at all (long or thin) rather than an object of any shape.

Internal to the tracker (:mod:`vidtrack.track._pass`, :mod:`vidtrack.track._step`,
:mod:`vidtrack.track._search`) and :mod:`vidtrack.track._select`.
"""

import copy

import cv2
import numpy as np

from vidtrack.track._coverage import measure, trim_to_rod
from vidtrack.track._mixed import measure_mixed
from vidtrack.track._segment import work_margin
from vidtrack.track._touch import other_touching
from vidtrack.track._thin import THIN_PX, is_thin_line

#: A rod's coverage share beyond its band (``Blob.off_axis``) above which something is
#: attached across it (0 for one rod, blurred or not; 0.1-0.17 for a thin rod crossing a
#: straw at 40 degrees).
OFF_AXIS_MAX = 0.04
#: A rod more than this many times as wide as its clean frames (``Blob.width``; they at
#: least :data:`FILL_WIDTH_MIN` wide) holds something beside it: a rod is as wide however
#: it turns (its length is what foreshortens). Measured on ``vidtrack synth``'s straws
#: 3.3 to 3.7 px wide, dark, with a highlight, a rider: clean frames at most 1.14 times;
#: seen end on in the top view with a rider across it that no band leaves out, 1.34 to
#: 2.3 times (the clean frames' width creeping up as the rider came nearer), at 2 to
#: 2.8 px from the straw. (A flat straw spinning about its length would be flagged in its
#: wide frames: this tracker's rods are round.)
WIDTH_GROWN = 1.3
#: A rod whose coverage fills less than this fraction of what its clean frames filled
#: (``area / (length x width)``) has something attached.
FILL_MIN = 0.8
#: ... and, within :data:`SEPARATE_FRAMES` frames of one with detections beyond its band
#: (something attached: a tenth of its pixels or more), below this fraction: two rods
#: drifting apart leave the shape half broken for a while.
FILL_SEPARATE = 0.9
SEPARATE_FRAMES = 10
#: Narrower than this (px, from the coverage's moments) a rod's width is set by where it
#: falls on the pixel grid: a straw 1.1 px wide lying along a row measures 0.4 to 2.0 px
#: as it moves across it, so its fill says nothing (``vidtrack synth`` at its default
#: 5.3 mm/px: 0.59 to 1.9). Its shape is then judged by its coverage beyond its band.
FILL_WIDTH_MIN = THIN_PX
#: A rod shorter than its clean frames by at least this (px; and 5 % of their length, and
#: 3 times the median change of length between them, which a rod measured on its body
#: with a highlight along it changes by 1 to 2 px from frame to frame) ...
SHORT_PX = 1.0
#: ... whose centre lies off where they put it, along its axis, by about half what it
#: lost (between this share of it and one minus this share; give or take 3 times their
#: scatter) has one end hidden: behind something in front of it, its centre moves by
#: half what it lost; turning, it shortens about its centre.
END_SHIFT = 0.25
#: An object of any shape that lost at least this share of its area is looked at for a
#: part hidden at one side (:func:`hidden_side`).
SHORT_SHARE = 0.05
#: A rod's coverage per unit length (its width times its contrast) is kept as it turns
#: and moves; a frame with less than this share of its clean frames' has part of it
#: hidden at a side, or is pieces of it either side of something before it.
NARROW = 0.7
#: A rod measured on its own band (something attached cut away) is kept when its length
#: and width are within these fractions of its clean frames'.
ALONE_LENGTH_TOL = 0.10
ALONE_WIDTH_TOL = 0.20


def is_rod(width, length):
    """Long or thin (a straw: measured by its coverage), from the coverage's second
    moments; an unmeasured size counts as a rod."""
    if not (np.isfinite(width) and np.isfinite(length)):
        return True
    return width < 4.0 or length >= 3.0 * width


def rodlike(blob):
    """:func:`is_rod` of one blob."""
    return is_rod(blob.width, blob.length)


def rodlike_run(blobs):
    """:func:`is_rod` of the median width and length of ``blobs`` (a tracklet): a rod,
    measured by its coverage; else an object of any shape, measured by its silhouette."""
    w = [b.width for b in blobs if np.isfinite(b.width)]
    ln = [b.length for b in blobs if np.isfinite(b.length)]
    if not w or not ln:
        return True
    return is_rod(float(np.median(w)), float(np.median(ln)))


def thin_line_run(blobs):
    """The strongest pixels of ``blobs`` (a tracklet) are a thin line (their median width
    and length: :func:`~vidtrack.track._thin.is_thin_line`): a thin straw, whatever
    fainter thing (a rider, a shadow) its detections also hold."""
    w = [b.strong_shape[0] for b in blobs if np.isfinite(b.strong_shape[0])]
    ln = [b.strong_shape[1] for b in blobs if np.isfinite(b.strong_shape[1])]
    if len(w) < max(3, len(blobs) // 2):
        return False
    w, ln = float(np.median(w)), float(np.median(ln))
    return is_thin_line(w, ln)


def rod_fill(blob):
    """Coverage area over ``length x width`` of the coverage's moments (1 for a
    rectangle, less for a blurred thin rod, much less for two rods across each other);
    None when not measured, or for a rod narrower than :data:`FILL_WIDTH_MIN` (whose
    width is the pixel grid's: it has no rectangle to fill)."""
    if not (np.isfinite(blob.area) and np.isfinite(blob.length) and np.isfinite(blob.width)):
        return None
    if blob.width < FILL_WIDTH_MIN:
        return None
    box = blob.length * blob.width
    return float(blob.area / box) if box > 0 else None


def attached_across(b, f):
    """The rod's shape is broken by something attached (its fill below :data:`FILL_MIN`
    of its clean frames', or coverage beyond its band)."""
    fill = rod_fill(b)
    return (fill is not None and fill < FILL_MIN * f.ref(f.fills, fill)) or \
        b.off_axis > OFF_AXIS_MAX


def rod_alone(reg, group, lv, b, f, ref_w, ref_len, min_area):
    """(the straw measured on its own band (:func:`trim_to_rod`), or None when nothing
    lies beyond the band or what is left is not the straw's clean shape (fill, nothing
    across, length and width as in its clean frames); the detections cut away)."""
    work = reg.work(group, lv, margin=work_margin(ref_w, ref_len, b.bbox))
    before = work.others.copy()
    dropped = trim_to_rod(work, width=ref_w, length=ref_len)
    if not dropped:
        return None, 0
    b2 = copy.copy(b)
    measure(work, b2, lv, width=ref_w, length=ref_len)
    if b2.banded:
        # a rod of both polarities (a highlight along it): its core's band leaves out
        # what rides beside it, without the cut across its ends at its clean length (a
        # straw turning is longer than in its clean frames)
        b2 = copy.copy(b)
        measure_mixed(reg.work(group, lv, margin=work_margin(ref_w, ref_len, b.bbox)), b2,
                      rod=True)
    fill = rod_fill(b2)
    if not (b2.area > 0 and (fill is None or fill >= FILL_MIN * f.ref(f.fills, fill))
            and b2.off_axis <= OFF_AXIS_MAX
            and abs(b2.length - ref_len) <= ALONE_LENGTH_TOL * ref_len
            and abs(b2.width - ref_w) <= ALONE_WIDTH_TOL * ref_w):
        return None, dropped
    b2.mask_area = int(np.count_nonzero(work.sel))
    # something of the other polarity still touching the band (a blade) is behind it;
    # not the ringing of compression between the straw and the rider cut away
    cut = cv2.dilate((work.others & ~before).view(np.uint8), np.ones((5, 5), np.uint8))
    d = work.d
    work.d = np.where(cut.view(bool), np.float32(0.0), d)
    b2.merged = other_touching(work, width=ref_w, min_area=min_area)
    work.d = d
    return b2, dropped


def rod_shortened(short, jitter):
    """A rod ``short`` (px) shorter than its clean frames' length, whose length changes
    by ``jitter`` (px, median) from one to the next, is short enough to be looked at for
    an end hidden (:data:`SHORT_PX`). Arrays or scalars."""
    with np.errstate(invalid="ignore"):
        return np.asarray(short, float) >= np.maximum(SHORT_PX, 3.0 * np.asarray(jitter, float))


def area_shrunk(lost, jitter):
    """An object of any shape that lost a share ``lost`` of its area, which changes by
    ``jitter`` (relative, median) from one clean frame to the next, shrank enough to be
    looked at for a part hidden (:data:`SHORT_SHARE`). Arrays or scalars."""
    with np.errstate(invalid="ignore"):
        return np.asarray(lost, float) >= np.maximum(SHORT_SHARE,
                                                     3.0 * np.asarray(jitter, float))


def end_hidden(along, short, err, jitter):
    """A rod ``short`` (px) shorter than its clean frames' length, its centre
    ``along`` (px) off where they put it along its axis, their scatter ``err`` (px) and
    the median change of their length from one to the next ``jitter`` (px): one end
    hidden (:data:`SHORT_PX`, :data:`END_SHIFT`). Arrays or scalars."""
    short = np.asarray(short, float)
    err = 3.0 * np.asarray(err, float)
    off = np.abs(along)
    with np.errstate(invalid="ignore"):
        return (rod_shortened(short, jitter)
                & (off >= np.maximum(END_SHIFT * short, err))
                & (off <= (1.0 - END_SHIFT) * short + err))


def hidden_side(off, lost, area, err, jitter, reach=None):
    """An object of any shape of area ``area`` (px^2) that lost a share ``lost`` of it,
    its centroid ``off`` (px) from where its clean frames put it, their scatter ``err``
    (px) and the relative change of their area from one to the next ``jitter``: part of
    it hidden at one side. Hidden behind a straight edge, a disc of radius R that lost a
    share s has its centroid moved by s / (1 - s) times the hidden part's distance from
    its centre, 0.42 R (half of it) to R (a sliver); shrinking as it turns, about its
    centre. ``reach`` (px) is the farthest its part can lie from its centre (a disc's
    radius unless given: half a rod's length, whose corner or side may be hidden with
    its length kept). Lost at least :data:`SHORT_SHARE` (and 3 times ``jitter``), moved
    at least a tenth of the least and at most the most (give or take 3 times ``err``)."""
    lost = np.asarray(lost, float)
    r = np.sqrt(np.asarray(area, float) / np.pi) if reach is None else \
        np.asarray(reach, float)
    err = 3.0 * np.asarray(err, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        most = r * lost / np.maximum(1.0 - lost, 1e-6)
        return (area_shrunk(lost, jitter)
                & (lost < 1.0)
                & (np.abs(off) >= np.maximum(0.1 * 0.42 * most, err))
                & (np.abs(off) <= most + err))
