"""An object of any shape measured by its silhouette (holes filled), or, for an object
of one grey level, by its fully covered core and the edge round it read against its
surroundings (what is attached beyond, a shadow, cut off).

Internal to the tracker (:mod:`vidtrack.track._step`, :mod:`vidtrack.track._search`).
"""

import copy
import math

import cv2
import numpy as np

from vidtrack.track._moments import from_moments
from vidtrack.track._segment import K3, K5, READABLE, convex_hull, fill_holes, opposite
from vidtrack.track._shadow import attached_shadow
from vidtrack.track._touch import larger_than_shadow

#: A pixel whose ``|level - background|`` is below this many detection thresholds may be
#: missed where the object covers it (a pixel at 1.2 to 1.6 thresholds was, through
#: noise and compression: :func:`hidden_shift`).
BLIND = 1.5


def trim_attached(work, *, reach_px, along=(0.0, 0.0)):
    """Drop detections not within ``reach_px`` of the object's fully covered core (None:
    only measure the core).

    For an object of one grey level (``work.den`` from its level): its pixels show its
    level whatever the background, so their coverage ``c = d / den`` is 1, partial only
    in a ring at its edge (and a smear along the motion: ``along``, the motion's vector
    in px per exposure at most; the smear is read off the core, shorter along the
    motion than across it by the blur's length). What is detected farther out is
    attached to it, not of it: a shadow of the same polarity (c about 0.5: a lighter
    darkening, blurred), a reflection. Those pixels are taken out of ``work.sel`` (into
    ``work.trimmed``: the surroundings the edge is read against).

    Returns
    -------
    (int, int, float)
        The core's pixel count (c >= 0.8), the pixels dropped, and the core's share of
        the region it closes (holes filled; 1 for an object of one grey level, less for a
        textured object, which the caller does not trim; 0 when the core's grey levels
        spread over more than 15 % of its contrast plus twice the noise: shading,
        texture).
    """
    sel = work.sel.view(bool)
    readable = np.abs(work.den) > np.float32(READABLE) * work.t
    c = np.zeros_like(work.d)
    np.divide(work.d, work.den, out=c, where=readable)
    filled = fill_holes(work.sel)
    core = (sel & (c >= 0.8)).view(np.uint8)
    n_core = int(np.count_nonzero(core))
    if n_core == 0:
        return 0, 0, 0.0
    # how solid the core is: its share of the region it closes (a ball of one grey
    # level: all of it; a textured object's scattered bright patches: little)
    closed = cv2.morphologyEx(core, cv2.MORPH_CLOSE, K5).view(bool)
    closed = fill_holes(closed.view(np.uint8)) & filled
    region = int(np.count_nonzero(closed))
    uniform = float(np.count_nonzero(core.view(bool) & closed)) / region if region else 0.0
    # and of one grey level: the core's pixels agree (their spread a small part of the
    # contrast; a white cup's shading or a toy's fur do not)
    vals = work.f[core.view(bool)]
    contrast = float(np.median(np.abs(work.d[core.view(bool)])))
    if vals.size >= 5 and contrast > 0 and not _even(vals, contrast, work.t):
        uniform = 0.0
    if reach_px is None:
        return n_core, 0, uniform
    r = max(1, int(math.ceil(reach_px)))
    disk = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    foot = cv2.dilate(core, disk)
    au, av = along
    length = float(np.hypot(au, av))
    if length >= 1.0:
        # the smear along the motion, as the core shows it: motion blur shortens the
        # fully covered core along the motion by its length, and spreads half of it
        # beyond each end (a round object's core is as long as it is wide unblurred)
        m = cv2.moments(core, True)
        if m["m00"] > 0:
            ux, uy = au / length, av / length
            mu20, mu02, mu11 = m["mu20"] / m["m00"], m["mu02"] / m["m00"], m["mu11"] / m["m00"]
            var_along = ux * ux * mu20 + 2 * ux * uy * mu11 + uy * uy * mu02
            var_perp = uy * uy * mu20 - 2 * ux * uy * mu11 + ux * ux * mu02
            blur = max(0.0, np.sqrt(12.0 * max(var_perp, 0.0))
                       - np.sqrt(12.0 * max(var_along, 0.0)))
            blur = min(blur, length, 10.0)
            au, av, length = 0.5 * blur * ux, 0.5 * blur * uy, 0.5 * blur
    if length >= 1.0:
        k = int(math.ceil(length))
        line = np.zeros((2 * k + 1, 2 * k + 1), np.uint8)
        cv2.line(line, (k - int(round(au)), k - int(round(av))),
                 (k + int(round(au)), k + int(round(av))), 1, 1)
        foot = cv2.dilate(foot, line)
    drop = filled & ~foot.view(bool)
    n_drop = int(np.count_nonzero(drop & sel))
    if n_drop:
        work.sel = (sel & ~drop).view(np.uint8)
        work.trimmed = drop
    return n_core, n_drop, uniform


