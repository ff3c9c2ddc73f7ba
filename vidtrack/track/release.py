"""The release: where the object's ride (on a blade, in a hand) ends and its free flight
begins.

Position and velocity are continuous at the release; the acceleration is not: riding
the blade the straw is pushed round (centripetal and Coriolis, of order omega^2 R:
hundreds of m/s^2), a thrown ball is pushed by the hand; in free flight only gravity and
drag act (of order k1 g: tens of m/s^2) and change smoothly. :func:`find_release` fits
a spline knot robustly to the start of the path (free flight continued backward, plus
the ride's extra acceleration) and finds the instant to a fraction of a frame. A drag
that falls off as a light object slows down bends the path smoothly and has no knot
beside something it touched: it is not taken for a release.
"""

import numpy as np

from vidtrack.track.path import MAD_TO_SIGMA, TUKEY

__all__ = ["find_release", "TUKEY"]

#: The robust reweighting stops once the knot moves less than this (frames) between two
#: rounds: a hundredth of the 0.5 frame the release is measured to.
KNOT_CONVERGED_FRAMES = 0.005


def _knot_design(ts, tk):
    """Columns of the C1 spline: a cubic in ``ts`` plus ``(tk - ts)_+^2`` (scaled time)."""
    pre = np.clip(tk - ts, 0.0, None)
    return np.column_stack([np.ones_like(ts), ts, ts ** 2, ts ** 3, pre ** 2])


def _weighted_lstsq(a, p, w):
    """Row-weighted least squares: coefficients and the unweighted residuals."""
    coef, *_ = np.linalg.lstsq(a * w[:, None], p * w[:, None], rcond=None)
    return coef, p - a @ coef


def _knot_rss(ts, p, w, tks):
    """Weighted RSS of the knot spline for each scaled knot in ``tks`` (vectorised).

    The cubic's columns are the same for every knot: the knot column and the positions
    are projected off them once, and each knot's RSS is the cubic's minus what its
    column explains (the same numbers as one least-squares solve per knot).
    """
    base = _knot_design(ts, 0.0)[:, :4] * w[:, None]
    u, s, _ = np.linalg.svd(base, full_matrices=False)
    q = u[:, s > s[0] * base.shape[0] * np.finfo(float).eps]
    e = p * w[:, None]
    e = e - q @ (q.T @ e)
    c = np.clip(tks[None, :] - ts[:, None], 0.0, None) ** 2 * w[:, None]
    r = c - q @ (q.T @ c)
    rr = np.einsum("ij,ij->j", r, r)
    re = r.T @ e
    explained = np.zeros_like(rr)
    # a knot column the cubic already spans (to rounding) explains nothing
    ok = rr > (c.shape[0] * np.finfo(float).eps) ** 2 * np.einsum("ij,ij->j", c, c)
    explained[ok] = np.sum(re[ok] ** 2, axis=1) / rr[ok]
    return float(np.sum(e * e)) - explained


def _best_knot(ts, p, w, lo, hi, scale):
    """Knot (frames) minimising the weighted RSS: a quarter-frame grid, refined to 0.01."""
    best, step = None, 0.25
    grid = np.arange(lo, hi + 1e-9, step)
    for fine in (0.05, 0.01, None):
        best = float(grid[int(np.argmin(_knot_rss(ts, p, w, grid / scale)))])
        if fine is None:
            return best
        grid = np.arange(max(lo, best - step), min(hi, best + step) + 1e-9, fine)
        step = fine


