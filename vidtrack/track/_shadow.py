"""The shadow attached to an object measured by its silhouette (a toy, a cup, anything not
of one grey level): found in its detections, so that it is not measured with it.

Internal to the tracker (:mod:`vidtrack.track._silhouette`). An object of one grey level
has its own way (:func:`vidtrack.track._silhouette.trim_attached`), a rod its own
(:mod:`vidtrack.track._touch`).

A shadow falling on the wall scales the wall's brightness by a factor that varies
smoothly: ``f / b`` is one value over its umbra (within the noise), whatever the wall's
texture, where an object's own pixels follow its own texture. Round the umbra the
penumbra lightens smoothly out to the surroundings: a shadow's edge is blurred where the
object's outline is a step. And it lies beside the object. Each of these alone an object
can show in places (a white cup's shaded side on a white card is a weak, smooth, soft
darkening beside the rest); the tracker therefore cuts a shadow only where it is attached
on the same side all through the flight (:meth:`vidtrack.track._pass.Pass.attached_shadow`).
"""

import cv2
import numpy as np

from vidtrack.track._segment import K3, K5, fill_holes

#: A shadow lets through at least this share of the light (a darker patch is the object's).
SHADE_MIN_RATIO = 0.45

#: A shadow darkens the wall by at most this share of the object's own contrast (the 90th
#: percentile of ``|f - b|`` over the rest of the detections): a part as strong as the
#: object is the object's (a dark cup over a white card beside its white twin).
SHADE_MAX = 0.8

#: An edge is sharp (the object's outline) where its gradient at a scale of 1 px is at
#: least this many times that at 2 px (a step: 2; blurred by 1 px: 1.6; by 2 px: 1.3).
SHARP = 1.5

#: Steps (1 px each) the umbra is grown by into its own darkening and its penumbra.
_GROW = 6


def attached_shadow(work, ad):
    """The detections of ``work`` (an object of any grey levels) that are a shadow
    attached to it, as a bool mask over the work box, or None. ``ad = |f - b|``.

    Its umbra is where the detections are darker than the wall, letting through at least
    :data:`SHADE_MIN_RATIO` of its light, by one factor over 5 x 5 pixels (the spread of
    ``f / b`` within half the threshold over the wall's level) and off the object's sharp
    outline; grown by :data:`_GROW` pixels into what darkens the wall by the same factor
    and, outwards only, into its lighter penumbra. A grown umbra is the shadow when it
    reaches the silhouette's edge, its centroid lies at least 0.3 of the rest's size
    from the rest's, its edge with the surroundings is blurred (at least 2 px wide and
    1.5 times the rest's, :func:`_edge_width`), it is weak (:data:`SHADE_MAX`), and the
    rest keeps at least 30 % of the detections. Holes in it, the thin tails it leaves
    along itself and specks it cuts off go with it.
    """
    sel = work.sel.view(bool)
    n = int(np.count_nonzero(sel))
    if n < 40:
        return None
    least = max(20, 0.05 * n)
    ratio = work.f / np.maximum(work.b, np.float32(1.0))
    dark = sel & (work.d < 0) & (ratio >= SHADE_MIN_RATIO)
    if np.count_nonzero(dark) < least:
        return None
    g1 = _grad(work.d, 1.0)
    filled = fill_holes(work.sel)
    outside = cv2.dilate((~filled).view(np.uint8), K3).view(bool)
    parts = _grown_umbrae(work, dark, ratio, g1, filled, outside, least)
    if not parts:
        return None
    rest = sel & ~np.logical_or.reduce(parts)
    n_rest = int(np.count_nonzero(rest))
    if n_rest < 0.3 * n:
        return None
    w_own = _edge_width(ad, g1, rest, outside)
    top = float(np.percentile(ad[rest], 90))
    yr, xr = np.nonzero(rest)
    keep = []
    for part in parts:
        ys, xs = np.nonzero(part)
        off = np.hypot(xs.mean() - xr.mean(), ys.mean() - yr.mean())
        w = _edge_width(ad, g1, part, outside)
        if (off >= 0.3 * np.sqrt(n_rest) and w >= 2.0 and w >= 1.5 * w_own
                and float(np.median(ad[part])) <= SHADE_MAX * top):
            keep.append(part)
    if not keep:
        return None
    shade = fill_holes(np.logical_or.reduce(keep).view(np.uint8)) & sel
    rest = (sel & ~shade).view(np.uint8)
    tails = rest.view(bool) & ~cv2.morphologyEx(rest, cv2.MORPH_OPEN, K5).view(bool)
    shade |= tails & cv2.dilate(shade.view(np.uint8), K5).view(bool)
    k, labels, stats, _ = cv2.connectedComponentsWithStats((sel & ~shade).view(np.uint8),
                                                           connectivity=8)
    if k > 2:
        sizes = stats[1:, cv2.CC_STAT_AREA]
        shade |= np.isin(labels, np.flatnonzero(sizes < 0.1 * sizes.max()) + 1)
    return shade


