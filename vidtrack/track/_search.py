"""Finding the object while it is not followed: the moving blobs of a whole frame, each
polarity and, where an object shows both, the whole, measured for the choice
(:class:`~vidtrack.track._select.Acquirer`).

Internal to :mod:`vidtrack.track._pass`.
"""

import copy
from types import SimpleNamespace

import cv2
import numpy as np

from vidtrack.track._rods import is_rod, rod_fill, rodlike_run
from vidtrack.track._coverage import measure
from vidtrack.track._mixed import measure_mixed
from vidtrack.track._moments import from_moments
from vidtrack.track._segment import (K3, K5, convex_hull, edge_stats, fill_holes, opposite,
                                     read_level, work_margin)
from vidtrack.track._shadow import attached_shadow
from vidtrack.track._silhouette import SPOT_MAX, hidden_bound, measure_silhouette, trim_attached
from vidtrack.track._select import on_body
from vidtrack.track._touch import edge_width, other_behind, other_touching

#: Boxes of moving pixels looked at per frame while searching (largest first).
SEARCH_BOXES = 16
#: Components per polarity and box measured while searching (largest first).
SEARCH_PARTS = 24
#: A rod is straight: its coverage fills at least this share of the rectangle its
#: moments describe (:func:`~vidtrack.track._rods.rod_fill`; a straw 0.85 to 1, the bright
#: crescent round a dark toy's rim 0.45 to 0.6).
STRAIGHT_FILL = 0.7
#: A shadow shows beside its object at most about as large as the object, its penumbra
#: aside: a blurred part more than this many times the size of the sharp part beside it
#: is not the sharp part's shadow.
SHADOW_AREA_MAX = 2.0


def on_own_body(work, min_area):
    """The convex hull of a compact blob's detections, holes filled, grown by a pixel
    (bool), when what touches the blob in the other polarity (pieces of at least
    ``min_area`` pixels; smaller ones are compression's specks) is there, lies wholly
    within it and is at most :data:`~vidtrack.track._silhouette.SPOT_MAX` of the blob's
    pixels: a spot on it (a steel ball's highlight), not something touching it. Else
    None (nothing changes): for a rod,
    across which something else lies within its hull, and where what touches it reaches
    beyond its hull (a shadow, a second object) or outweighs it.

    A dark ball with a highlight dropped from rest at 1000 frames/s (``vidtrack synth
    --model free``, tests/test_synth_distractors.py) is taken once it has fallen twice
    its size; every frame found till then had been flagged MERGED with its own
    highlight, the release was not found and the fit's t = 0 was the first frame after
    them (its y0 18 mm low, vy0 -0.81 m/s against 0)."""
    sel = fill_holes(work.sel).view(np.uint8)
    shape = from_moments(SimpleNamespace(), sel.astype(np.float32), (0, 0))
    if not shape.area > 0 or is_rod(shape.width, shape.length):
        return None
    hull = cv2.dilate(convex_hull(sel).view(np.uint8), K3).view(bool)
    # (what touches it, but compression's specks smaller than an object can be)
    opp = opposite(work).view(np.uint8)
    _, lab, stats, _ = cv2.connectedComponentsWithStats(opp)
    near = np.unique(lab[cv2.dilate(work.sel, K5).view(bool) & opp.view(bool)])
    near = near[(near > 0) & (stats[near, cv2.CC_STAT_AREA] >= min_area)]
    touching = np.isin(lab, near)
    if not near.size or (touching & ~hull).any() or \
            np.count_nonzero(touching) > SPOT_MAX * np.count_nonzero(work.sel):
        return None
    return hull


