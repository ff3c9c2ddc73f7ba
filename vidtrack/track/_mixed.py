"""An object of both polarities (a dark ball with its highlight, a dark straw with a
bright stripe along it) measured by its body; a rod of both polarities on its core's
band, without what a fainter rod beside it or across it adds.

Internal to the tracker (:mod:`vidtrack.track._coverage`, :mod:`vidtrack.track._step`,
:mod:`vidtrack.track._search`).
"""

import copy

import cv2
import numpy as np

from vidtrack.track._moments import axis, detections_off_axis, from_moments, top_third_median
from vidtrack.track._segment import K3, K5, convex_hull, fill_holes
from vidtrack.track._silhouette import measure_silhouette

#: A rod of both polarities: its core is where its main polarity shows at least this
#: share of its level (a rider of half the contrast never does), and its band reaches
#: :data:`CORE_EDGE_PX` beyond the core's farthest pixel.
CORE = 0.75
CORE_EDGE_PX = 1.5


def measure_mixed(work, blob, *, rod=None, separate=True, shadow=None):
    """Centroid etc. of an object of both polarities (in place): a rod (a dark straw
    with a highlight along it) by its body, anything else by :func:`measure_silhouette`.
    ``rod``: whether it is one (as its clean frames were: a straw seen end on still is);
    None: when this frame's body is 3 times as long as wide. A rod's body is taken
    within its core's band (:func:`_core_band`): a fainter rod riding along it or
    across it, closed into its body, is left out. ``separate`` False: the rod is
    measured whole, its band's measurement kept in ``blob.separated`` (the blobs a
    straw is chosen among are measured whole: cutting what its blade holds in some
    frames and not in others would break its path; any other object's shadow is then
    measured aside, :func:`measure_silhouette`).

    The body is what differs from the background by at least 0.15 of the object's
    contrast (the 90th percentile of ``|f - b|``; what the closing adds and
    compression's ringing round a sharp edge stay below), closed, holes filled, and its
    convex hull taken (a highlight reaching the edge leaves a notch). The body's
    interior covers fully. An edge pixel (the body's outer pixel and the one beyond)
    that shows at least a quarter of the contrast is read against the level of its own
    polarity within 2 px (a shaded rod is not of one level end to end); a fainter one
    is read signed against the polarity round it, so that noise and ringing average
    out instead of adding up. Where the highlight's blur
    cancels part of the edge the coverage reads low: the centre along the axis is then
    taken halfway between the ends (:func:`_rod_ends_centre`). A rod's ``off_axis`` is
    that of its detections about the body's axis (:func:`detections_off_axis`).
    """
    sel = work.sel.view(bool)
    if not sel.any():
        blob.area = 0.0
        return blob
    d = work.d
    ad = np.abs(d)
    top = np.float32(np.percentile(ad[sel], 90))
    strong = sel & (ad >= 0.25 * top)
    faint = (sel & (ad > 0.3 * top)).view(np.uint8)
    body = fill_holes(cv2.morphologyEx(faint, cv2.MORPH_CLOSE, K3))
    body &= ~work.others
    if shadow is None:
        shadow = "cut" if separate else "aside"
    if not body.any():
        return measure_silhouette(work, blob, shadow=shadow)
    band = _core_band(d, sel, strong) if rod is not False else None
    if rod is None:
        # (a rod with a fainter rod across it, closed into its body, is a rod: its body
        # within its core's band is judged)
        probe = from_moments(copy.copy(blob), (body if band is None else body & band)
                              .astype(np.float32), (0, 0))
        rod = probe.area > 0 and probe.length >= 3.0 * max(probe.width, 1.0)
    if not rod:
        return measure_silhouette(work, blob, shadow=shadow)
    if band is not None and not separate:
        sep = _rod_body(work, copy.copy(blob), d, ad, top, sel, strong, body, band)
        if sep.area > 0:
            blob.separated = (sep.u, sep.v, sep.area, sep.angle, sep.length, sep.width,
                              sep.off_axis)
        band = None
    return _rod_body(work, blob, d, ad, top, sel, strong, body, band)


