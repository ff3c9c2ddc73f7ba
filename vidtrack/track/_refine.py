"""After the pass over the frames: outliers, the release, and gaps (internal).

Works on the per-frame arrays of one view (times in frames ``tau``, positions ``u, v``,
``flags``), in place. Only *clean* points (flags 0, finite) are evidence; flagged points
are never used to judge others.

- :func:`flag_odd_sizes`: an object of any shape keeps its size from frame to frame; a
  clean frame far from the median size of the clean frames round it is flagged.
- :func:`flag_hidden_parts`: a rod shorter than the clean frames round it whose centre
  lies off their path along its axis by about half what it lost, or an object of any
  shape smaller than them whose centroid lies off their path as far as a part hidden at
  one side moves it, is partly hidden (coming out from behind something in front of
  it, or going behind it); flagged.
- :func:`flag_outliers`: a point farther than ``max(min_px, 6 x robust scatter)`` from a
  quadratic through its clean neighbours (up to 4 on each side, itself left out) is
  flagged OUTLIER.
- :func:`find_release`: position and velocity are continuous at the release, the
  acceleration jumps (riding the blade the straw is pushed round at hundreds of m/s^2;
  in free flight only gravity and drag act): a spline knot fitted robustly to the start
  of the path finds the instant to a fraction of a frame. Without a significant knot
  after which the acceleration is much smaller, the release is its first frame when the
  straw appeared in the open (not at the border, not on another moving object), else
  not identifiable (None).
- :func:`bridge_gaps`: runs of at most ``max_gap`` frames without a measurement, with
  clean points on both sides, get positions from a quadratic through up to 3 clean
  points on each side, flagged PREDICTED.
"""

import numpy as np

from vidtrack.track._rods import (SHORT_PX, SHORT_SHARE, area_shrunk, end_hidden,
                                  hidden_side, rod_shortened)
from vidtrack.track.background import MAD_TO_SIGMA
# (the rules tracker's, and its tests')
from vidtrack.track.release import _knot_design, _knot_rss, find_release  # noqa: F401


def _quad_fit(t, p, t_eval):
    """Least-squares quadratic (linear below 4 points) through (t, p); values at t_eval."""
    t = np.asarray(t, float)
    deg = 2 if t.size >= 4 else 1
    t0 = t.mean()
    a = np.vander(t - t0, deg + 1, increasing=True)
    coef, *_ = np.linalg.lstsq(a, p, rcond=None)
    te = np.atleast_1d(np.asarray(t_eval, float)) - t0
    return np.vander(te, deg + 1, increasing=True) @ coef


def leave_one_out_residuals(tau, pos, idx, *, half=4, span=6.5):
    """Distance of each clean point from a quadratic through its clean neighbours.

    Parameters
    ----------
    tau : numpy.ndarray
        Times in frames of all frames.
    pos : numpy.ndarray
        ``(n, 2)`` positions.
    idx : numpy.ndarray
        Indices of the clean points (sorted).
    half : int
        Neighbours used on each side.
    span : float
        Farthest neighbour in frames.

    Returns
    -------
    numpy.ndarray
        Residual (px) per clean point; NaN where fewer than 4 neighbours exist.

    Notes
    -----
    The least-squares weights depend only on the neighbours' time offsets, which are
    the same for nearly every point of an unbroken track: they are computed once per
    pattern.
    """
    res = np.full(idx.size, np.nan)
    cache = {}
    for k, i in enumerate(idx):
        lo = idx[max(0, k - half):k]
        hi = idx[k + 1:k + 1 + half]
        if lo.size == 0 or hi.size == 0:
            continue
        nb = np.concatenate([lo, hi])
        off = tau[nb] - tau[i]
        keep = np.abs(off) <= span
        if np.count_nonzero(keep) < 4:
            continue
        nb, off = nb[keep], off[keep]
        key = np.round(off, 6).tobytes()
        w = cache.get(key)
        if w is None:
            deg = 2 if off.size >= 4 else 1
            w = np.linalg.pinv(np.vander(off, deg + 1, increasing=True))[0]
            cache[key] = w
        pred = w @ pos[nb]
        res[k] = float(np.hypot(*(pos[i] - pred)))
    return res


