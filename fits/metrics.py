"""Field measures of straw handling from the source papers.

- recovery rate and uncleanness of the straw recovery device (Chen 2018, section 5,
  eqs. 23 and 24 of that section; Table 4),
- winding mass, coverage uniformity and pickup rate of the mulching device (Liao 2021,
  eqs. 20, 21 and 22; Tables 2 and 3),
- mulching uniformity lambda of the slip-cutting blade (Hou 2019, eq. 24).

Masses are in kg (any one unit works where only ratios enter); rates are in percent.
Every function takes scalars or arrays (broadcast elementwise) unless it reduces a set
of sample masses, and raises :class:`fits.errors.InputError` for negative masses, a
zero denominator or non-finite values.

Example
-------
>>> from fits.metrics import pickup_rate_pct
>>> round(float(pickup_rate_pct(8.62 + 8.14, 18.0)), 1)     # Liao 2021, Table 3, trial 1
93.1
"""

from dataclasses import dataclass

import numpy as np

from fits.errors import InputError

__all__ = ["TrialSummary", "coverage_uniformity_pct", "mulching_uniformity",
           "pickup_rate_pct", "recovery_rate_pct", "summarize_trials", "uncleanness_pct",
           "winding_mass_kg"]


def _masses(name, value, *, allow_zero=True):
    a = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name} must be finite, got {value!r}")
    if np.any(a < 0) or (not allow_zero and np.any(a == 0)):
        raise InputError(f"{name} must be {'>= 0' if allow_zero else '> 0'} kg, "
                         f"got {value!r}")
    return a


def _out(a):
    return float(a) if np.ndim(a) == 0 else a


def recovery_rate_pct(recovered_kg, unrecovered_kg):
    """Straw recovery rate S = G_k / (G_k + G_j) x 100 % (Chen 2018, eq. 23, section 5).

    Parameters
    ----------
    recovered_kg : float or array
        G_k, straw recovered by the device, kg.
    unrecovered_kg : float or array
        G_j, straw left unrecovered in the test section, kg.

    Returns
    -------
    float or ndarray, percent.

    Raises
    ------
    InputError
        A negative or non-finite mass, or no straw at all (G_k + G_j = 0).
    """
    gk = _masses("recovered_kg", recovered_kg)
    gj = _masses("unrecovered_kg", unrecovered_kg)
    total = gk + gj
    if np.any(total == 0):
        raise InputError("recovery rate: recovered + unrecovered straw is 0 kg; the rate "
                         "is not defined")
    return _out(100.0 * gk / total)


def uncleanness_pct(impurity_kg, recovered_kg):
    """Uncleanness S_b = G_b / G_k x 100 % (Chen 2018, eq. 24, section 5).

    Parameters
    ----------
    impurity_kg : float or array
        G_b, mass of foreign matter (soil, stones) in the recovered material, kg.
    recovered_kg : float or array
        G_k, recovered straw, kg (> 0).
    """
    gb = _masses("impurity_kg", impurity_kg)
    gk = _masses("recovered_kg", recovered_kg, allow_zero=False)
    return _out(100.0 * gb / gk)


def winding_mass_kg(fed_kg, thrown_kg):
    """Straw wound on the conveyor W0 = W1 - W2 (Liao 2021, eq. 20).

    Parameters
    ----------
    fed_kg : float or array
        W1, total straw fed in, kg.
    thrown_kg : float or array
        W2, straw thrown out onto the sheet, kg (<= W1).
    """
    w1 = _masses("fed_kg", fed_kg)
    w2 = _masses("thrown_kg", thrown_kg)
    if np.any(w2 > w1 * (1 + 1e-12)):
        raise InputError(f"winding mass: more straw thrown out ({thrown_kg!r} kg) than fed "
                         f"in ({fed_kg!r} kg)")
    return _out(w1 - w2)


def pickup_rate_pct(picked_kg, total_kg):
    """Pickup rate S_j = W4 / W3 x 100 % (Liao 2021, eq. 22).

    Parameters
    ----------
    picked_kg : float or array
        W4, straw picked up (in Table 3 the left plus the right side), kg.
    total_kg : float or array
        W3, straw laid in the test area, kg (> 0).
    """
    w4 = _masses("picked_kg", picked_kg)
    w3 = _masses("total_kg", total_kg, allow_zero=False)
    return _out(100.0 * w4 / w3)


def coverage_uniformity_pct(masses_kg):
    """Coverage uniformity F_b = (1 - (m_max - m_min) / m_mean) x 100 % (Liao 2021, eq. 21).

    Parameters
    ----------
    masses_kg : array, shape (..., n)
        Straw mass in each of the n equal strips across the sheet (Liao: 4 strips of
        500 mm), along the last axis; n >= 2.

    Returns
    -------
    float or ndarray, percent: 100 for a perfectly even cover; it becomes negative when
    the spread exceeds the mean (eq. 21 as printed has no lower bound).
    """
    m = _masses("masses_kg", masses_kg)
    if m.ndim == 0 or m.shape[-1] < 2:
        raise InputError(f"coverage uniformity needs at least 2 strip masses, got {masses_kg!r}")
    mean = m.mean(axis=-1)
    if np.any(mean == 0):
        raise InputError("coverage uniformity: no straw on the sheet (mean mass 0 kg)")
    return _out(100.0 * (1.0 - (m.max(axis=-1) - m.min(axis=-1)) / mean))


def mulching_uniformity(masses_kg):
    """Mulching uniformity lambda = sum (m_i - m_mean)^2 / (n m_mean^2) (Hou 2019, eq. 24).

    Parameters
    ----------
    masses_kg : array, shape (..., n)
        Straw mass per unit area at n sample points (Hou: 10), along the last axis.

    Returns
    -------
    float or ndarray, dimensionless: the squared coefficient of variation (population
    variance over the squared mean); 0 for a perfectly even cover; Hou 2019 counts
    lambda < 0.1 as acceptable.
    """
    m = _masses("masses_kg", masses_kg)
    if m.ndim == 0 or m.shape[-1] < 2:
        raise InputError(f"mulching uniformity needs at least 2 sample masses, got {masses_kg!r}")
    mean = m.mean(axis=-1)
    if np.any(mean == 0):
        raise InputError("mulching uniformity: no straw at any sample point (mean mass 0)")
    dev = m - mean[..., None]
    return _out(np.sum(dev * dev, axis=-1) / (m.shape[-1] * mean * mean))


@dataclass(frozen=True)
class TrialSummary:
    """Mean, sample standard deviation, extremes and count of repeated field trials."""

    mean: float
    std: float | None
    min: float
    max: float
    n: int

    def to_dict(self):
        """JSON-ready dict."""
        return {"mean": self.mean, "std": self.std, "min": self.min, "max": self.max,
                "n": self.n}


def summarize_trials(values):
    """Summary of repeated trials (Chen 2018, Table 4: the mean of 5 test sections).

    Parameters
    ----------
    values : 1-D array
        One result per trial (e.g. recovery rate of each section, %).

    Returns
    -------
    TrialSummary
        ``std`` is the sample standard deviation (ddof = 1), None for a single trial.
    """
    v = np.asarray(values, dtype=float).ravel()
    if v.size == 0 or not np.all(np.isfinite(v)):
        raise InputError(f"trial values must be a non-empty list of finite numbers, "
                         f"got {values!r}")
    return TrialSummary(mean=float(v.mean()),
                        std=float(v.std(ddof=1)) if v.size > 1 else None,
                        min=float(v.min()), max=float(v.max()), n=int(v.size))
