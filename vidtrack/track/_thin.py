"""A thin straw (under :data:`THIN_PX` wide) measured by fitting its own line to the pixels.

A straw 1 px wide has a width set by where it falls on the pixel grid, and a fainter
thing beside it (a rider 1.5 px away, a blurred shadow) pulls its coverage moments by a
good part of a pixel: their sum holds both. Its strongest pixels (coverage at least 0.55
of its best pixel's) are the straw's alone; they give the line a model starts from:

    c(x, y) = a * [Phi((r + 1/2) / s) - Phi((r - 1/2) / s)]
                * [Phi((h - q) / s2) - Phi((-h - q) / s2)]

with ``q, r`` a pixel centre's distance along and across the segment of centre
``(u, v)``, angle ``theta`` and half-length ``h``; ``a`` the coverage per unit length
(the straw's width), ``s`` its blur across (optics and the straw's own width, with the
pixel's unit box, which is exact for a line along a row), ``s2`` along (motion blur).
Fitted by least squares with a soft-l1 loss (scale 0.05 of full coverage), so that the
pixels of what lies beside it, which the line does not explain, weigh little. The
segment's centre is the coverage centroid of a uniform rod.

A line along the grid (its ends under :data:`ALIGNED_PX` apart across the rows it runs
along) is shaped across by the pixel's unit box, not by a blur: each pixel holds the
overlap of a strip ``a`` wide with it, and those overlaps' centroid is up to 0.1 px off
the strip's centre as it moves across the row (a 1.4 px strip). There the place across
it is that of the strip through the box (:func:`_strip_model`, exact without optics,
with a Gaussian blur beyond), fitted after the box model; along it the box model's.

Measured on ``vidtrack synth`` at its default scale (a 1.1 px straw), unflagged frames
against the truth's coverage centroid: no distractor, front 0.021 px median and 0.13 px
at worst (moments: 0.037 and 0.17), top 0.044 and 0.13 (0.037 and 0.21); a rider riding
1.5 px beside it, front 0.022 and 0.19 (moments: 0.36 and 0.83). Against the straw's
centre (the silhouette's), the 1.4 px straw of the default run: top view, which lies
along a row all through, 0.041 px RMS with the strip across (0.075 without), front
0.026 (0.028).

Internal to :mod:`vidtrack.track._coverage`.
"""

import math

import cv2
import numpy as np

#: A straw whose strongest pixels are narrower than this (px) is thin: its width is set
#: by where it falls on the pixel grid (a 1.1 px straw along a row measures 0.4 to 2 px).
THIN_PX = 2.5
#: Shortest strongest-pixel line (px) a segment is fitted to: shorter, a straw seen
#: nearly end on is a blob whose length and blur the fit cannot tell apart.
FIT_MIN_LENGTH_PX = 5.0
#: Bounds of the blur across (the straw's own width in it) and along the segment (px).
_BLUR_ACROSS = (0.3, 3.0)
_BLUR_ALONG = (0.3, 6.0)
#: A pixel is among the strongest with at least this fraction of the coverage of the
#: best ones: a 1.1 px straw's pixels show 0.45 to 0.9 as it falls across or along a row,
#: a rider of half its contrast and half its width at most 0.29.
_STRONG = 0.55
#: A line whose strongest pixels leave a longer stretch (px) along it without one is no
#: uniform rod (a highlight along a dark straw cancels its middle, leaving its ends):
#: not fitted.
GAP_MAX_PX = 2.5
#: ... or whose middle third holds less than this fraction of the coverage per unit
#: length of each outer third (away from the ends). Measured on ``vidtrack synth``'s thin
#: straws: clean, 1 % of the frames below 0.67 to 0.70; with a highlight, a median 0.61.
DIP = 0.65
#: Something beside a thin straw whose largest change is at most this fraction of the
#: straw's is fainter (a rider of half its contrast): a fitted line is not moved by it.
FAINTER = 0.7
#: Shortest line (px) whose thirds are compared (each outer third 2 px at least).
DIP_MIN_LENGTH_PX = 9.0
#: A line whose ends lie less than this (px) apart across the pixel rows (or columns) it
#: runs along lies along the grid: every pixel across it samples the same place of its
#: profile, and the pixels' unit box (not a blur) shapes it (:func:`_strip_model`).
ALIGNED_PX = 0.5
#: Bounds of the blur across a line along the grid beyond its width and the pixel's box
#: (optics; none in a rendered straw).
_BLUR_STRIP = (0.02, 3.0)
#: Pixels fitted: within this distance (px) of the strongest pixels' line and of its ends.
_REACH_PX = 4.0
#: Soft-l1 scale of the residuals, in coverage.
_F_SCALE = 0.05
#: Largest distance (px) of the fitted centre from the strongest pixels' centroid, in
#: straw lengths: beyond, the fit ran off (kept: the moments).
_MAX_SHIFT = 0.25