def find_release(tau, pos, usable_mask, *, first_in_open, window=80, min_before=2,
                 min_after=10, significance=25.0, min_ratio=2.0, huber=2.5, attached=None,
                 attached_within=10.0, pushed_cos=None):
    """Release (first frame of free flight) from where the path's acceleration jumps.

    Position and velocity are continuous at the release; the acceleration is not:
    riding the blade the straw is pushed round (centripetal and Coriolis, of order
    omega^2 R: hundreds of m/s^2), in free flight only gravity and drag act (of order
    k1 g: tens of m/s^2). The first ``window`` usable points are fitted with a cubic in
    time plus ``(tk - t)_+^2``: free flight continued backward, plus the ride's extra
    acceleration, a spline whose second derivative jumps at ``tk`` (a further cubic term
    for the ride makes the knot unstable on synthetic runs). ``tk`` is chosen by least
    squares on a quarter-frame grid and refined to 0.01 frame; the residuals are
    reweighted (twice Huber at ``huber`` robust sigmas, then Tukey's biweight) and the
    knot found again, so that a few centroids thrown off by the rotor cannot pull it
    (on synthetic paths, 0.05 px noise and four errors of up to 1.5 px among the 30
    frames round the release, the knot's RMS error drops from 0.6 to 0.37 frame for a
    release 12 frames into the track; 6 frames in, Huber alone misses 8 releases in
    30, the biweight none, at 0.9 frame RMS). The knot counts when it lowers the residual
    sum of squares by more than ``significance`` noise variances and the acceleration
    just before it is at least ``min_ratio`` times the free flight's there (the ride is
    the strongly accelerated part). The release frame is the first frame at or after
    ``tk - 0.2``.

    Parameters
    ----------
    tau : numpy.ndarray
        Times in frames of all frames.
    pos : numpy.ndarray
        ``(n, 2)`` positions.
    usable_mask : numpy.ndarray of bool
        Points that may be used (measured; merged with the rotor is allowed).
    first_in_open : bool
        The object's first sighting touched neither the image border nor another moving
        object: when no knot is found, it appeared in free flight (from behind
        something) and its first frame is the release.
    window : int
        Usable points fitted, from the first.
    min_before, min_after : int
        Least usable points before and after the knot.
    significance : float
        Least drop of the residual sum of squares, in noise variances.
    min_ratio : float
        Least ratio of the acceleration before the knot to that after it.
    huber : float
        Residuals beyond this many robust sigmas are down-weighted in the first
        reweightings (Huber); after them Tukey's biweight (``TUKEY`` robust sigmas)
        drops gross errors altogether.
    attached : numpy.ndarray of bool, optional
        Frames where the object touched another moving object (the blade, a hand).
        Given, a knot counts only when such a frame lies within ``attached_within``
        frames before it: an object flying free before the knot was not released there
        (a light object's drag falls off as it slows down, which a knot can mimic).
    pushed_cos : float, optional
        Given, a knot counts only when the ride's extra acceleration (before the knot,
        less the free flight's) points along the velocity at the knot at least this
        much (the cosine of the angle between them), and ``attached`` is not asked: a
        blade or a hand pushes what it carries (or turns it, centripetally: cosine near
        0), while drag falling off as a light object slows down, or a shuttlecock's
        strong drag after a racket's hit, leaves an extra braking before the knot
        (cosine near -1), touched or not. A straw riding a blade that it hides from the
        camera touches nothing visible.

    Returns
    -------
    (int or None, float or None, str)
        Index of the release frame, the release instant in frames (sub-frame), and how
        it was decided.
    """
    idx = np.flatnonzero(usable_mask)
    if idx.size < min_after + min_before + 4:
        return None, None, "too few measured points to find the release"
    idx = idx[:window]
    t = tau[idx] - tau[idx[0]]
    p = pos[idx]
    scale = max(float(t[-1]), 1.0)
    ts = t / scale
    lo = float(t[min_before - 1]) + 0.5
    hi = float(t[-min_after])
    if hi <= lo:
        return _first_seen(idx, first_in_open)
    w = np.ones(idx.size)
    tk = None
    for it in range(6):
        prev, tk = tk, _best_knot(ts, p, w, lo, hi, scale)
        if it >= 3 and abs(tk - prev) < KNOT_CONVERGED_FRAMES:
            break
        _, r = _weighted_lstsq(_knot_design(ts, tk / scale), p, w)
        z = np.hypot(r[:, 0], r[:, 1])
        sigma = MAD_TO_SIGMA * max(float(np.median(z)), 1e-9)
        if it < 2:       # Huber first, then Tukey's biweight: gross errors get no say
            cut = huber * sigma
            w = np.where(z <= cut, 1.0, np.sqrt(cut / np.maximum(z, 1e-300)))
        else:
            w = np.clip(1.0 - (z / (TUKEY * sigma)) ** 2, 0.0, None)
    a1 = _knot_design(ts, tk / scale)
    coef, r1 = _weighted_lstsq(a1, p, w)
    rss1 = float(np.sum((r1 * w[:, None]) ** 2))
    _, r0 = _weighted_lstsq(a1[:, :4], p, w)
    rss0 = float(np.sum((r0 * w[:, None]) ** 2))
    dof = max(2 * (idx.size - a1.shape[1]) - 1, 1)
    var = max(rss1 / dof, 1e-12)
    if (rss0 - rss1) / var < significance:
        return _first_seen(idx, first_in_open)
    tks = tk / scale
    acc_free = (2.0 * coef[2] + 6.0 * coef[3] * tks) / scale ** 2      # px / frame^2
    acc_ride = acc_free + 2.0 * coef[4] / scale ** 2
    a_free = float(np.hypot(*acc_free))
    a_ride = float(np.hypot(*acc_ride))
    if a_ride < min_ratio * a_free:
        return _first_seen(idx, first_in_open, weak=(a_ride, a_free))
    t_rel = tau[idx[0]] + tk
    if pushed_cos is not None:
        if _push_cosine(coef, tks, scale) < pushed_cos:
            return _first_seen(idx, first_in_open, free=(a_ride, a_free))
    elif attached is not None:
        near = (tau >= t_rel - attached_within) & (tau <= t_rel + 1.0)
        if not np.any(np.asarray(attached, bool) & near):
            return _first_seen(idx, first_in_open, free=(a_ride, a_free))
    after = np.flatnonzero(tau >= t_rel - 0.2)
    return (int(after[0]), float(t_rel),
            f"the path's acceleration drops from {a_ride:.3g} to {a_free:.3g} px/frame^2 "
            "here (end of the ride on the blade)")


def _push_cosine(coef, tks, scale):
    """The cosine of the angle between the ride's extra acceleration (the knot term's)
    and the path's velocity at the knot (1: pushed along, -1: braked)."""
    vel = (coef[1] + 2.0 * coef[2] * tks + 3.0 * coef[3] * tks ** 2) / scale
    extra = 2.0 * coef[4] / scale ** 2
    norm = float(np.hypot(*vel) * np.hypot(*extra))
    return float(vel @ extra) / norm if norm > 0 else -1.0


def _first_seen(idx, first_in_open, weak=None, free=None):
    if first_in_open:
        return int(idx[0]), None, "the object was first seen in free flight"
    if free is not None:
        why = (f"the acceleration drops from {free[0]:.3g} to {free[1]:.3g} px/frame^2 "
               "while nothing pushes or touches the object (drag, not a release)")
    else:
        why = ("no jump of the acceleration was found" if weak is None else
               f"the acceleration changes only from {weak[0]:.3g} to {weak[1]:.3g} "
               "px/frame^2, not the ride's strong acceleration ending")
    return None, None, f"{why}: the release is not identifiable in this view"
