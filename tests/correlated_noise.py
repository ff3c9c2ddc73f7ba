"""Errors of known correlation for the tests of fits.errmodel and fits.lsq."""

import numpy as np


def ou_series(rng, n, ell_steps):
    """Unit-variance exponentially correlated series, correlation time ``ell_steps``
    samples (exact AR(1) sampling)."""
    phi = np.exp(-1.0 / ell_steps)
    e = np.empty(n)
    e[0] = rng.standard_normal()
    xi = rng.standard_normal(n) * np.sqrt(1 - phi * phi)
    for i in range(1, n):
        e[i] = phi * e[i - 1] + xi[i]
    return e
