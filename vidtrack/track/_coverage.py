"""A rod (a straw) measured by its coverage.

:func:`measure` turns the straw's blob into its centroid, area, orientation and length
from its **coverage** of each pixel: a pixel that the opaque straw covers by a fraction
c shows ``f = b + c (s - b)`` (b the background, s the straw's grey level), so
``c = (f - b) / (s - b)``, not clipped to [0, 1] (:data:`COVERAGE_RANGE`). Weighting
by c instead of by ``|f - b|`` keeps the centroid unbiased over a textured background,
where ``|s - b|`` changes from pixel to pixel. Where ``|s - b|`` is within the noise
the coverage cannot be read off the pixel; inside the straw's rod (its axis and width
from the readable part) such a pixel gets the rod's coverage (:func:`_band_fill`).

Internal to the tracker (:mod:`vidtrack.track._step`, :mod:`vidtrack.track._search`,
:mod:`vidtrack.track._rods`).
"""

import cv2
import numpy as np

from vidtrack.track._mixed import measure_mixed
from vidtrack.track._moments import axis, from_moments, share_off_axis
from vidtrack.track._segment import COVERAGE_RANGE, K3, READABLE, opposite
from vidtrack.track._thin import (GAP_MAX_PX, THIN_PX, fit_line, is_thin_line, local_centroid,
                                 strong_line)


def measure(work, blob, level, *, width=None, length=None, thin=None, separate=True):
    """Coverage-weighted centroid, area, orientation and length of the straw (in place).

    Parameters
    ----------
    work : Work
        The box around the straw's components (:meth:`Region.work`).
    blob : Blob
        The straw's main component; its fields are filled in.
    level : float
        The straw's grey level.
    width, length : float, optional
        The straw's reference width and length (px), for the pixels where the straw
        cannot be seen (its level within the noise of the background's).
    thin : bool or None
        Its clean frames were a thin straw (:data:`~vidtrack.track._thin.THIN_PX`):
        its line is fitted when this frame's strongest pixels are a thin line too;
        False: they were not (not fitted); None: not known (fitted when this frame's
        are).
    separate : bool
        A rod of both polarities is measured on its core's band (:func:`measure_mixed`;
        False: whole, the band's measurement in ``blob.separated``).

    Returns
    -------
    Blob
        ``blob``, with ``u, v`` the coverage centroid (px), ``area`` the coverage sum
        (px^2), ``angle`` the orientation of the major axis in (-pi/2, pi/2] from +u
        towards +v, ``length`` and ``width`` ``sqrt(12 lambda)`` of the coverage's
        second moments (exact for a uniform rectangle).

    Notes
    -----
    The support is the detected pixels grown by one pixel, without other components.
    Unreadable pixels (``|level - background|`` below :data:`READABLE` times the
    threshold) inside a rod along the readable part's axis get the rod's coverage;
    other unreadable pixels of the support get the normalised average of their
    readable neighbours. A rod whose eroded detections hold pixels of the other
    polarity (at least 3 and 5 % of them: a highlight along a dark straw) is measured by
    :func:`measure_mixed` instead, its ``off_axis`` then read off its detections about
    the body's axis.
    """
    others = work.others
    support = cv2.dilate(work.sel, K3)
    support[others] = 0
    d, t, den = work.d, work.t, work.den
    readable = np.abs(den) > np.float32(READABLE) * t
    c = np.zeros_like(d)
    np.divide(d, den, out=c, where=readable)
    np.clip(c, *COVERAGE_RANGE, out=c)
    sup = support.view(bool)
    # a highlight along the straw (brighter than the background where the straw is
    # darker), which the closing took into the detections, would be read as negative
    # coverage: a rod of both polarities, measured by its body
    # (not a straw known to be thin whose strongest pixels are still a thin line: what
    # the closing joined to it there, a shadow between it and a rider beside it, is not
    # inside it; its own line is fitted below)
    lit = cv2.erode(work.sel, K3).view(bool) & (d * den < 0) & (np.abs(d) > t)
    if np.count_nonzero(lit) >= max(3, 0.05 * np.count_nonzero(work.sel)) and \
            not (thin and _thin_line(c, sup, readable)):
        measure_mixed(work, blob, rod=True, separate=separate)
        blob.level = level
        return blob
    unread = sup & ~readable
    if unread.any():
        c_read = c.copy()
        band = _band_fill(c, sup, unread, readable, width=width, length=length)
        if band is not None:
            # once more with the axis of the completed rod (a partly hidden rod's
            # visible part tilts the first axis)
            sup1 = (sup & readable) | (band & ~others)
            c2 = c_read.copy()
            band2 = _band_fill(c2, sup1, sup1 & ~readable, readable, width=width,
                               length=length)
            if band2 is not None:
                band, c = band2, c2
            band &= ~others
            sup = (sup & readable) | band
            unread[:] = False
    if unread.any():
        # normalised 3 x 3 averages of the readable coverage, twice (2 px deep)
        w = (sup & ~unread).astype(np.float32)
        cw = c * w
        for _ in range(2):
            num = cv2.blur(cw, (3, 3), borderType=cv2.BORDER_CONSTANT)
            cnt = cv2.blur(w, (3, 3), borderType=cv2.BORDER_CONSTANT)
            got = unread & (cnt > 0)
            c[got] = num[got] / cnt[got]
            w[got] = 1.0
            cw = c * w
            unread &= ~got
            if not unread.any():
                break
    c_all = c.copy()
    c[~sup] = 0.0
    m = cv2.moments(c, False)
    m00 = m["m00"]
    if m00 < 0.5 * float(c[c > 0].sum()):
        # the negative coverage outweighs half the positive: a faint blob in noise,
        # whose moments are not a rod's; measured on the positive coverage alone
        np.clip(c, 0.0, None, out=c)
        m = cv2.moments(c, False)
        m00 = m["m00"]
    x0, y0 = work.origin
    if not m00 > 0:
        blob.area = 0.0
        return blob
    from_moments(blob, c, work.origin, m)
    blob.level = level
    blob.off_axis = share_off_axis(c, m, blob.angle)
    line = strong_line(c)
    if line is not None:
        blob.strong_shape = line[:2]
        if line[0] < THIN_PX and thin is not False:
            # a thin straw: the moments' axis runs between it and a fainter rod beside
            # it, and their band holds both; its strongest pixels' axis is its own, and
            # its centre that of its own line fitted to the pixels (_thin)
            if line[1] >= 2.0 * THIN_PX:
                blob.off_axis = max(blob.off_axis, share_off_axis(
                    c, None, line[4], centre=line[2:4], band=0.5 * line[0] + 1.5))
            domain = cv2.dilate(sup.view(np.uint8), K3).view(bool) & ~others
            domain &= sup | readable
            got = fit_line(c_all, domain, line, m00 / max(line[1], 1.0))
            blob.fitted = got is not None
            if got is None and line[5] <= GAP_MAX_PX:
                # too short for a line (seen nearly end on), or the fit failed: the
                # coverage within 2 px of its strongest pixels (a fainter rod farther
                # off is not of it; a rod whose middle a highlight cancels keeps its
                # moments)
                got = local_centroid(c, line)
            if got is not None:
                blob.u, blob.v = x0 + got[0], y0 + got[1]
    return blob