def measure_solid(work, blob, *, smear=None):
    """Centroid etc. of an object of one grey level, its edge read against its
    surroundings (in place; ``work.den`` from its level).

    Its fully covered core (c >= 0.8) and enclosed holes cover fully. A pixel of the
    ring round the core (2 px) is partly covered, ``c = (f - b') / (s - b')``, clipped to
    [0, 1], where ``b'`` is the pixel's static background plus how much the surroundings
    (2 to 5 px beyond the core) differ from theirs: a shadow falling beside the object
    darkens what shows between its edge and the shadow, which read against the static
    background would look like more of the object. Something of the other polarity
    larger than a shadow (:func:`~vidtrack.track._touch.larger_than_shadow`: an arm
    passing 2 px beside it) is not of the surroundings: it does not shade what lies
    between (read as shaded, the ring on its side put the centre 0.2-0.28 px towards
    it).

    ``smear``: how far its edge may be smeared by its motion (px; its motion in a frame
    at most): its detections farther than 2 px plus that from their outline are fully
    covered too.
    """
    sel = work.sel.view(bool)
    readable = np.abs(work.den) > np.float32(READABLE) * work.t
    c = np.zeros_like(work.d)
    np.divide(work.d, work.den, out=c, where=readable)
    core = (sel & (c >= 0.8)).view(np.uint8)
    if not core.any():
        return measure_silhouette(work, blob)
    ring_k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5))
    far_k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (11, 11))
    offset = np.zeros_like(work.d)
    # (something of the other polarity larger than a shadow beside it, an arm passing,
    # does not shade what lies between it and the object: not of the surroundings)
    opp = opposite(work)
    apart = larger_than_shadow(
        work, opp, cv2.dilate(core, far_k).view(bool)) if opp.any() else None
    apart = work.others if apart is None else (work.others | apart)
    for _ in range(2):
        # the core, then the surroundings' offset, then the core read against them
        core_b = fill_holes(core) & ~work.others
        near = cv2.dilate(core_b.view(np.uint8), ring_k).view(bool)
        far = cv2.dilate(core_b.view(np.uint8), far_k).view(bool)
        band = (far & ~near & ~apart).astype(np.float32)
        num = cv2.blur(work.d * band, (9, 9), borderType=cv2.BORDER_REPLICATE)
        cnt = cv2.blur(band, (9, 9), borderType=cv2.BORDER_REPLICATE)
        offset = np.where(cnt > 0.05, num / np.maximum(cnt, 1e-6), np.float32(0.0))
        d2 = work.d - offset
        den2 = work.den - offset
        c2 = np.zeros_like(work.d)
        np.divide(d2, den2, out=c2, where=np.abs(den2) > np.float32(READABLE) * work.t)
        core2 = (sel & (c2 >= 0.8)).view(np.uint8)
        if not core2.any():
            break
        core = core2
    core_b = fill_holes(core) & ~work.others
    if smear is not None:
        # deep inside its detections it is fully covered, whatever its shading there (a
        # highlight, and round it the glow that brings it to the background's level:
        # read as partly covered, the centre moved away from it)
        r = 2 + int(math.ceil(smear))
        disk = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
        core_b |= cv2.erode(fill_holes(work.sel).view(np.uint8), disk).view(bool) & ~work.others
    near = cv2.dilate(core_b.view(np.uint8), ring_k).view(bool)
    ring = near & ~core_b & ~work.others & (sel | cv2.dilate(work.sel, K3).view(bool))
    d2 = work.d - offset
    den2 = work.den - offset
    ok = ring & (np.abs(den2) > np.float32(READABLE) * work.t)
    cov = np.zeros_like(work.d)
    cov[ok] = np.clip(d2[ok] / den2[ok], 0.0, 1.0)
    cov[core_b] = 1.0
    return from_moments(blob, cov, work.origin)


