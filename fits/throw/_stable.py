"""Ratio functions that stay accurate where their naive forms cancel or divide by zero.

Each takes a float64 array and returns one of the same shape. Near the removable
singularity a short Taylor series is used (truncation error below 1e-17 relative at the
switch point); elsewhere the direct library form (log1p, expm1, ...) is exact to a few
ulp. These are what make the throw models right as Cp -> 0 and as k * t grows.
"""

import numpy as np


def _where_small(x, limit, series, direct):
    """Evaluate ``series`` where |x| < limit and ``direct`` elsewhere, without warnings."""
    x = np.asarray(x, dtype=float)
    small = np.abs(x) < limit
    if not small.any():
        with np.errstate(over="ignore"):     # sinh/x -> inf only where the caller discards it
            return direct(x)
    out = np.empty_like(x)
    out[small] = series(x[small])
    big = ~small
    out[big] = direct(x[big])
    return out


def log1p_ratio(e):
    """``log1p(e) / e`` for e > -1, equal to 1 at e = 0."""
    return _where_small(e, 1e-4,
                        lambda e: 1.0 + e * (-0.5 + e * (1.0 / 3.0 + e * (-0.25 + e / 5.0))),
                        lambda e: np.log1p(e) / e)


def log1p_ratio_m1(e):
    """``log1p(e) / e - 1`` for e > -1, without the cancellation near e = 0."""
    return _where_small(e, 1e-3,
                        lambda e: e * (-0.5 + e * (1.0 / 3.0 + e * (-0.25 + e * (0.2 + e * (
                            -1.0 / 6.0 + e / 7.0))))),
                        lambda e: (np.log1p(e) - e) / e)


def sinc(x):
    """``sin(x) / x``, equal to 1 at x = 0 (unnormalised sinc)."""
    return _where_small(x, 1e-4, lambda x: 1.0 - x * x / 6.0 * (1.0 - x * x / 20.0),
                        lambda x: np.sin(x) / x)


def sinhc(x):
    """``sinh(x) / x``, equal to 1 at x = 0."""
    return _where_small(x, 1e-4, lambda x: 1.0 + x * x / 6.0 * (1.0 + x * x / 20.0),
                        lambda x: np.sinh(x) / x)


def tanhc(x):
    """``tanh(x) / x``, equal to 1 at x = 0."""
    return _where_small(x, 1e-4, lambda x: 1.0 - x * x / 3.0 * (1.0 - 0.4 * x * x),
                        lambda x: np.tanh(x) / x)


def tanc(x):
    """``tan(x) / x`` for |x| < pi/2, equal to 1 at x = 0."""
    return _where_small(x, 1e-4, lambda x: 1.0 + x * x / 3.0 * (1.0 + 0.4 * x * x),
                        lambda x: np.tan(x) / x)


def atanc(x):
    """``arctan(x) / x``, equal to 1 at x = 0."""
    return _where_small(x, 1e-4, lambda x: 1.0 - x * x / 3.0 * (1.0 - 0.6 * x * x),
                        lambda x: np.arctan(x) / x)


def expm1_ratio(z):
    """phi1(z) = ``expm1(z) / z``, equal to 1 at z = 0."""
    return _where_small(z, 1e-5, lambda z: 1.0 + z / 2.0 * (1.0 + z / 3.0 * (1.0 + z / 4.0)),
                        lambda z: np.expm1(z) / z)


def expm1_ratio2(z):
    """phi2(z) = ``(exp(z) - 1 - z) / z**2``, equal to 1/2 at z = 0."""
    return _where_small(z, 1e-3,
                        lambda z: 0.5 + z * (1.0 / 6.0 + z * (1.0 / 24.0 + z * (
                            1.0 / 120.0 + z / 720.0))),
                        lambda z: (np.expm1(z) - z) / (z * z))
