"""Local quadratic paths in pixel time-space, for choosing and for flagging.

A thrown object's image moves smoothly: over a few frames its pixel position is a
quadratic in time (gravity, drag and perspective change slowly). :func:`local_quadratic`
fits, for every point of a path, a quadratic in time through its neighbours within a
window (leaving the point itself out), all points at once (batched 3 x 3 normal
equations in time centred on the point, so the fit is well conditioned), and returns
each point's prediction and the local acceleration.
"""

import warnings

import numpy as np

from vidtrack.track.background import MAD_TO_SIGMA

__all__ = ["local_quadratic", "robust_trend", "robust_path", "neighbour_median", "robust_scale",
           "clean_side", "extrapolate", "runs", "MAD_TO_SIGMA", "TUKEY"]

#: Tukey's biweight tuning constant (in robust sigmas of the residuals).
TUKEY = 4.685

#: The median of the distance of a 2-D normal point from its centre, in its sigmas: a
#: distance's median over this is the per-axis scatter.
RAYLEIGH_MEDIAN = 1.1774100225154747


def robust_scale(x, *, floor=0.0):
    """``1.4826 * median |x - median(x)|`` of the finite values, at least ``floor``."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    if x.size == 0:
        return float(floor)
    return max(float(MAD_TO_SIGMA * np.median(np.abs(x - np.median(x)))), float(floor))


#: :func:`clean_side` reads a normal law's centre and scatter off these two quantiles of
#: the values, and their standard normal quantiles.
CLEAN_QUANTILES = (0.1, 0.3)
_CLEAN_Z = (-1.2815515655446004, -0.5244005127080407)


def clean_side(x, *, floor=0.0):
    """The centre and scatter of the clean values among ``x`` where what disturbs them
    only raises them (a misfit: what touches an object adds to it, nothing takes from
    it): a normal law through the values' 10th and 30th percentiles
    (:data:`CLEAN_QUANTILES`). A share ``s`` of the values raised moves them to the
    clean values' ``0.1 / (1 - s)`` and ``0.3 / (1 - s)`` quantiles: the centre 0.4 of
    the clean scatter high at 30 % raised, 1.7 at 60 %, where the median is at the clean
    values' 71st percentile and at their largest. The scatter is at least ``floor``;
    (NaN, ``floor``) without finite values."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    if x.size == 0:
        return float("nan"), float(floor)
    lo, hi = np.quantile(x, CLEAN_QUANTILES)
    scale = (hi - lo) / (_CLEAN_Z[1] - _CLEAN_Z[0])
    return float(hi - _CLEAN_Z[1] * scale), max(float(scale), float(floor))


def runs(mask):
    """(start, stop) of each run of True in ``mask`` (stop exclusive)."""
    edges = np.flatnonzero(np.diff(np.r_[0, np.asarray(mask).astype(np.int8), 0]))
    return list(zip(edges[::2], edges[1::2]))


def extrapolate(t, u, v, at):
    """The point at time ``at`` carried on from the points ``(u, v)`` at times ``t``
    (ascending, the nearest last): a quadratic in time through them where there are
    three or more over at least two frames, a line through the last two, else the last."""
    t = np.asarray(t, float)
    u, v = np.asarray(u, float), np.asarray(v, float)
    if t.size >= 3 and t[-1] - t[0] >= 2:
        # (u and v fitted in one call, as two columns: the same coefficients bit for
        # bit as one call each, for half the cost; this runs for every frame a chain
        # is grown by)
        pu, pv = np.polyval(np.polyfit(t - t[-1], np.column_stack([u, v]), 2), at - t[-1])
        return float(pu), float(pv)
    if t.size >= 2:
        r = (at - t[-1]) / (t[-1] - t[-2])
        return float(u[-1] + r * (u[-1] - u[-2])), float(v[-1] + r * (v[-1] - v[-2]))
    return float(u[-1]), float(v[-1])