def measure_silhouette(work, blob, *, shadow="cut"):
    """Centroid, area, orientation and size of an object of any grey levels (in place).

    For an object that is brighter than the background in some parts and darker in
    others (a dark ball with a highlight, a white cup with a dark opening), or that is
    textured, no single grey level gives the coverage. Its silhouette does: the detected
    pixels (either polarity) with their holes filled (where the object's own grey level
    happens to equal the background's) cover fully; round the edge, a pixel's coverage
    is its ``|f - b|`` against the largest ``|f - b|`` of the object's interior within
    2 px (an edge pixel half covered by the object shows half of the nearby interior's
    contrast), clipped to [0, 1]. Then moments as in :func:`measure`.

    Its shadow (:func:`~vidtrack.track._shadow.attached_shadow`) is not of it.
    ``shadow``: ``"cut"``, measured without it; ``"aside"``, measured whole and, where
    a shadow is attached, without it too, kept in ``blob.shadowless``; None, measured
    whole without looking for one (the first pass
    over a view measures objects whole, and takes a shadow for one only when it is
    attached all through: :meth:`vidtrack.track._pass.Pass.attached_shadow`).
    """
    if not work.sel.any():
        blob.area = 0.0
        return blob
    ad = np.abs(work.d)
    shade = attached_shadow(work, ad) if shadow is not None else None
    if shade is None:
        return _silhouette(work, blob, work.sel, ad)
    sel = (work.sel.view(bool) & ~shade).view(np.uint8)
    trimmed = shade if work.trimmed is None else (work.trimmed | shade)
    if shadow == "aside":
        alone = _silhouette(work, copy.copy(blob), sel, ad, trimmed=trimmed)
        if alone.area > 0:
            blob.shadowless = (alone.u, alone.v, alone.area, alone.angle, alone.length,
                               alone.width)
        return _silhouette(work, blob, work.sel, ad)
    work.trimmed = trimmed
    return _silhouette(work, blob, sel, ad)


def _silhouette(work, blob, sel, ad, *, trimmed=None):
    """:func:`measure_silhouette` of the detections ``sel`` (``ad = |f - b|``); the edge
    is not read over ``trimmed`` (default ``work.trimmed``). An object of one grey level
    with a spot of the other polarity (a steel ball's highlight) is measured by
    :func:`measure_spotted`."""
    trimmed = work.trimmed if trimmed is None else trimmed
    filled = fill_holes(sel)
    if measure_spotted(work, blob, filled, ad, trimmed=trimmed):
        return blob
    fu8 = filled.view(np.uint8)
    inner = cv2.erode(fu8, K3).view(bool)
    ref = cv2.dilate(np.where(inner, ad, np.float32(0.0)), K5)
    ref = np.maximum(ref, work.t)
    edge = (cv2.dilate(fu8, K3).view(bool) & ~inner) & ~work.others
    if trimmed is not None:
        edge &= ~trimmed
    c = np.zeros_like(ad)
    c[edge] = np.minimum(ad[edge] / ref[edge], 1.0)
    c[inner] = 1.0
    return from_moments(blob, c, work.origin)


#: A spot of the other polarity is a highlight (or a mark) on an object when its strong
#: pixels are at most this share of the object's own.
SPOT_MAX = 0.5

#: The least pixels an object's interior needs for its grey level to be read
#: (:func:`own_level`), and the least of its plateau where it has no such interior
#: (:func:`measure_spotted`).
OWN_LEAST = 12
PLATEAU_LEAST = 6


