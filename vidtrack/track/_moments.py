"""A rod's coverage moments: its axis, its fields from them, its share beyond its band
(what is attached across it shows there), a level from its strongest pixels.

Internal to the tracker's measurements (:mod:`vidtrack.track._coverage`,
:mod:`vidtrack.track._mixed`, :mod:`vidtrack.track._silhouette`).
"""

import cv2
import numpy as np


def axis(c):
    """Centroid, unit axis and the two second moments of a coverage image."""
    m = cv2.moments(c, False)
    m00 = m["m00"]
    if not m00 > 0:
        return None
    a, bb, cc = m["mu20"] / m00, m["mu11"] / m00, m["mu02"] / m00
    ang = 0.5 * np.arctan2(2.0 * bb, a - cc)
    half = 0.5 * (a + cc)
    rad = np.hypot(0.5 * (a - cc), bb)
    return (m["m10"] / m00, m["m01"] / m00, np.cos(ang), np.sin(ang), half + rad,
            max(half - rad, 0.0))


def top_third_median(vals):
    """Median of the largest third of ``vals`` (a 1-D array, not empty): an object's
    level from its most changed pixels, which are the fully covered ones."""
    k = max(1, vals.size // 3)
    return float(np.median(np.partition(vals, vals.size - k)[vals.size - k:]))


def from_moments(blob, c, origin, m=None):
    """``blob`` (in place) with the centroid, area, length, width and angle of the
    coverage image ``c`` whose top-left pixel is ``origin`` (``m``: its moments, when the
    caller has them); area 0 when it is empty."""
    if m is None:
        m = cv2.moments(c, False)
    m00 = m["m00"]
    if not m00 > 0:
        blob.area = 0.0
        return blob
    x0, y0 = origin
    blob.u = x0 + m["m10"] / m00
    blob.v = y0 + m["m01"] / m00
    blob.area = float(m00)
    a, bb, cc = m["mu20"] / m00, m["mu11"] / m00, m["mu02"] / m00
    half = 0.5 * (a + cc)
    rad = np.hypot(0.5 * (a - cc), bb)
    blob.length = float(np.sqrt(12.0 * max(half + rad, 0.0)))
    blob.width = float(np.sqrt(12.0 * max(half - rad, 0.0)))
    ang = 0.5 * np.arctan2(2.0 * bb, a - cc)
    if ang <= -np.pi / 2:
        ang += np.pi
    blob.angle = float(ang)
    return blob


def share_off_axis(c, m, ang, *, centre=None, band=None):
    """Share of a rod's coverage beyond its band (twice the median distance from the
    axis plus 1.5 px, or ``band``) from the axis (through the centroid of moments ``m``,
    or ``centre``), away from its ends: 0 for one rod, blurred or not; a rod attached
    across it (riding along, crossing) puts its arms there."""
    pos = c > 0.15
    if np.count_nonzero(pos) < 6:
        return 0.0
    yy, xx = np.nonzero(pos)
    w = c[pos].astype(np.float64)
    cx, cy = centre if centre is not None else (m["m10"] / m["m00"], m["m01"] / m["m00"])
    ca, sa = np.cos(ang), np.sin(ang)
    along = (xx - cx) * ca + (yy - cy) * sa
    across = np.abs(-(xx - cx) * sa + (yy - cy) * ca)
    if band is None:
        order = np.argsort(across)
        cum = np.cumsum(w[order])
        half = float(across[order][np.searchsorted(cum, 0.5 * cum[-1])])
        band = 2.0 * half + 1.5
    k = along.size
    lo, hi = np.partition(along, (k // 10, k - 1 - k // 10))[[k // 10, k - 1 - k // 10]]
    mid = (along > lo) & (along < hi)
    total = float(w[mid].sum())
    if total <= 0:
        return 0.0
    return float(w[mid & (across > band)].sum() / total)


def detections_off_axis(work, blob, ad, top, *, sel=None):
    """:func:`_off_axis` of a rod measured by its body (:func:`measure_mixed`): of its
    detections, each weighted by its change ``ad`` (up to ``top``, the 90th percentile of
    them), about the body's axis. What is attached across or beside the rod, and was
    closed into its body, shows there. ``sel``: the detections that are the rod's
    (default: all)."""
    if sel is None:
        sel = work.sel.view(bool)
    if not sel.any() or not blob.area > 0:
        return 0.0
    det = np.where(sel, np.minimum(ad / max(top, np.float32(1e-6)), np.float32(1.0)),
                   np.float32(0.0)).astype(np.float32)
    m = cv2.moments(det, False)
    if not m["m00"] > 0:
        return 0.0
    return share_off_axis(det, m, blob.angle)