def _grown_umbrae(work, dark, ratio, g1, filled, outside, least):
    """The umbrae of :func:`attached_shadow`, each grown, that reach the silhouette's
    edge (``outside``: the pixels round it); ``dark``: the detections darker than the
    wall, ``ratio = f / b``, ``g1`` the gradient at 1 px."""
    sel = work.sel.view(bool)
    g2 = _grad(work.d, 2.0)
    sharp = (g2 >= np.float32(0.1) * work.t) & (g1 >= np.float32(SHARP) * g2)
    sharp = cv2.dilate(sharp.view(np.uint8), K3).view(bool)
    m = sel.astype(np.float32)
    cnt = np.maximum(cv2.blur(m, (5, 5)), np.float32(1e-6))
    mean = cv2.blur(ratio * m, (5, 5)) / cnt
    spread = np.sqrt(np.maximum(cv2.blur(ratio * ratio * m, (5, 5)) / cnt - mean * mean, 0.0))
    tol = np.maximum(np.float32(0.02), np.float32(0.5) * work.t
                     / np.maximum(work.b, np.float32(1.0)))
    umbra = dark & (spread <= tol) & ~sharp
    umbra = cv2.morphologyEx(umbra.view(np.uint8), cv2.MORPH_CLOSE, K5).view(bool) & dark
    k, labels = cv2.connectedComponents(umbra.view(np.uint8), connectivity=8)
    depth = cv2.distanceTransform(filled.view(np.uint8), cv2.DIST_L2, 3)
    parts = []
    for j in range(1, k):
        part = labels == j
        if np.count_nonzero(part) < least:
            continue
        level = float(np.median(ratio[part]))
        band = max(2.0 * float(np.median(tol[part])), 0.04)
        same = dark & (np.abs(ratio - level) <= band)
        lighter = dark & ~sharp & (ratio >= level - band)
        for _ in range(_GROW):
            # (the penumbra outwards only: towards the surroundings, not into the object)
            inner = cv2.erode(np.where(part, depth, np.float32(1e6)), K3)
            grown = cv2.dilate(part.view(np.uint8), K3).view(bool)
            part = part | (grown & (same | (lighter & (depth <= inner))))
        if np.count_nonzero(part & outside) >= 4:
            parts.append(part)
    return parts


def _grad(d, sigma):
    """Gradient magnitude of ``d`` smoothed over ``sigma`` px (grey levels per px)."""
    ds = cv2.GaussianBlur(d, (0, 0), sigma)
    return np.hypot(cv2.Sobel(ds, cv2.CV_32F, 1, 0, ksize=3),
                    cv2.Sobel(ds, cv2.CV_32F, 0, 1, ksize=3)) / np.float32(8.0)


def _edge_width(ad, grad, part, outside):
    """How wide ``part``'s edge with ``outside`` is (px): its typical ``|f - b|`` over the
    steepest gradient along that edge (the 90th percentile). NaN without an edge."""
    rim = part & outside
    if np.count_nonzero(rim) < 4:
        return np.nan
    g = float(np.percentile(grad[rim], 90))
    return float(np.median(ad[part])) / g if g > 0 else np.inf