def measure_spotted(work, blob, region, ad, *, trimmed=None):
    """Centroid etc. of an object of one grey level with a spot of the other polarity
    within its outline (a dark steel ball and its highlight), in place; False (``blob``
    untouched) for any other object. ``region``: its silhouette (its detections, holes
    filled); ``ad = |f - b|``.

    Read as a silhouette, such an object went wrong two ways. Its edge pixels were read
    against the largest contrast near them, which near the highlight is the highlight's:
    they read low and the centre moved away from it. And round its sharp outline
    compression rings at a tenth of its contrast, above the detection threshold where the
    contrast is high; the segmentation's closing joins those pixels to it and the filled
    silhouette took them as fully covered (a dark ball 10 by 8 px with a highlight, MJPG
    quality 60: 122 of 335 frames 0.5 to 1.95 px off).

    Its strong pixels (of either polarity, above 0.3 of the 90th percentile of
    ``|f - b|`` over its silhouette: ringing stays below) are mostly of one
    polarity, its own; those of the other (at most :data:`SPOT_MAX` of its own) lie
    within the convex hull of its own; its own pixels' interior (eroded by a pixel, at
    least :data:`OWN_LEAST`; an object too small for that, a ball 6 px across with its
    highlight in the middle, by its plateau: its own pixels within 0.8 of their 90th
    percentile, at least :data:`PLATEAU_LEAST`) is of one grey level
    (:func:`own_level`). Then the hull is its body
    (fully covered inside, the highlight with it), and a pixel at the body's edge (its
    outer pixel and the one beyond) is covered by ``(f - b) / (level - b)``, clipped to
    [0, 1], where ``level - b`` is readable (:data:`READABLE`; on background of its own
    brightness the edge cannot be read, 0), and fully where the spot reaches the body's
    outer pixel. What lies beyond is not read.
    """
    if not region.any():
        return False
    d = work.d
    top = np.float32(np.percentile(ad[region], 90))
    strong = region & (ad > np.float32(0.3) * top)
    counts = [np.count_nonzero(strong & (d * p > 0)) for p in (1.0, -1.0)]
    pol = np.float32(1.0 if counts[0] >= counts[1] else -1.0)
    own = strong & (d * pol > 0)
    spot = strong & (d * pol < 0)
    n_spot = int(np.count_nonzero(spot))
    if n_spot == 0 or n_spot > SPOT_MAX * np.count_nonzero(own):
        return False
    interior = cv2.erode(own.view(np.uint8), K3).view(bool)
    if np.count_nonzero(interior) < OWN_LEAST:
        # too small for an interior (a ball 6 px across, the highlight in its middle):
        # its plateau, the pixels of its own within 0.8 of their 90th percentile
        top_own = np.float32(np.percentile(ad[own], 90))
        interior = own & (ad >= np.float32(0.8) * top_own)
    level = own_level(work, interior, least=PLATEAU_LEAST)
    if level is None:
        return False
    contrast = d[interior] * pol
    if not _even(contrast, float(np.median(contrast)), work.t[interior]):
        return False
    hull = convex_hull(own)
    if (spot & ~hull).any():
        return False
    body = hull & ~work.others
    bu8 = body.view(np.uint8)
    inner = cv2.erode(bu8, K3).view(bool)
    edge = cv2.dilate(bu8, K3).view(bool) & ~inner & ~work.others
    if trimmed is not None:
        edge &= ~trimmed
    den = np.float32(level) - work.b
    ok = edge & (den * pol > np.float32(READABLE) * work.t)
    c = np.zeros_like(d)
    c[ok] = np.clip(d[ok] / den[ok], 0.0, 1.0)
    c[edge & body & (d * pol < 0)] = 1.0
    c[inner] = 1.0
    from_moments(blob, c, work.origin)
    return blob.area > 0


def _outline(work):
    """The object's silhouette: its detections with holes filled, less what was cut off
    as not of it (bool)."""
    sil = fill_holes(work.sel)
    if work.trimmed is not None:
        sil &= ~work.trimmed
    return sil


def _even(vals, contrast, t):
    """Whether the values ``vals`` (an object's interior: its grey levels, or their
    contrast against the background) agree: their interquartile range within 15 % of
    the object's ``contrast`` plus twice the noise (``t``: detection thresholds, 5 noise
    sigmas; their median taken)."""
    q25, q75 = np.percentile(vals, [25, 75])
    return bool(q75 - q25 <= 0.15 * contrast + 2.0 * float(np.median(t)) / 5.0)