def _rod_body(work, blob, d, ad, top, sel, strong, body, band):
    """:func:`measure_mixed` of a rod (in place), from its detections ``sel``, their
    changes ``d`` and ``ad = |d|`` (``top``: its 90th percentile), the strong ones and
    the closed body; within ``band`` when given (:func:`_core_band`)."""
    zero = np.float32(0.0)
    blob.banded = band is not None
    if band is not None:
        # a fainter rod riding along it or across it, closed into its body: the rod is
        # its core's band
        body = body & band
        sel = sel & band
        strong = strong & band
    # (its largest piece: a speck of compression's ringing beside it would stretch the
    # hull over the background)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(body.view(np.uint8), connectivity=8)
    if n > 2:
        body = labels == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    body = convex_hull(body) & ~work.others
    bu8 = body.view(np.uint8)
    inner = cv2.erode(bu8, K3).view(bool)
    edge = cv2.dilate(bu8, K3).view(bool) & ~inner & ~work.others
    if work.trimmed is not None:
        edge &= ~work.trimmed
    if band is not None:
        edge &= band
    # the polarity round each pixel (of the body's strong pixels within 2 px)
    sgn = np.where(strong & body, np.sign(d), zero).astype(np.float32)
    near = cv2.blur(sgn, (5, 5), borderType=cv2.BORDER_CONSTANT)
    side = np.where(strong, np.sign(d), np.sign(near)).astype(np.float32)
    side[side == 0] = np.sign(d[side == 0])
    ref = np.zeros_like(d)
    for pol in (1.0, -1.0):
        mine = strong & body & (d * pol > 0)
        if not mine.any():
            continue
        level = top_third_median((d * pol)[mine])
        loc = cv2.dilate(np.where(mine, d * pol, zero), K5)
        loc = np.where(loc >= 0.5 * level, loc, np.float32(level))
        ref = np.where(side == pol, loc, ref)
    ref = np.where(ref > 0, ref, top)
    c = np.zeros_like(d)
    c[edge] = np.clip(side[edge] * d[edge] / ref[edge], -1.0, 1.0)
    c[inner] = 1.0
    from_moments(blob, c, work.origin)
    if blob.area > 0:
        _rod_ends_centre(blob, c, work.origin)
        blob.off_axis = detections_off_axis(work, blob, ad, top, sel=sel)
    return blob


def _core_band(d, sel, strong):
    """The band of a rod of both polarities round its core, or None when nothing of its
    detections lies beyond it.

    The core is where the rod's main polarity (of more of its strong pixels) shows at
    least :data:`CORE` of its level (the median of the strongest third): a dark straw's
    edges either side of its highlight reach it end to end, a fainter rod riding along
    it or across it does not. The band runs along the core's axis, from the core's
    farthest pixel on one side to its farthest on the other, plus :data:`CORE_EDGE_PX`
    (the blurred edge beyond the fully covered pixels) each side. None also when the
    core is under 6 pixels or not 3 times as long as wide (seen end on: no axis).
    """
    counts = [np.count_nonzero(strong & (d * pol > 0)) for pol in (1.0, -1.0)]
    pol = 1.0 if counts[0] >= counts[1] else -1.0
    vals = (d * pol)[strong & (d * pol > 0)]
    if vals.size < 6:
        return None
    core = sel & (d * pol >= CORE * top_third_median(vals))
    if np.count_nonzero(core) < 6:
        return None
    cu, cv_, ca, sa, lam1, lam2 = axis(core.astype(np.float32))
    if lam1 < 9.0 * max(lam2, 1.0 / 12.0):
        return None
    yy, xx = np.indices(sel.shape, dtype=np.float32)
    perp = -(xx - cu) * sa + (yy - cv_) * ca
    band = (perp >= float(perp[core].min()) - CORE_EDGE_PX) & \
        (perp <= float(perp[core].max()) + CORE_EDGE_PX)
    if np.count_nonzero(sel & ~band) < 3:
        return None
    return band


def _rod_ends_centre(blob, c, origin):
    """Move a rod's centroid along its axis to halfway between its ends (in place).

    A rod is uniform along its length: its coverage per unit length there is its width.
    Where a highlight's blur cancels part of its edge the coverage there reads low and
    pulls the moments' centroid towards the other end. Along the axis the coverage is
    binned (1 px); bins more than 1.5 widths from both ends are given the median of
    those bins, the ends keep what they read.
    """
    x0, y0 = origin
    cx, cy = blob.u - x0, blob.v - y0
    ca, sa = np.cos(blob.angle), np.sin(blob.angle)
    ys, xs = np.nonzero(c)
    w = c[ys, xs].astype(np.float64)
    s = (xs - cx) * ca + (ys - cy) * sa
    lit = w > 0.05
    if np.count_nonzero(lit) < 6:
        return
    lo, hi = float(s[lit].min()), float(s[lit].max())
    k = np.floor(s - lo + 0.5).astype(int)
    keep = (k >= 0) & (k <= int(round(hi - lo)))
    prof = np.bincount(k[keep], weights=w[keep], minlength=int(round(hi - lo)) + 1)
    centres = lo + np.arange(prof.size)
    margin = 1.5 * max(blob.width, 1.0)
    mid = (centres > lo + margin) & (centres < hi - margin)
    if np.count_nonzero(mid) < 3:
        return
    prof = prof.copy()
    prof[mid] = float(np.median(prof[mid]))
    tot = float(prof.sum())
    if not tot > 0:
        return
    shift = float((prof * centres).sum() / tot)
    blob.u += shift * ca
    blob.v += shift * sa