def is_thin_line(width, length):
    """Strongest pixels (:func:`strong_line`) ``width`` wide and ``length`` long are a
    thin straw's line: under :data:`THIN_PX` wide, and at least twice that and 3 times
    their width long (shorter, a straw seen nearly end on is a blob)."""
    return width < THIN_PX and length >= max(2.0 * THIN_PX, 3.0 * width)


def strongest(c):
    """Pixels with at least :data:`_STRONG` of the coverage of its best pixel (a straw
    seen end on is a pixel or two; full coverage at most); None without a covered
    pixel."""
    # (a pixel is covered fully at most: beyond, the noise or the level's error)
    peak = min(float(c.max()), 1.0) if c.size else 0.0
    if not peak > 0:
        return None
    return (c >= np.float32(_STRONG * peak)).view(np.uint8)


def local_centroid(c, line):
    """Centroid of the coverage ``c`` within 2 px of its strongest pixels (``line`` from
    :func:`strong_line`, for its reach), or None."""
    strong = strongest(c)
    if strong is None:
        return None
    near = cv2.dilate(strong, np.ones((5, 5), np.uint8)).view(bool)
    m = cv2.moments(np.where(near, np.maximum(c, np.float32(0.0)), np.float32(0.0)), False)
    if not m["m00"] > 0:
        return None
    u, v = m["m10"] / m["m00"], m["m01"] / m["m00"]
    if math.hypot(u - line[2], v - line[3]) > 0.5 * max(line[1], 2.0):
        return None
    return u, v


def strong_line(c):
    """(width, length, cx, cy, angle, gap) of the strongest pixels (:func:`strongest`;
    ``sqrt(12 lambda)`` of their unweighted second moments; ``gap`` the longest stretch
    along the axis without one), or None. A fainter rod (a
    rider: half the contrast, half the width) or a blurred shadow attached to a thin
    straw stays below that; the straw does not."""
    strong = strongest(c)
    if strong is None:
        return None
    m = cv2.moments(strong, True)
    if not m["m00"] >= 1:
        return None
    a, bb, cc = m["mu20"] / m["m00"], m["mu11"] / m["m00"], m["mu02"] / m["m00"]
    half = 0.5 * (a + cc)
    rad = math.hypot(0.5 * (a - cc), bb)
    cx, cy = m["m10"] / m["m00"], m["m01"] / m["m00"]
    ang = 0.5 * math.atan2(2.0 * bb, a - cc)
    width = math.sqrt(12.0 * max(half - rad, 0.0))
    gap = 0.0
    if width < THIN_PX:          # (only a thin straw's is looked at)
        ys, xs = np.nonzero(strong)
        q = np.sort((xs - cx) * math.cos(ang) + (ys - cy) * math.sin(ang))
        gap = float(np.diff(q).max()) if q.size > 1 else 0.0
    return (width, math.sqrt(12.0 * max(half + rad, 0.0)), cx, cy, ang, gap)


_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)


def _phi(z):
    return _INV_SQRT_2PI * np.exp(-0.5 * z * z)


def _ndtr(z):
    """The standard normal's distribution function (scipy's, imported when first fitted:
    a run whose straw is not thin never loads it)."""
    from scipy.special import ndtr

    return ndtr(z)


def _along(p, xx, yy):
    """``cos, sin`` of the segment ``p``'s angle, the pixels' distances along and across
    it from its centre, ``w1, w2`` (its ends over the blur along) and its profile along."""
    u, v, th, h, s2 = p[0], p[1], p[2], p[3], p[6]
    ca, sa = math.cos(th), math.sin(th)
    dx, dy = xx - u, yy - v
    q = dx * ca + dy * sa
    r = dy * ca - dx * sa
    w1, w2 = (h - q) / s2, (-h - q) / s2
    return ca, sa, q, r, w1, w2, _ndtr(w1) - _ndtr(w2)