def local_quadratic(t, y, window, *, leave_out=True, weights=None, leverage=False,
                    ahead=False):
    """Each point's value predicted by a quadratic through its neighbours.

    Parameters
    ----------
    t : (N,) array
        Times (any unit; frames here), increasing.
    y : (N,) or (N, D) array
        Values at those times.
    window : int
        Neighbours within ``window`` positions either side are used.
    leave_out : bool, keyword-only
        Leave the point itself out of its own fit (a prediction, for outlier tests).
    weights : (N,) array, optional
        Weights of the points as neighbours (0 leaves a point out of every fit).
    ahead : bool, keyword-only
        Use the point and the ``2 * window`` points after it only (a fit that sees
        nothing before the point: where the path changes at a frame, the frames after
        it are fitted from that side alone).
    leverage : bool, keyword-only
        Also return each prediction's variance in units of one point's variance
        (``h``: ``(A^-1)[0, 0]`` of the fit's normal matrix with unit weights): a point
        predicted from neighbours on one side only (the ends of a path) is predicted
        less well, and a test of its residual divides by ``sqrt(1 + h)``.

    Returns
    -------
    pred : (N,) or (N, D) array
        The fit's value at each point's time; NaN where fewer than 3 neighbours (or 2,
        giving a line) are there.
    acc : (N,) or (N, D) array
        Twice the quadratic coefficient: the acceleration (units of y per time^2);
        0 where a line was fitted, NaN where nothing was.
    h, ha : (N,) arrays
        With ``leverage``: the prediction's and the acceleration's variance factors
        (NaN where none; the acceleration's NaN where a line was fitted).
    """
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    one = y.ndim == 1
    y2 = y[:, None] if one else y
    n = t.size
    w = np.ones(n) if weights is None else np.asarray(weights, float)
    offs = np.arange(0, 2 * window + 1) if ahead else np.arange(-window, window + 1)
    if leave_out:
        offs = offs[offs != 0]
    j = np.arange(n)[:, None] + offs[None, :]
    inside = (j >= 0) & (j < n)
    jc = np.clip(j, 0, n - 1)
    m = inside * w[jc]
    dt = t[jc] - t[:, None]
    s = [np.sum(m * dt ** k, axis=1) for k in range(5)]
    a = np.stack([np.stack([s[0], s[1], s[2]], -1), np.stack([s[1], s[2], s[3]], -1),
                  np.stack([s[2], s[3], s[4]], -1)], -2)
    count = np.sum(m > 0, axis=1)
    pred = np.full(y2.shape, np.nan)
    acc = np.full(y2.shape, np.nan)
    hvar = np.full(n, np.nan)
    avar = np.full(n, np.nan)
    yj = y2[jc]
    b = np.stack([np.sum((m * dt ** k)[..., None] * yj, axis=1) for k in range(3)], 1)
    quad = count >= 3
    if quad.any():
        det = np.linalg.det(a[quad])
        ok = np.abs(det) > 1e-12 * np.maximum(s[4][quad] * s[0][quad] * s[2][quad], 1e-300)
        idx = np.flatnonzero(quad)[ok]
        if idx.size:
            coef = np.linalg.solve(a[idx], b[idx])
            pred[idx] = coef[:, 0]
            acc[idx] = 2.0 * coef[:, 2]
            if leverage:
                e0 = np.zeros((idx.size, 3, 2))
                e0[:, 0, 0] = 1.0
                e0[:, 2, 1] = 1.0
                inv = np.linalg.solve(a[idx], e0)
                hvar[idx] = inv[:, 0, 0]
                avar[idx] = 4.0 * inv[:, 2, 1]
    line = (count == 2) | (quad & ~np.isfinite(pred[:, 0]))
    if line.any():
        a2 = a[line][:, :2, :2]
        det = np.linalg.det(a2)
        ok = np.abs(det) > 1e-12
        idx = np.flatnonzero(line)[ok]
        if idx.size:
            coef = np.linalg.solve(a2[ok], b[idx][:, :2])
            pred[idx] = coef[:, 0]
            acc[idx] = 0.0
            if leverage:
                e0 = np.zeros((idx.size, 2, 1))
                e0[:, 0, 0] = 1.0
                hvar[idx] = np.linalg.solve(a2[ok], e0)[:, 0, 0]
    out = (pred[:, 0], acc[:, 0]) if one else (pred, acc)
    return out + (hvar, avar) if leverage else out


