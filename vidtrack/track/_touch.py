"""What touches the object the tracker follows, in the other polarity: a shadow beside
it (blurred edges, a copy of it) or something behind it.

Internal to the tracker (:mod:`vidtrack.track._step`, :mod:`vidtrack.track._search`).
"""

import math

import cv2
import numpy as np

from vidtrack.track._segment import K3, K5, edge_stats, opposite
from vidtrack.track._thin import strong_line, strongest


def opposite_touching(work, min_area):
    """Pixels changed the other way (than the object's level) touching the object."""
    opp = opposite(work).view(np.uint8)
    hug = cv2.dilate(work.sel, np.ones((5, 5), np.uint8))
    return int(np.count_nonzero(hug & opp)) >= min_area


#: What touches the object in the other polarity and runs out of the region round it
#: with more than this many times its pixels (or runs through that region) is larger
#: than a shadow of it (a copy of it, a few pixels off): an arm or a machine part
#: before or behind it (:func:`larger_than_shadow`).
SHADOW_AREA_MAX = 3.0


def shadow_beside(work, *, least=0.0):
    """What touches the object in the other polarity is a shadow: its edges are
    blurred (at least 1.4 times as wide as the object's), and (``least``) it shows
    beside the object over at least that fraction of the object's pixels (a shadow is
    a copy of the object; a blurred fringe of something passing behind is not). Not
    when it is larger than a shadow (:func:`larger_than_shadow`: an arm passing before
    it, its edges blurred by its motion)."""
    opp = opposite(work)
    near = cv2.dilate(work.sel, np.ones((9, 9), np.uint8)).view(bool)
    n_sel = np.count_nonzero(work.sel)
    if np.count_nonzero(opp & near) < least * n_sel:
        return False
    if larger_than_shadow(work, opp, near) is not None:
        return False
    _, w_opp = edge_stats(work, opp & near, alone=True)
    _, w_own = edge_stats(work, work.sel.view(bool), alone=True)
    return bool(np.isfinite(w_opp) and np.isfinite(w_own) and w_opp >= 1.4 * w_own)


def larger_than_shadow(work, opp, near):
    """What of ``opp`` (the other polarity's changed pixels, bool) meets ``near`` (bool),
    when it runs out of the work region with more than :data:`SHADOW_AREA_MAX` times the
    object's pixels, or runs through it (out at two opposite sides: longer than the
    region round the object, which a copy of it a few pixels off is not), as a bool
    mask: an arm or a machine part, not a shadow of the object. None when it does not,
    or nothing meets it."""
    if not (opp & near).any():
        return None
    _, lab = cv2.connectedComponents(opp.view(np.uint8))
    touching = np.unique(lab[opp & near])
    whole = np.isin(lab, touching[touching > 0])
    top, bottom = whole[0].any(), whole[-1].any()
    left, right = whole[:, 0].any(), whole[:, -1].any()
    if (top and bottom) or (left and right) or (
            (top or bottom or left or right)
            and np.count_nonzero(whole) > SHADOW_AREA_MAX * np.count_nonzero(work.sel)):
        return whole
    return None