def _parts(p, xx, yy):
    ca, sa, q, r, w1, w2, along = _along(p, xx, yy)
    s = p[5]
    z1, z2 = (r + 0.5) / s, (r - 0.5) / s
    across = _ndtr(z1) - _ndtr(z2)
    return ca, sa, q, r, z1, z2, w1, w2, across, along


def _model(p, xx, yy):
    *_, across, along = _parts(p, xx, yy)
    return p[4] * across * along


def _jacobian(p, xx, yy):
    a, s, s2 = p[4], p[5], p[6]
    ca, sa, q, r, z1, z2, w1, w2, A, B = _parts(p, xx, yy)
    p1, p2, g1, g2 = _phi(z1), _phi(z2), _phi(w1), _phi(w2)
    dA_dr = (p1 - p2) / s
    dB_dq = (g2 - g1) / s2
    jac = np.empty((xx.size, 7))
    jac[:, 0] = a * (dA_dr * sa * B - A * dB_dq * ca)
    jac[:, 1] = a * (-dA_dr * ca * B - A * dB_dq * sa)
    jac[:, 2] = a * (-dA_dr * q * B + A * dB_dq * r)
    jac[:, 3] = a * A * (g1 + g2) / s2
    jac[:, 4] = A * B
    jac[:, 5] = -a * B * (p1 * z1 - p2 * z2) / s
    jac[:, 6] = -a * A * (g1 * w1 - g2 * w2) / s2
    return jac


def _ramp(x, s):
    """The integral of the blurred unit step up to ``x``: ``s (z Phi(z) + phi(z))``,
    ``z = x / s`` (``max(x, 0)`` without blur)."""
    z = x / s
    return s * (z * _ndtr(z) + _phi(z))


def _strip_parts(p, xx, yy):
    *_, r, _, _, along = _along(p, xx, yy)
    a, s = p[4], p[5]
    # the strip [-a/2, a/2] seen through the pixel's unit box: edges at r +- (a +- 1)/2
    e = [r + 0.5 * (a + 1.0), r + 0.5 * (a - 1.0), r - 0.5 * (a - 1.0), r - 0.5 * (a + 1.0)]
    across = sum(g * _ramp(x, s) for g, x in zip(_EDGE_SIGNS, e))
    return e, across, along


#: Signs of the four blurred ramps that make a strip seen through the pixel's box.
_EDGE_SIGNS = (1.0, -1.0, -1.0, 1.0)


def _strip_model(p, xx, yy):
    """A line along the grid: a strip ``a`` wide (its coverage per unit length, as a
    uniform straw's) through the pixels' unit box, blurred by ``s`` across, ``s2`` along;
    exact without optics for a straw whose rows span under :data:`ALIGNED_PX`."""
    _, across, along = _strip_parts(p, xx, yy)
    return across * along


def _strip_jacobian(p, xx, yy):
    """Derivatives of :func:`_strip_model` by the segment's place across (its centre moved
    along the normal), its width ``a`` and its blur across ``s``: the parameters
    :func:`_across` fits."""
    s = p[5]
    e, _, along = _strip_parts(p, xx, yy)
    cdf = [_ndtr(x / s) for x in e]
    dT_dr = sum(g * c for g, c in zip(_EDGE_SIGNS, cdf))
    dT_da = 0.5 * (cdf[0] - cdf[1] + cdf[2] - cdf[3])
    dT_ds = sum(g * _phi(x / s) for g, x in zip(_EDGE_SIGNS, e))
    return np.column_stack([-dT_dr * along, dT_da * along, dT_ds * along])


def _dips(xx, yy, cc, line):
    """Its coverage per unit length dips in the middle third (below :data:`DIP` of each
    outer third's, away from the ends): no uniform rod (a highlight along a dark straw
    cancels its middle; a rider beside it adds to one part, never below both others)."""
    _, length, cx, cy, ang, _ = line
    if length < DIP_MIN_LENGTH_PX:
        return False
    ca, sa = math.cos(ang), math.sin(ang)
    q = (xx - cx) * ca + (yy - cy) * sa
    r = np.abs((yy - cy) * ca - (xx - cx) * sa)
    band = r <= 2.0
    third = length / 6.0
    mid = band & (np.abs(q) <= third)
    ends = [band & (q * side > third) & (q * side <= 0.5 * length - 1.0)
            for side in (1.0, -1.0)]
    if np.count_nonzero(mid) < 3 or min(np.count_nonzero(e) for e in ends) < 3:
        return False
    per_mid = cc[mid].sum() / (2.0 * third)
    per_end = 0.5 * length - 1.0 - third
    return bool(all(per_mid < DIP * cc[e].sum() / per_end for e in ends))