def own_level(work, inner, *, least=OWN_LEAST):
    """The object's grey level where its interior's pixels agree (an object of one grey
    level, whatever the background does round it), else None (textured, two-toned: a
    white cup with a dark opening, a ball with a highlight).

    ``inner``: its interior, its silhouette eroded by a pixel; at least ``least`` pixels,
    whose interquartile range is within 15 % of their median contrast plus twice the
    noise (:func:`_even`, as :func:`trim_attached` asks of a core).
    """
    if np.count_nonzero(inner) < least:
        return None
    vals = work.f[inner]
    if not _even(vals, float(np.median(np.abs(work.d[inner]))), work.t[inner]):
        return None
    return float(np.median(vals))


def hidden_bound(work, blob, *, known=None, area=None):
    """:func:`hidden_shift` of an object whose interior shows one grey level
    (:func:`own_level`), or, where too little of it shows, of the level ``known`` (an
    object known to be of one grey level); 0 for any other."""
    if not blob.area > 0 or not work.sel.any():
        return 0.0
    sil = _outline(work)
    inner = cv2.erode(sil.view(np.uint8), K3).view(bool)
    own = own_level(work, inner)
    if own is None and known is not None and np.count_nonzero(inner) < OWN_LEAST:
        own = known
    return 0.0 if own is None else hidden_shift(work, blob, level=own, area=area, sil=sil)


def hidden_shift(work, blob, *, level, area=None, sil=None):
    """How far the centre of an object of one grey level ``level`` could be from where
    its detected pixels put it, because part of it lies over background of its own
    brightness (px).

    Where ``|level - background|`` is below about the detection threshold (``BLIND``
    times it) a fully covered pixel may not be detected: the object is cut off there,
    unseen, and its centre measured towards what shows (a dark ball crossing a dark
    patch of a textured wall: 1.2 px off on a ball 16 px across, its area 20 % short).
    The blind pixels that touch its silhouette (connected to it through blind pixels)
    within half its size of the measured centre (its size: its length, or the diameter
    of its area or of ``area``, its clean frames', whichever is larger) are what could
    be of it. The bound: the largest shift of the centre were those of them on one side
    of it (in one of eight directions) covered. 0 where none touch it. ``sil``: its
    silhouette, where the caller has it.
    """
    if not work.sel.any() or not blob.area > 0:
        return 0.0
    if sil is None:
        sil = _outline(work)
    blind = np.abs(np.float32(level) - work.b) <= np.float32(BLIND) * work.t
    blind &= ~sil & ~work.others
    if work.trimmed is not None:
        blind &= ~work.trimmed
    if not blind.any():
        return 0.0
    ox, oy = work.origin
    cu, cv = blob.u - ox, blob.v - oy
    size = max(float(blob.length), 2.0 * math.sqrt(max(blob.area, area or 0.0) / math.pi))
    reach = 0.5 * size
    yy, xx = np.mgrid[0:blind.shape[0], 0:blind.shape[1]]
    near = (xx - cu) ** 2 + (yy - cv) ** 2 <= reach * reach
    blind &= near
    if not blind.any():
        return 0.0
    # blind pixels reached from the silhouette through blind pixels
    _, labels = cv2.connectedComponents(blind.view(np.uint8), connectivity=8)
    rim = cv2.dilate(sil.view(np.uint8), K3).view(bool) & blind
    touching = np.unique(labels[rim])
    touching = touching[touching > 0]
    if touching.size == 0:
        return 0.0
    hid = np.isin(labels, touching)
    du = (xx[hid] - cu).astype(np.float64)
    dv = (yy[hid] - cv).astype(np.float64)
    # the worst case: of them, those on one side (eight directions), whose shift the
    # ones on the other side would not cancel
    worst = 0.0
    for a in np.arange(8) * (np.pi / 4):
        proj = du * math.cos(a) + dv * math.sin(a)
        side = proj > 0
        k = int(np.count_nonzero(side))
        if k == 0:
            continue
        total = float(proj[side].sum())
        worst = max(worst, total / (blob.area + k))
    return worst