def search_blobs(seg, i, frame, gain, *, shape, min_area, blade=None, near=None,
                 within=None, shadow="aside"):
    """The moving blobs of frame ``i``, measured (each polarity, and the wholes of both).

    ``near``: ``((u, v), reach)`` of the object named or just taken, looked for first
    however many larger things move elsewhere (boxes are taken largest first);
    ``within``: ``((u, v), gate)`` where a straw that was followed and lost can be, the
    only place it is looked for; ``blade``: a boolean mask of the frame, a blob wholly
    inside it is not looked at; ``shape``: the frame's (rows, cols); ``shadow``: how a
    silhouette's attached shadow is measured (:func:`measure_silhouette`).
    """
    boxes = seg.coarse(frame, gain)
    if not boxes:
        return []
    rows, cols = shape
    if near is not None:
        (nu, nv), reach = near
        boxes.sort(key=lambda bx: max(bx[0] - nu, nu - bx[2], bx[1] - nv,
                                      nv - bx[3], 0.0) > reach)
    pad = 2 * seg.decimate + 2
    if within is not None:
        p, gate = within
        boxes = [bx for bx in boxes
                 if max(bx[0] - p[0], p[0] - bx[2], bx[1] - p[1], p[1] - bx[3]) <= gate]
    rois = []
    for x0, y0, x1, y1, _ in boxes[:SEARCH_BOXES]:
        r = [max(0, x0 - pad), max(0, y0 - pad), min(cols, x1 + pad), min(rows, y1 + pad)]
        for q in rois:
            if r[0] < q[2] and q[0] < r[2] and r[1] < q[3] and q[1] < r[3]:
                q[:] = [min(r[0], q[0]), min(r[1], q[1]), max(r[2], q[2]), max(r[3], q[3])]
                break
        else:
            rois.append(r)
    out = []
    for r in rois:
        parts = {1: [], -1: []}
        for pol in (1, -1):
            reg = seg.segment(frame, tuple(r), gain=gain, polarity=pol)
            if any(c.touches_roi for c in reg.components(min_area, shape)):
                # the coarse box cut an object: look at a wider box
                w, h = r[2] - r[0], r[3] - r[1]
                r = [max(0, r[0] - w // 2 - pad), max(0, r[1] - h // 2 - pad),
                     min(cols, r[2] + w // 2 + pad), min(rows, r[3] + h // 2 + pad)]
                reg = seg.segment(frame, tuple(r), gain=gain, polarity=pol)
            comps = sorted(reg.components(min_area, shape), key=lambda c: -c.mask_area)
            if len(comps) > SEARCH_PARTS:     # compression noise: the small ones go
                comps = [c for c in comps[:SEARCH_PARTS] if c.mask_area >= 3 * min_area]
            for b in comps:
                if blade is not None:
                    x0, y0, x1, y1 = b.bbox
                    if blade[y0:y1, x0:x1].all():
                        continue
                lv = read_level(reg, b)
                work = reg.work([b.label], lv, margin=work_margin(None, None, b.bbox))
                b.contrast, b.edge_w = edge_stats(work)
                b.edge_w_alone = edge_stats(work, alone=True)[1]
                # (what touches it only on its own body, its highlight, is its own)
                b.merged = other_touching(work, width=None, min_area=min_area) and \
                    other_behind(work, lv, width=None, min_area=min_area,
                                 ignore=on_own_body(work, min_area))
                b.core, _, b.uniform = trim_attached(work, reach_px=None)
                # (a copy: its measurement without a shadow, aside, would not be kept)
                sil = measure_silhouette(work, copy.copy(b),
                                         shadow="cut" if shadow == "cut" else None)
                measure(work, b, lv, separate=False)
                if not b.area > 0:
                    continue
                if sil.area > 0:
                    b.silhouette = (sil.u, sil.v, sil.area, sil.angle, sil.length,
                                    sil.width)
                    b.hidden = hidden_bound(work, sil)
                b.level = lv
                b.polarity = pol
                b.index = i
                out.append(b)
                parts[pol].append(b)
        if parts[1] and parts[-1]:
            out.extend(_wholes(seg, i, frame, r, gain, parts, shape=shape, min_area=min_area))
    return out


def _wholes(seg, i, frame, r, gain, parts, *, shape, min_area):
    """Objects made of parts of both polarities (a dark ball with its highlight)."""
    reg = seg.segment(frame, tuple(r), gain=gain, polarity=0)
    found = []
    for b in reg.components(min_area, shape):
        x0, y0, x1, y1 = b.bbox
        inside = {pol: [q for q in parts[pol] if x0 <= q.u <= x1 and y0 <= q.v <= y1]
                  for pol in (1, -1)}
        if not inside[1] or not inside[-1]:
            continue
        area_of = {pol: sum(q.mask_area for q in inside[pol]) for pol in (1, -1)}
        big = max((1, -1), key=lambda pol: area_of[pol])
        small = -big
        if area_of[small] < max(min_area, 0.03 * b.mask_area):
            continue
        # the smaller polarity inside the larger's box (a highlight, an opening),
        # or parts side by side (a cup half lit, a plush toy's light and dark
        # sides); a straw on a large blade is neither
        outer = max(inside[big], key=lambda q: q.mask_area)
        ox0, oy0, ox1, oy1 = outer.bbox
        enclosed = all((ox0 <= q.bbox[0] and oy0 <= q.bbox[1] and q.bbox[2] <= ox1
                        and q.bbox[3] <= oy1) or on_body(q, outer) for q in inside[small])
        # (a rod riding a blade of the other polarity is its own object; patches
        # of other shapes (a texture's, of which some may be long) are parts, up to
        # a tenth of the whole)
        if not enclosed and area_of[big] > (3.0 if _rods(inside[small]) else 10.0) \
                * area_of[small]:
            continue
        work = reg.work([b.label], np.nan, margin=work_margin(None, None, b.bbox))
        # a shadow beside an object is not part of it: its edges are blurred (unless it
        # is attached to an object of both polarities, which still is one without it);
        # beside a rod, a part of the other polarity whose edges are not as sharp as the
        # rod's is something else (a blade, its shadow), where a texture's patches
        # pass smoothly through the wall's grey level from one polarity to the other
        # (a blurred dark part much larger than the sharp bright one is not its shadow:
        # a dark toy whose bright crescent at its rim is sharp, its own dark texture
        # fading into the wall); a shadow told by each part's edges without those it
        # shares with the other polarity (a shadow's edge with the object beside it is
        # the object's)
        wb, wd = edge_width(inside[1]), edge_width(inside[-1])
        sb, sd = edge_width(inside[1], alone=True), edge_width(inside[-1], alone=True)
        sb, sd = (sb if np.isfinite(sb) else wb), (sd if np.isfinite(sd) else wd)
        unlike = (sd >= 1.6 * sb and area_of[-1] <= SHADOW_AREA_MAX * area_of[1]) or \
            (_rods(inside[big]) and wb >= 1.6 * wd)
        if (not enclosed and np.isfinite(wb) and np.isfinite(wd) and unlike
                and not _both_without_shadow(work, min_area)):
            continue
        b.contrast, b.edge_w = edge_stats(work)
        b.edge_w_alone = b.edge_w
        measure_mixed(work, b, separate=False)
        if not b.area > 0:
            continue
        b.hidden = hidden_bound(work, b)
        b.polarity = 0
        b.index = i
        found.append(b)
    return found


def _rods(parts):
    """Whether rods (:func:`rodlike_run`, straight: :data:`STRAIGHT_FILL`) hold at least
    two thirds of the parts' area."""
    return sum(q.mask_area for q in parts if rodlike_run([q]) and _straight(q)) \
        >= 2.0 / 3.0 * sum(q.mask_area for q in parts)


def _straight(q):
    """Whether a part fills its moments' rectangle as a straight rod does (a rod too thin
    for its width to say: yes)."""
    fill = rod_fill(q)
    return fill is None or fill >= STRAIGHT_FILL


def _both_without_shadow(work, min_area):
    """Whether the detections of ``work`` are an object of both polarities with a shadow
    attached (:func:`attached_shadow`): without it, each polarity still holds at least
    ``min_area`` pixels and a tenth of the rest (a bright ball beside its shadow is
    bright alone)."""
    shade = attached_shadow(work, np.abs(work.d))
    if shade is None:
        return False
    rest = work.sel.view(bool) & ~shade
    least = max(min_area, 0.1 * np.count_nonzero(rest))
    return bool(np.count_nonzero(rest & (work.d > 0)) >= least
                and np.count_nonzero(rest & (work.d < 0)) >= least)
