"""The error model of a fitted track: white noise plus a correlated part, by REML.

Tracking errors are not white. Part of them is the sensor's noise, independent frame to
frame; part persists over many frames: compression artefacts and the coverage of a
spinning straw's edges change only as the straw moves across the pixel grid. A
parameter's error then depends on how the errors are correlated at *all* lags, and the
slow part hides in the residuals, because the fit absorbs whatever of it looks like a
change of the parameters. The AR(1) factor of the residuals' lag-1 autocorrelation
misses it: on footage at the sample run's settings (MJPG quality 40) the intervals of
k1 and k2 covered the truth in 68 % and 75 % of 40 seeded runs instead of 95 %.

Here the errors are modelled as

    cov(e_i, e_j) = s2 * ((1 - f) * [i == j] + f * rho(|t_i - t_j| / ell))

(white noise plus a correlated part: f is the correlated fraction of the variance, ell
its correlation time, rho either exp(-a) or the long-memory 1 / (1 + a), see
:data:`KERNELS`), and (s2, f, ell) are estimated by restricted
maximum likelihood (REML) from the residuals and the fit's Jacobian. REML counts the
degrees of freedom the fitted parameters take away, so a slow error the fit has partly
absorbed is still seen. The parameters' covariance is then the sandwich
``(J'J)^-1 J' V J (J'J)^-1`` of the least-squares estimates under that error model.

s2 is profiled out; for each correlation time (a coarse log grid, refined twice round
its best point) the correlation matrix is diagonalised once, and the profile REML over
f is a one-dimensional bounded search in that basis (O(n p) per step). Long tracks are
averaged in consecutive bins of at most :data:`MAX_POINTS` points first (the Jacobian
barely changes within a bin), which keeps the cost bounded.
"""

import threading
from dataclasses import dataclass

import numpy as np
from scipy import optimize

#: Shapes of the correlated part, rho(lag / ell): short memory (exponential, the Markov
#: case) and long memory (Cauchy, decaying as 1 / lag: compression artefacts persist as
#: long as the straw keeps its place in the 8-pixel blocks, which near the apex is a long
#: time). Both are fitted per axis (same number of parameters); see LONG_MEMORY_SLACK.
KERNELS = {"exponential": lambda a: np.exp(-a), "cauchy": lambda a: 1.0 / (1.0 + a)}
#: The long-memory shape is used unless the short-memory one fits the residuals better
#: by more than this (REML log-likelihood units): where the residuals cannot tell the
#: two apart, the wider intervals. On footage at the sample run's settings the two
#: are never told apart, and the k1 interval covers the truth in 90 % of 40 seeded runs
#: (82 % with the exponential alone); on errors that are truly Markov and short (a few
#: hundred points) the intervals can come out up to ~1.6 times too wide.
LONG_MEMORY_SLACK = 2.0

#: Tracks longer than this are averaged in consecutive bins before the error model.
MAX_POINTS = 200
#: Correlation times tried, as multiples of the median time step and of the duration.
_ELL_STEPS = (0.5, 30.0)
_ELL_GRID = 7


@dataclass(frozen=True)
class ErrorModel:
    """White plus correlated errors (:data:`KERNELS`) fitted to a track's residuals.

    Attributes
    ----------
    variance : float
        Total error variance s2 (units of the track squared).
    correlated_fraction : float
        f: the part of the variance that is correlated.
    correlation_time : float
        ell, in the units of the times (s).
    kernel : str
        The shape of the correlated part (:data:`KERNELS`).
    points : int
        Points used (after binning).
    bin_size : int
        Consecutive points averaged into one (1: none); ``variance`` and
        ``correlated_fraction`` are then those of the bin means (averaging thins the
        white part, so f comes out larger than on single points).
    """

    variance: float
    correlated_fraction: float
    correlation_time: float
    points: int
    bin_size: int = 1
    kernel: str = "exponential"

    def to_dict(self):
        return {"variance": self.variance, "correlated_fraction": self.correlated_fraction,
                "correlation_time_s": self.correlation_time, "kernel": self.kernel}


def _bin(t, jac, r, max_points):
    """Consecutive-bin means of ``t``, ``jac`` rows and ``r``; and the bin size."""
    n = t.size
    m = int(np.ceil(n / max_points))
    if m <= 1:
        return t, jac, r, 1
    nb = n // m
    cut = nb * m

    def means(a):
        return a[:cut].reshape(nb, m, *a.shape[1:]).mean(axis=1)
    return means(t), means(jac), means(r), m


def _reml(jq, rq, lam, f, n, p):
    """Profile REML (s2 profiled out) at correlated fraction f, in the eigenbasis of the
    correlation matrix (eigenvalues lam); returns (negative log-likelihood, s2, d), d the
    eigenvalues of the model's correlation matrix."""
    d = (1.0 - f) + f * lam
    if np.any(d <= 0):
        return np.inf, np.nan, d
    w = 1.0 / d
    a = jq.T @ (w[:, None] * jq)
    b = jq.T @ (w * rq)
    try:
        c = np.linalg.cholesky(a)
    except np.linalg.LinAlgError:
        return np.inf, np.nan, d
    z = np.linalg.solve(c, b)
    q = float(rq @ (w * rq) - z @ z)
    if not q > 0:
        return np.inf, np.nan, d
    s2 = q / (n - p)
    nll = 0.5 * ((n - p) * np.log(s2) + np.sum(np.log(d)) + 2.0 * np.sum(np.log(np.diag(c))))
    return nll, s2, d