def fit_line(c, domain, line, density):
    """Centre (u, v) in ``c``'s pixels of the segment fitted to the coverage ``c`` over
    the pixels ``domain`` (bool), from ``line`` (:func:`strong_line`) and the coverage
    per unit length ``density``; None when the line is too short or broken, or the fit
    fails or runs off."""
    width, length, cx, cy, ang, gap = line
    if length < FIT_MIN_LENGTH_PX or gap > GAP_MAX_PX:
        return None
    yy, xx = np.nonzero(domain)
    xx = xx.astype(np.float64)
    yy = yy.astype(np.float64)
    cc = c[yy.astype(np.intp), xx.astype(np.intp)].astype(np.float64)
    # the pixels round the line (what lies farther cannot move it)
    ca, sa = math.cos(ang), math.sin(ang)
    near = ((np.abs((yy - cy) * ca - (xx - cx) * sa) <= _REACH_PX)
            & (np.abs((xx - cx) * ca + (yy - cy) * sa) <= 0.5 * length + _REACH_PX))
    xx, yy, cc = xx[near], yy[near], cc[near]
    if xx.size < 8 or _dips(xx, yy, cc, line):
        return None
    p0 = [cx, cy, ang, 0.5 * length, max(density, 0.3), 0.5, 0.7]
    lo = [-np.inf, -np.inf, -np.inf, 0.0, 0.0, _BLUR_ACROSS[0], _BLUR_ALONG[0]]
    hi = [np.inf, np.inf, np.inf, np.inf, np.inf, _BLUR_ACROSS[1], _BLUR_ALONG[1]]
    res = _least_squares(lambda p: _model(p, xx, yy) - cc, lambda p: _jacobian(p, xx, yy),
                         p0, lo, hi)
    if res is None:
        return None
    u, v = float(res.x[0]), float(res.x[1])
    th, h = float(res.x[2]), float(res.x[3])
    if length >= DIP_MIN_LENGTH_PX and h * abs(math.sin(2.0 * th)) < ALIGNED_PX:
        # along the grid (and long enough that a speck of noise is not taken for one):
        # across it, where the strip through the pixels' box puts it. Only across: the
        # strip's width is its coverage per unit length, which a grey level read a few
        # per cent off changes, and with it where the strip's ends put its centre
        # along (0.07 px between two passes of the same frame); the box's is not
        d = _across(res.x, xx, yy, cc)
        if d is not None:
            u, v = u - d * math.sin(th), v + d * math.cos(th)
    if not (np.isfinite(u) and np.isfinite(v)
            and math.hypot(u - cx, v - cy) <= _MAX_SHIFT * length):
        return None
    return u, v


def _across(x, xx, yy, cc):
    """How far across the segment ``x`` (fitted by the box model) the strip through the
    pixels' box puts it, its width and blur across fitted (the blur from none), the rest
    held; None when the fit fails."""
    u, v, th, h, a, _, s2 = (float(t) for t in x)
    nu, nv = -math.sin(th), math.cos(th)

    def full(q):
        return [u + q[0] * nu, v + q[0] * nv, th, h, q[1], q[2], s2]

    res = _least_squares(lambda q: _strip_model(full(q), xx, yy) - cc,
                         lambda q: _strip_jacobian(full(q), xx, yy),
                         [0.0, a, 0.05], [-np.inf, 0.0, _BLUR_STRIP[0]],
                         [np.inf, np.inf, _BLUR_STRIP[1]])
    return None if res is None else float(res.x[0])


def _least_squares(fun, jac, p0, lo, hi):
    """scipy's least squares with the soft-l1 loss from ``p0`` within ``[lo, hi]``;
    None when it fails or does not converge."""
    from scipy.optimize import least_squares

    try:
        res = least_squares(fun, np.clip(p0, lo, hi), jac=jac, bounds=(lo, hi),
                            loss="soft_l1", f_scale=_F_SCALE, xtol=1e-4, ftol=1e-4,
                            max_nfev=60)
    except (ValueError, np.linalg.LinAlgError):
        return None
    return res if res.success and np.isfinite(res.x).all() else None