def _thin_line(c, sup, readable):
    """The strongest pixels of the positive coverage over the support are a thin line."""
    line = strong_line(np.where(sup & readable, np.maximum(c, np.float32(0.0)),
                                np.float32(0.0)))
    return line is not None and is_thin_line(line[0], line[1])


def _band_fill(c, sup, unread, readable, *, width, length):
    """Coverage of unreadable pixels from a rod model along the readable part's axis.

    The rod has the readable part's axis and the reference ``width``; along the axis it
    spans the readable part's covered pixels, extended towards an end that runs into
    unreadable pixels until it has the reference ``length``. Returns the pixels filled
    (to be added to the support).
    """
    ax = axis(np.where(sup, c, np.float32(0.0)))
    if ax is None:
        return None
    cx, cy, ca, sa, lam1, lam2 = ax
    if not (width and np.isfinite(width) and width > 0):
        width = float(np.sqrt(12.0 * lam2)) if lam2 > 0 else 1.0
    rows, cols = c.shape
    yy, xx = np.mgrid[0:rows, 0:cols]
    along = (xx - cx) * ca + (yy - cy) * sa
    across = np.abs(-(xx - cx) * sa + (yy - cy) * ca)
    inband = across <= 0.5 * width
    seen = readable & sup & (c > 0.5)
    if not seen.any():
        return None
    lo, hi = float(along[seen].min()), float(along[seen].max())
    # readable covered pixels on the axis beyond the detections (below the detection
    # threshold but readable) extend the rod while they continue it without a gap
    more = np.sort(along[readable & inband & (c > 0.5) & ~sup])
    if more.size:
        above = more[more > hi]
        for a in above:
            if a - hi > 1.5:
                break
            hi = float(a)
        below = more[more < lo][::-1]
        for a in below:
            if lo - a > 1.5:
                break
            lo = float(a)
    if length and np.isfinite(length) and hi - lo < length - 1.0:
        lo_hidden = (~readable & inband & (along < lo) & (along > lo - 2.5)).any()
        hi_hidden = (~readable & inband & (along > hi) & (along < hi + 2.5)).any()
        short = length - 1.0 - (hi - lo)
        if lo_hidden and hi_hidden:
            lo, hi = lo - short / 2, hi + short / 2
        elif lo_hidden:
            lo -= short
        elif hi_hidden:
            hi += short
    prof = np.clip(0.5 * width + 0.5 - across, 0.0, 1.0)
    prof *= np.clip(np.minimum(along - lo, hi - along) + 0.5, 0.0, 1.0)
    band = prof > 0
    hidden = band & ~readable
    c[hidden] = prof[hidden]
    return band