def flag_odd_sizes(area, flags, mask, *, odd_flag, half=20, low=0.7, high=1.35):
    """Flag frames of ``mask`` whose ``area`` is off the median of the ``mask`` frames
    within ``half`` frames (outside ``low`` to ``high`` times it); returns the count."""
    idx = np.flatnonzero(mask & np.isfinite(area))
    if idx.size < 5:
        return 0
    a = area[idx]
    bad = []
    for k, i in enumerate(idx):
        lo, hi = np.searchsorted(idx, [i - half, i + half + 1])
        med = float(np.median(a[lo:hi]))
        if med > 0 and not low * med <= a[k] <= high * med:
            bad.append(i)
    flags[bad] |= odd_flag
    return len(bad)


def flag_grown_seeds(area, length, flags, seeds, clean, *, merged_flag, ratio=1.3,
                     length_ratio=1.15, count=10, reach=60):
    """Flag frames of ``seeds`` whose ``area`` exceeds ``ratio`` times, or whose
    ``length`` exceeds ``length_ratio`` times, the median of the first ``count``
    ``clean`` frames after them (within ``reach`` frames); returns the count flagged."""
    later = np.flatnonzero(clean & np.isfinite(area) & np.isfinite(length))
    bad = []
    for i in np.flatnonzero(seeds & np.isfinite(area) & np.isfinite(length)):
        k = np.searchsorted(later, i + 1)
        ref = later[k:k + count]
        ref = ref[ref - i <= reach]
        if ref.size >= 3 and (area[i] > ratio * float(np.median(area[ref]))
                              or length[i] > length_ratio * float(np.median(length[ref]))):
            bad.append(i)
    flags[bad] |= merged_flag
    return len(bad)


def _window(tau, size, idx, i, half, rod):
    """``(ref, short, jitter, full)`` of frame ``i`` against the measured frames ``idx``
    within ``half`` frames (:func:`flag_hidden_parts`), or None when it is not smaller
    than they say or they are too few."""
    near = idx[(np.abs(tau[idx] - tau[i]) <= half) & (idx != i)]
    if near.size < 4:
        return None
    ref = float(np.percentile(size[near], 75))
    change = np.abs(np.diff(size[near]))
    if rod:
        short, jitter = ref - size[i], float(np.median(change))
        maybe = rod_shortened(short, jitter)
    else:
        short = 1.0 - size[i] / ref
        jitter = float(np.median(change / np.maximum(size[near][:-1], 1e-9)))
        maybe = area_shrunk(short, jitter)
    full = near[size[near] >= 0.95 * ref]
    if not maybe or full.size < 4:
        return None
    return ref, short, jitter, full


