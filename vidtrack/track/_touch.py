"""What touches the object the tracker follows, in the other polarity: a shadow beside
it (blurred edges, a copy of it) or something behind it.

Internal to :mod:`vidtrack.track.tracker`.
"""

import cv2
import numpy as np

from vidtrack.track._segment import edge_stats


def opposite_touching(work, min_area):
    """Pixels changed the other way (than the object's level) touching the object."""
    opp = ((work.d * work.den < 0) & (np.abs(work.d) > work.t)).view(np.uint8)
    hug = cv2.dilate(work.sel, np.ones((5, 5), np.uint8))
    return int(np.count_nonzero(hug & opp)) >= min_area


def shadow_beside(work, *, least=0.0):
    """What touches the object in the other polarity is a shadow: its edges are
    blurred (at least 1.4 times as wide as the object's), and (``least``) it shows
    beside the object over at least that fraction of the object's pixels (a shadow is
    a copy of the object; a blurred fringe of something passing behind is not)."""
    opp = (work.d * work.den < 0) & (np.abs(work.d) > work.t)
    near = cv2.dilate(work.sel, np.ones((9, 9), np.uint8)).view(bool)
    if np.count_nonzero(opp & near) < least * np.count_nonzero(work.sel):
        return False
    _, w_opp = edge_stats(work, opp & near, alone=True)
    _, w_own = edge_stats(work, work.sel.view(bool), alone=True)
    return bool(np.isfinite(w_opp) and np.isfinite(w_own) and w_opp >= 1.4 * w_own)


def edge_width(parts):
    """Edge width (px) of the larger parts (the mask-area weighted median)."""
    parts = sorted((q for q in parts if np.isfinite(q.edge_w)), key=lambda q: q.edge_w)
    if not parts:
        return np.nan
    half = 0.5 * sum(q.mask_area for q in parts)
    run = 0.0
    for q in parts:
        run += q.mask_area
        if run >= half:
            return float(q.edge_w)
    return float(parts[-1].edge_w)
