"""fits.errmodel against errors of known structure: white, correlated, long tracks.

The truth is the simulation: errors drawn from a known process added to a known line or
parabola; the covariance the module gives must match the spread of the least-squares
estimates over many draws (coverage of 95 % intervals), where the white-noise formula
visibly fails.
"""

import numpy as np
import pytest

from correlated_noise import ou_series
from fits.errmodel import ErrorModel, fit_error_model


def _coverage(rng, *, n, reps, f, ell_steps, sigma=1e-3):
    """Coverage of the curvature's 95 % interval: this module and the white formula."""
    t = np.arange(n) / 1200.0
    jac = np.column_stack([np.ones(n), t, t * t])
    truth = np.array([0.1, 2.0, -5.0])
    hit_model = hit_white = 0
    for _ in range(reps):
        e = sigma * (np.sqrt(1 - f) * rng.standard_normal(n)
                     + np.sqrt(f) * ou_series(rng, n, ell_steps))
        y = jac @ truth + e
        beta, *_ = np.linalg.lstsq(jac, y, rcond=None)
        r = jac @ beta - y
        cov, _ = fit_error_model(t, jac, r)
        white = np.linalg.inv(jac.T @ jac) * (r @ r) / (n - 3)
        for c, name in ((cov, "model"), (white, "white")):
            ok = abs(beta[2] - truth[2]) <= 1.97 * np.sqrt(c[2, 2])
            if name == "model":
                hit_model += ok
            else:
                hit_white += ok
    return hit_model / reps, hit_white / reps


def test_white_errors_give_the_least_squares_covariance():
    rng = np.random.default_rng(1)
    model, white = _coverage(rng, n=150, reps=150, f=0.0, ell_steps=1.0)
    assert 0.90 <= model <= 0.99
    assert abs(model - white) <= 0.04


def test_correlated_errors_widen_the_intervals_to_their_true_spread():
    rng = np.random.default_rng(2)
    model, white = _coverage(rng, n=150, reps=150, f=0.7, ell_steps=12.0)
    assert white < 0.75                      # the white formula is far too narrow here
    assert model >= 0.88


def test_the_model_recovers_the_correlated_fraction_and_time():
    rng = np.random.default_rng(3)
    n, f, ell = 400, 0.6, 10.0
    t = np.arange(n) / 1200.0
    jac = np.column_stack([np.ones(n), t])
    fs, ells = [], []
    for _ in range(10):
        e = np.sqrt(1 - f) * rng.standard_normal(n) + np.sqrt(f) * ou_series(rng, n, ell)
        beta, *_ = np.linalg.lstsq(jac, e, rcond=None)
        _, m = fit_error_model(t, jac, jac @ beta - e, max_points=n)
        fs.append(m.correlated_fraction)
        ells.append(m.correlation_time * 1200.0)
    assert np.median(fs) == pytest.approx(f, abs=0.15)
    assert np.median(ells) == pytest.approx(ell, rel=0.5)


def test_long_tracks_are_binned_and_keep_the_spread():
    """1200 points binned to 200: the standard error is not below the Monte Carlo
    spread of the slope. These errors are Markov (exponential), but 200 bins cannot
    tell that from long memory, so the wider long-memory intervals are used
    (LONG_MEMORY_SLACK): up to ~1.6 times the true spread, never narrower."""
    rng = np.random.default_rng(4)
    n, reps = 1200, 60
    t = np.arange(n) / 1200.0
    jac = np.column_stack([np.ones(n), t])
    slopes, ses = [], []
    for _ in range(reps):
        e = 0.5 * rng.standard_normal(n) + ou_series(rng, n, 40.0)
        beta, *_ = np.linalg.lstsq(jac, e, rcond=None)
        cov, m = fit_error_model(t, jac, jac @ beta - e, max_points=200)
        slopes.append(beta[1])
        ses.append(np.sqrt(cov[1, 1]))
    assert m.bin_size == 6 and m.points == 200
    ratio = np.median(ses) / np.std(slopes)
    assert 0.85 <= ratio <= 1.8


def test_too_few_points_are_taken_as_white():
    t = np.arange(5.0)
    jac = np.column_stack([np.ones(5), t, t * t])
    r = np.array([1.0, -1.0, 0.5, 0.2, -0.7])
    cov, m = fit_error_model(t, jac, r)
    assert m == ErrorModel(float(r @ r) / 2, 0.0, 0.0, 5)
    assert np.allclose(cov, np.linalg.inv(jac.T @ jac) * float(r @ r) / 2)