def flag_hidden_parts(tau, pos, size, flags, mask, *, cut_flag, angle=None, reach=None,
                      half=12):
    """Flag the clean, measured frames ``mask`` of an object that have part of it hidden.

    ``size``: a rod's length (with its ``angle``), or the coverage of an object of any
    shape (``angle`` None; a rod's coverage with ``reach``, half its length per frame:
    a corner or a side of it hidden). For each frame, the frames of the mask within ``half`` frames
    give its size (their 75th percentile: it may come out from behind something on one
    side only) and how much that changes from one to the next; when it is smaller
    (:func:`~vidtrack.track._rods.end_hidden`, :func:`~vidtrack.track._rods.hidden_side`),
    a quadratic through those of them at 95 % of that size or more (4 at least) says
    where it is, within their scatter about it and the uncertainty of its extrapolation
    (its leverage there). Works in both directions of time, where the follower (which
    flags an object going behind something as it goes) cannot see one that was taken
    while it came out.
    """
    idx = np.flatnonzero(mask & np.isfinite(size))
    rod = angle is not None
    bad = []
    if idx.size < 5:
        return
    # only frames smaller than the largest of the half frames either side of them (a
    # window of as many clean frames spans as many frames or more) can be
    s = size[idx]
    most = np.lib.stride_tricks.sliding_window_view(
        np.pad(s, half, mode="edge"), 2 * half + 1).max(axis=1)
    small = (most - s >= SHORT_PX) if rod else (s <= (1.0 - SHORT_SHARE) * most)
    for i in idx[small]:
        got = _window(tau, size, idx, i, half, rod)
        if got is not None and not ((got[3] < i).any() and (got[3] > i).any()):
            # its full-size frames all on one side, and on the other none is clean up
            # to the nearest of them (it went behind something whole, or something
            # passed before it, and is coming out: partly hidden over more frames than
            # the window): those within 3 times as far on both sides, if there are, put
            # it, not an extrapolation
            wide = _window(tau, size, idx, i, 3 * half, rod)
            if wide is not None and (wide[3] < i).any() and (wide[3] > i).any():
                far = wide[3][wide[3] < i].max() if (got[3] > i).any() else \
                    wide[3][wide[3] > i].min()
                if not ((idx > min(i, far)) & (idx < max(i, far))).any():
                    got = wide
        if got is None:
            continue
        ref, short, jitter, full = got
        t0 = tau[full].mean()
        a = np.vander(tau[full] - t0, 3, increasing=True)
        coef, *_ = np.linalg.lstsq(a, pos[full], rcond=None)
        x0 = np.vander(np.atleast_1d(tau[i] - t0), 3, increasing=True)[0]
        rss = float(np.sum((pos[full] - a @ coef) ** 2))
        lev = float(x0 @ np.linalg.pinv(a.T @ a) @ x0)
        # (scatter per coordinate, at least 0.05 px: positions are not exact)
        err = max(np.sqrt(rss / (2 * max(full.size - 3, 1))), 0.05) * np.sqrt(1.0 + lev)
        off = pos[i] - x0 @ coef
        if rod:
            along = off[0] * np.cos(angle[i]) + off[1] * np.sin(angle[i])
            hidden = end_hidden(along, short, err, jitter)
        else:
            hidden = hidden_side(float(np.hypot(*off)), short, ref, err, jitter,
                                 None if reach is None else reach[i])
        if hidden:
            bad.append(i)
    flags[bad] |= cut_flag


def flag_outliers(tau, pos, flags, *, clean_mask, outlier_flag, min_px=1.0):
    """Flag clean points that leave the smooth path; returns the robust scatter (px)."""
    idx = np.flatnonzero(clean_mask)
    if idx.size < 6:
        return np.nan
    res = leave_one_out_residuals(tau, pos, idx)
    ok = np.isfinite(res)
    if not ok.any():
        return np.nan
    scale = MAD_TO_SIGMA * float(np.median(res[ok]))
    thr = max(min_px, 6.0 * scale)
    bad = idx[ok & (res > thr)]
    flags[bad] |= outlier_flag
    return scale


def bridge_gaps(tau, pos, flags, clean_mask, *, max_gap, lost_flag, predicted_flag):
    """Fill short gaps between clean points by a quadratic (in place); returns count."""
    idx = np.flatnonzero(clean_mask)
    filled = 0
    for a, b in zip(idx[:-1], idx[1:]):
        gap = b - a - 1
        if gap <= 0 or gap > max_gap:
            continue
        inside = np.arange(a + 1, b)
        if not np.all(flags[inside] & lost_flag):
            continue
        k = np.searchsorted(idx, a)
        nb = np.concatenate([idx[max(0, k - 2):k + 1], idx[k + 1:k + 4]])
        est = _quad_fit(tau[nb], pos[nb], tau[inside])
        pos[inside] = est
        flags[inside] = (flags[inside] & ~lost_flag) | predicted_flag
        filled += gap
    return filled