def beside_thin(work, *, width):
    """What touches a thin straw (:data:`~vidtrack.track._thin.THIN_PX`) in the other
    polarity is a shadow beside it: at most a third of the straw's strongest pixels fall
    inside it, closed over the straw's width (a blade behind the straw surrounds them),
    and at most half of it inside the straw's band (a highlight along it is inside);
    it is a copy of the straw (along it within 25 degrees, half to twice its length, its
    centre within a quarter of the length of the straw's along it: not a tooth it is
    leaving, beyond one end) and much fainter (its 90th percentile change at most 0.35
    of the straw's). A thin straw's edges cannot tell a blurred shadow from a sharp
    object: their width is the blur's."""
    sel = work.sel.view(bool)
    readable = np.abs(work.den) > work.t
    c = np.zeros_like(work.d)
    np.divide(work.d, work.den, out=c, where=readable)
    strong = strongest(np.where(sel, c, np.float32(0.0)))
    if strong is None or not strong.any():
        return False
    opp = opposite(work).view(np.uint8)
    k = 2 * int(np.ceil(max(width or 1.0, 1.0))) + 3
    behind = cv2.morphologyEx(opp, cv2.MORPH_CLOSE, np.ones((k, k), np.uint8)).view(bool)
    s = strong.view(bool)
    if np.count_nonzero(s & behind) > np.count_nonzero(s) / 3.0:
        return False
    # and a copy of it (a shadow): along it, of about its length
    near = cv2.dilate(work.sel, np.ones((9, 9), np.uint8)).view(bool) & opp.view(bool)
    line = strong_line(np.where(sel, c, np.float32(0.0)))
    m = cv2.moments(np.where(near, np.abs(work.d), np.float32(0.0)), False)
    if line is None or not m["m00"] > 0:
        return False
    a, bb, cc = m["mu20"] / m["m00"], m["mu11"] / m["m00"], m["mu02"] / m["m00"]
    rad = np.hypot(0.5 * (a - cc), bb)
    length = float(np.sqrt(12.0 * max(0.5 * (a + cc) + rad, 0.0)))
    turn = abs((0.5 * np.arctan2(2.0 * bb, a - cc) - line[4] + np.pi / 2) % np.pi - np.pi / 2)
    along = ((m["m10"] / m["m00"] - line[2]) * np.cos(line[4])
             + (m["m01"] / m["m00"] - line[3]) * np.sin(line[4]))
    if not (turn <= np.radians(25.0) and 0.5 * line[1] <= length <= 2.0 * line[1]
            and abs(along) <= 0.25 * line[1]):
        return False
    # outside the straw (a highlight along it lies inside its band)
    ys, xs = np.nonzero(near)
    w = np.abs(work.d[ys, xs])
    ca, sa = np.cos(line[4]), np.sin(line[4])
    inside = ((np.abs((ys - line[3]) * ca - (xs - line[2]) * sa) <= 0.5 * line[0] + 0.5)
              & (np.abs((xs - line[2]) * ca + (ys - line[3]) * sa) <= 0.5 * line[1]))
    if w[inside].sum() > 0.5 * w.sum():
        return False
    # and much fainter than the straw (a blade or a tooth it leaves is solid)
    own = float(np.percentile(np.abs(work.d[s]), 90))
    return float(np.percentile(np.abs(work.d[near]), 90)) <= 0.35 * own


def edge_width(parts, *, alone=False):
    """Edge width (px) of the larger parts (the mask-area weighted median); ``alone``:
    each part's without the edges of what touches it in the other polarity (a shadow's
    edge with the object beside it is the object's, sharp)."""
    def width(q):
        return q.edge_w_alone if alone else q.edge_w

    parts = sorted((q for q in parts if np.isfinite(width(q))), key=width)
    if not parts:
        return np.nan
    half = 0.5 * sum(q.mask_area for q in parts)
    run = 0.0
    for q in parts:
        run += q.mask_area
        if run >= half:
            return float(width(q))
    return float(width(parts[-1]))


def other_touching(work, *, width, min_area, ignore=None):
    """Something of the other polarity touches the straw: solid (it survives a 3 x 3
    opening) and reaching beyond the 2-pixel seam where compression rings round the
    straw's edges (a halo is not an object). ``ignore``: pixels not looked at (bool; a
    spot on the object's own body)."""
    sel = work.sel
    opp = opposite(work, ignore).view(np.uint8)
    hug = cv2.dilate(sel, K5)
    if np.count_nonzero(hug & opp) < min_area:
        return False
    k = 2 * int(math.ceil(max(width or 1.0, 1.0))) + 3
    kernel = np.ones((k + 4, k + 4), np.uint8)
    solid = cv2.morphologyEx(opp, cv2.MORPH_OPEN, K3)
    return np.count_nonzero(cv2.dilate(sel, kernel) & ~hug & solid) >= min_area


def other_behind(work, level, *, width, min_area, ignore=None):
    """Take a moving object of the other polarity touching the straw as its background.

    A bright straw riding a dark blade (or crossing a dark object) does not cover the
    static background but the object: its coverage must be read against the object's
    level. The object's pixels near the straw (changed *away* from the straw's level)
    are closed over the straw's width, and inside that region the background becomes the
    object's median level (in place, in ``work``). ``ignore``: pixels where the other
    polarity is the object's own (its highlight, :func:`~vidtrack.track._search.on_own_body`),
    not looked at.

    Returns
    -------
    bool
        True when such an object touches the straw (the frame is then flagged).
    """
    if not other_touching(work, width=width, min_area=min_area, ignore=ignore):
        return False
    sel = work.sel
    opp = opposite(work, ignore).view(np.uint8)
    k = 2 * int(math.ceil(max(width or 1.0, 1.0))) + 3
    kernel = np.ones((k, k), np.uint8)
    near = cv2.dilate(sel, kernel).view(bool)
    obj = opp.view(bool) & near
    if not obj.any():
        return True
    obj_level = np.float32(np.median(work.f[obj]))
    behind = cv2.morphologyEx(opp, cv2.MORPH_CLOSE, kernel).view(bool) & near
    b = work.b.copy()
    b[behind] = obj_level
    work.b = b
    work.d = work.f - b
    work.den = np.float32(level) - b
    return True