def trim_to_rod(work, *, width, length, core=0.75):
    """Keep the straw's own band of the detections (in place, in ``work``).

    The straw is a rod of a known width and length at one grey level: its fully
    covered core (coverage at least ``core``; a dimmer rod never reaches it) gives its
    axis, and only the detections within ``width / 2 + 1`` px of that axis and
    ``length / 2 + 1`` px along it from the core's centre are the straw's; the rest (a
    thinner, dimmer rod riding along it or across it) become other pixels, which
    :func:`measure` leaves out; the band's pixels beside them (not fully covered) are
    made unreadable, for :func:`measure` to complete from the rod model. Returns the
    number of detections dropped, or None when
    the core is too small or too round to give an axis (nothing changed).
    """
    sel = work.sel.view(bool)
    readable = np.abs(work.den) > np.float32(READABLE) * work.t
    c = np.zeros_like(work.d)
    np.divide(work.d, work.den, out=c, where=readable)
    full = sel & readable & (c >= core)
    if np.count_nonzero(full) < 3:
        return None
    m = cv2.moments(full.view(np.uint8), True)
    a, bb, cc = m["mu20"] / m["m00"], m["mu11"] / m["m00"], m["mu02"] / m["m00"]
    rad = np.hypot(0.5 * (a - cc), bb)
    if not rad > 0.25 * (a + cc):       # a round core: no axis
        return None
    ang = 0.5 * np.arctan2(2.0 * bb, a - cc)
    cu, cv_ = m["m10"] / m["m00"], m["m01"] / m["m00"]
    yy, xx = np.indices(sel.shape, dtype=np.float32)
    along = (xx - cu) * np.cos(ang) + (yy - cv_) * np.sin(ang)
    perp = -(xx - cu) * np.sin(ang) + (yy - cv_) * np.cos(ang)
    # (a thin straw's width is the pixel grid's: its band is the thin limit's)
    half = 0.5 * max(width, THIN_PX) + 1.0
    band = (np.abs(perp) <= half) & (np.abs(along) <= 0.5 * length + 1.0)
    drop = sel & ~band
    n = int(np.count_nonzero(drop))
    if n:
        work.sel = (sel & band).view(np.uint8)
        work.others = work.others | drop
        # the band's edge pixels beside what was cut away show both: not readable,
        # completed from the rod model
        beside = cv2.dilate(drop.view(np.uint8), K3).view(bool) & band & ~full
        if beside.any():
            den = work.den.copy()
            den[beside] = 0.0
            work.den = den
    return n


def shade_background(work):
    """Take a shadow beside the straw into its background (in place, in ``work``).

    A shadow darkens the static background by a factor that varies smoothly (its
    penumbra), also under the straw's edge on that side, where the straw's coverage is
    read. The factor ``f / b`` is read off the shadow's pixels beside the straw (changed
    away from the straw's level) and carried 2 px further by normalised 3 x 3
    averages, under the straw's edge; there the background becomes ``b`` times it.
    Returns the number of pixels whose background changed.
    """
    opp = opposite(work)
    near = cv2.dilate(work.sel, np.ones((9, 9), np.uint8)).view(bool)
    shade = opp & near
    if not shade.any():
        return 0
    b = work.b
    ratio = np.ones_like(b)
    np.divide(work.f, b, out=ratio, where=shade & (b > 0))
    w = shade.astype(np.float32)
    rw = ratio * w
    known = shade.copy()
    for _ in range(2):
        num = cv2.blur(rw, (3, 3), borderType=cv2.BORDER_CONSTANT)
        cnt = cv2.blur(w, (3, 3), borderType=cv2.BORDER_CONSTANT)
        got = ~known & (cnt > 0)
        ratio[got] = num[got] / cnt[got]
        w[got] = 1.0
        known |= got
        rw = ratio * w
    b2 = b.copy()
    b2[known] = b[known] * ratio[known]
    work.b = b2
    work.d = work.f - b2
    level = work.den + b          # the straw's level (den = level - b)
    work.den = level - b2
    return int(np.count_nonzero(known))