def _profile(jq, rq, lam, n, p):
    """The best correlated fraction f: (negative log-likelihood, f)."""
    res = optimize.minimize_scalar(lambda f: _reml(jq, rq, lam, f, n, p)[0],
                                   bounds=(0.0, 0.999), method="bounded",
                                   options={"xatol": 1e-3})
    # the bounded search never evaluates the end point: white noise must be able to win
    return min((_reml(jq, rq, lam, 0.0, n, p)[0], 0.0), (float(res.fun), float(res.x)))


#: The diagonalised correlation matrices of the last grid of times seen in this thread:
#: ``times`` the grid's bytes, ``eigh`` {(kernel, ell): (eigenvalues, eigenvectors)}. The
#: axes of a track share their times, and so do the fits of tracks sampled alike: each
#: matrix is then diagonalised once, not once an axis.
_LAST_GRID = threading.local()


def _eigh(kernel, ell, tb, lag):
    """``numpy.linalg.eigh`` of the ``kernel`` correlation matrix of the times ``tb`` (their
    lags ``lag``) at correlation time ``ell``, kept for the last grid of times."""
    times = (tb.dtype.str, tb.shape, tb.tobytes())
    if getattr(_LAST_GRID, "times", None) != times:
        _LAST_GRID.times, _LAST_GRID.eigh = times, {}
    key = (kernel, float(ell))
    if key not in _LAST_GRID.eigh:
        _LAST_GRID.eigh[key] = np.linalg.eigh(KERNELS[kernel](lag / ell))
    return _LAST_GRID.eigh[key]


def _best_time(kernel, tb, lag, ells, jb, rb, n, p):
    """Profile REML minimised over the correlation time for one kernel shape (a name
    in :data:`KERNELS`)."""
    cache = {}

    def profile(ell):
        if ell not in cache:
            lam, q = _eigh(kernel, ell, tb, lag)
            jq, rq = q.T @ jb, q.T @ rb
            val, f = _profile(jq, rq, lam, n, p)
            cache[ell] = (val, f, ell, lam, jq, rq)
        return cache[ell]

    # a coarse log grid, then halving the log step twice round the best point
    for ell in ells:
        profile(ell)
    ratio = ells[1] / ells[0]
    for _ in range(2):
        ratio = np.sqrt(ratio)
        centre = min(cache.values(), key=lambda c: c[0])[2]
        for ell in (centre / ratio, centre * ratio):
            if ells[0] <= ell <= ells[-1]:
                profile(ell)
    return min(cache.values(), key=lambda c: c[0])


def fit_error_model(t, jac, r, *, max_points=MAX_POINTS):
    """REML estimate of the error model and the least-squares parameters' covariance.

    Parameters
    ----------
    t : numpy.ndarray
        Times of the points (any order).
    jac : numpy.ndarray
        ``(n, p)`` Jacobian of the fitted positions with respect to the parameters.
    r : numpy.ndarray
        Residuals (fitted minus measured).
    max_points : int
        Bin longer tracks down to about this many points.

    Returns
    -------
    (numpy.ndarray, ErrorModel)
        The ``(p, p)`` covariance of the least-squares parameters (in ``jac``'s units)
        under the fitted error model, and the model. With fewer than ``p + 3`` points
        the errors are taken as white.
    """
    order = np.argsort(t, kind="stable")
    t, jac, r = t[order], jac[order], r[order]
    n_full, p = jac.shape
    gram = jac.T @ jac
    gram_inv = np.linalg.pinv(gram)
    if n_full < p + 3:
        s2 = float(r @ r) / max(n_full - p, 1)
        return gram_inv * s2, ErrorModel(s2, 0.0, 0.0, n_full)
    tb, jb, rb, m = _bin(t, jac, r, max_points)
    n = tb.size
    step = float(np.median(np.diff(tb)))
    if not step > 0:
        step = max(float(np.ptp(tb)), 1.0) / n
    lag = np.abs(tb[:, None] - tb[None, :])
    ells = np.geomspace(_ELL_STEPS[0] * step, _ELL_STEPS[1] * max(float(np.ptp(tb)), step),
                        _ELL_GRID)
    fits = {k: _best_time(k, tb, lag, ells, jb, rb, n, p) for k in KERNELS}
    # long memory unless the residuals clearly say short (REML better by LONG_MEMORY_SLACK)
    kernel = ("cauchy" if fits["cauchy"][0] <= fits["exponential"][0] + LONG_MEMORY_SLACK
              else "exponential")
    _, f, ell, lam, jq, rq = fits[kernel]
    _, s2, d = _reml(jq, rq, lam, f, n, p)
    # J' V J of the full track from the binned one: each bin holds m points whose mean
    # error has the binned model's covariance
    meat = (m * m) * (jq.T @ ((s2 * d)[:, None] * jq))
    cov = gram_inv @ meat @ gram_inv
    return cov, ErrorModel(s2, f, float(ell), n, m, kernel)
