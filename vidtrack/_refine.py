"""After the pass over the frames: outliers, the release, and gaps (internal).

Works on the per-frame arrays of one view (times in frames ``tau``, positions ``u, v``,
``flags``), in place. Only *clean* points (flags 0, finite) are evidence; flagged points
are never used to judge others.

- :func:`flag_outliers`: a point farther than ``max(min_px, 6 x robust scatter)`` from a
  quadratic through its clean neighbours (up to 4 on each side, itself left out) is
  flagged OUTLIER.
- :func:`find_release`: position and velocity are continuous at the release, the
  acceleration jumps (riding the blade the straw is pushed round at hundreds of m/s^2;
  in free flight only gravity and drag act): a spline knot fitted to the start of the
  path finds the instant to a fraction of a frame. Without a significant knot the
  release is its first frame when the straw appeared in the open (not at the border,
  not on another moving object), else not identifiable (None).
- :func:`bridge_gaps`: runs of at most ``max_gap`` frames without a measurement, with
  clean points on both sides, get positions from a quadratic through up to 3 clean
  points on each side, flagged PREDICTED.
"""

import numpy as np

from vidtrack.background import MAD_TO_SIGMA


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


def _knot_rss(t, p, tau_k, cols):
    """Residual sum of squares of the C1 spline with a knot at ``tau_k`` (both axes)."""
    pre = np.clip(tau_k - t, 0.0, None)
    a = np.column_stack(cols + [pre ** 2])
    coef, *_ = np.linalg.lstsq(a, p, rcond=None)
    r = p - a @ coef
    return float(np.sum(r * r)), r


def find_release(tau, pos, usable_mask, *, first_in_open, latest=None, window=60,
                 min_after=10, significance=25.0):
    """Release (first frame of free flight) from where the path's acceleration jumps.

    Position and velocity are continuous at the release; the acceleration is not:
    riding the blade the straw is pushed round (centripetal and Coriolis, hundreds of
    m/s^2), in free flight only gravity and drag act. The first ``window`` usable
    points are fitted with a cubic in time plus ``(tk - t)_+^2`` (a spline whose second
    derivative jumps at ``tk``; a further cubic term for the ride would triple the
    knot's scatter on synthetic runs), ``tk`` chosen by least
    squares on a 0.1-frame grid and refined to 0.01 frame; the knot counts when it
    lowers the residual sum of squares by more than ``significance`` times the noise
    variance. The release frame is the first frame at or after ``tk - 0.2``.

    Parameters
    ----------
    tau : numpy.ndarray
        Times in frames of all frames.
    pos : numpy.ndarray
        ``(n, 2)`` positions.
    usable_mask : numpy.ndarray of bool
        Points that may be used (measured; merged with the blade is allowed).
    first_in_open : bool
        The straw's first sighting touched neither the image border nor another moving
        object: it appeared in free flight (from behind something).
    latest : float, optional
        Latest possible release (time in frames): the straw has left the blade by the
        time it is first seen clear of every other moving object.

    Returns
    -------
    (int or None, float or None, str)
        Index of the release frame, the release instant in frames (sub-frame), and how
        it was decided.
    """
    idx = np.flatnonzero(usable_mask)
    if idx.size < min_after + 4:
        return None, None, "too few measured points to find the release"
    idx = idx[:window]
    t = tau[idx] - tau[idx[0]]
    p = pos[idx]
    scale = max(float(t[-1]), 1.0)
    ts = t / scale
    cols = [np.ones_like(ts), ts, ts ** 2, ts ** 3]
    a0 = np.column_stack(cols)
    coef, *_ = np.linalg.lstsq(a0, p, rcond=None)
    rss0 = float(np.sum((p - a0 @ coef) ** 2))
    lo, hi = 1.0, float(t[-min_after])
    if latest is not None:
        hi = min(hi, float(latest - tau[idx[0]]))
    if hi <= lo:
        return _first_seen(idx, first_in_open)
    grid = np.arange(lo, hi + 1e-9, 0.1)
    rss = np.array([_knot_rss(ts, p, g / scale, cols)[0] for g in grid])
    k = int(np.argmin(rss))
    fine = np.arange(max(lo, grid[k] - 0.1), min(hi, grid[k] + 0.1) + 1e-9, 0.01)
    rssf = np.array([_knot_rss(ts, p, g / scale, cols)[0] for g in fine])
    tk = float(fine[int(np.argmin(rssf))])
    rss1, resid = _knot_rss(ts, p, tk / scale, cols)
    dof = max(2 * idx.size - 11, 1)
    var = max(rss1 / dof, 1e-12)
    if (rss0 - rss1) / var < significance:
        return _first_seen(idx, first_in_open)
    t_rel = tau[idx[0]] + tk
    after = np.flatnonzero(tau >= t_rel - 0.2)
    return (int(after[0]), float(t_rel),
            "the path's acceleration jumps here (end of the ride on the blade)")


def _first_seen(idx, first_in_open):
    if first_in_open:
        return int(idx[0]), None, "the straw was first seen in free flight"
    return None, None, ("no jump of the acceleration was found: the release is not "
                        "identifiable in this view")


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