def neighbour_median(x, window):
    """Each value's neighbours' median within ``window`` positions either side, itself
    left out (its own value where it has none)."""
    n = x.size
    pad = np.concatenate([np.full(window, np.nan), x, np.full(window, np.nan)])
    wins = np.lib.stride_tricks.sliding_window_view(pad, 2 * window + 1).copy()
    wins[:, window] = np.nan
    with warnings.catch_warnings():
        # (a frame with no neighbour: all-NaN window, its own value kept)
        warnings.simplefilter("ignore", RuntimeWarning)
        med = np.nanmedian(wins, axis=1)
    return np.where(np.isfinite(med), med, x) if n else med


#: :func:`robust_trend` reweighs the neighbours this many times.
TREND_ROUNDS = 3


def robust_trend(t, y, window):
    """Each point's value by :func:`local_quadratic` through its neighbours (leaving it
    out), the neighbours weighed by Tukey's biweight (:data:`TUKEY` robust sigmas) of
    their residuals, :data:`TREND_ROUNDS` times, the first from their neighbours' median
    (:func:`neighbour_median`): a run of gross errors where it is the smaller part of a
    window, even at the end of the series, has no say in its neighbours' values.

    Parameters
    ----------
    t : (N,) array
        Times, increasing.
    y : (N,) or (N, D) array
        Values; the weights follow the first column's residuals.
    window : int
        Neighbours within ``window`` positions either side.

    Returns
    -------
    (N,) or (N, D) array
        The values predicted (NaN where too few neighbours).
    """
    y = np.asarray(y, float)
    first = y if y.ndim == 1 else y[:, 0]
    def residual(fit):
        return first - (fit if fit.ndim == 1 else fit[:, 0])

    return _reweighed(t, y, window, neighbour_median(first, window), residual,
                      lambda r: robust_scale(r, floor=1e-12))[0]


def _reweighed(t, y, window, fit, residual, scale, rounds=TREND_ROUNDS, settle=None):
    """:func:`local_quadratic` through each point's neighbours weighed by Tukey's
    biweight of ``residual(fit)`` over ``scale(residuals)``, ``rounds`` times (or until
    no weight changes by more than ``settle``) from the first ``fit`` given. Returns
    (fit, the last weights' scale)."""
    sigma, before = float("nan"), None
    for _ in range(rounds):
        r = residual(fit)
        sigma = scale(r)
        weights = np.where(np.isfinite(r),
                           np.clip(1.0 - (r / (TUKEY * sigma)) ** 2, 0.0, None) ** 2, 0.0)
        if settle is not None and before is not None and np.max(np.abs(weights - before),
                                                                initial=0.0) <= settle:
            break
        before = weights
        fit, _ = local_quadratic(t, y, window, weights=weights)
    return fit, sigma


#: :func:`robust_path` reweighs its points until no weight changes by more than
#: :data:`PATH_SETTLE`, at most :data:`PATH_ROUNDS` times: a run of points on something
#: else 4 px beside the path, a third of the window long, pulls its first fit (from the
#: neighbours' median) half way to it, and six rounds free it.
PATH_ROUNDS = 12
PATH_SETTLE = 1e-3


def robust_path(t, uv, window, *, floor):
    """Each point of a 2-D path predicted by :func:`local_quadratic` through its
    neighbours (leaving it out), weighed by Tukey's biweight (:data:`TUKEY` scatters)
    of their distances from it, :data:`TREND_ROUNDS` times from their neighbours'
    median, until the weights settle (:data:`PATH_ROUNDS`, :data:`PATH_SETTLE`): a run
    of points on something else (a chain that went over to a thing beside the object
    for a while and came back), where it is the smaller part of a window, has no say in
    the path. The scatter is the distances' median over 1.1774 (a 2-D normal law's), at
    least ``floor`` (px): the model's own misfit over a long window is not taken for an
    error.

    Returns
    -------
    (numpy.ndarray, float)
        The (N, 2) points predicted (NaN where too few neighbours), and the scatter.
    """
    uv = np.asarray(uv, float)

    def scale(r):
        r = r[np.isfinite(r)]
        return max(float(np.median(r)) / RAYLEIGH_MEDIAN if r.size else 0.0, float(floor))

    start = np.column_stack([neighbour_median(uv[:, 0], window),
                             neighbour_median(uv[:, 1], window)])
    return _reweighed(t, uv, window, start, lambda fit: np.hypot(*(uv - fit).T), scale,
                      rounds=PATH_ROUNDS, settle=PATH_SETTLE)
