"""Chen et al. 2018 eqs. 12, 14, 16 and 18 evaluated exactly as printed.

Kept for comparison only (tests and ``vidtrack bench model``): these forms are valid for
the paper's own case (cp > 0, vy0 > 0, vx0 > 0, vz0 = v1) and, even there, overflow
on long descents (eq. 14: ``exp(2 k2 g cp (t - t1))``) and lose all accuracy as
cp -> 0 (eq. 14's two terms of order 1/cp^2 and 1/cp cancel). Use ``fits.throw``.
"""

import numpy as np

__all__ = ["printed_position"]


def printed_position(t, state, k, cp, *, g=9.80665):
    """Positions (N, 3) by eqs. 12, 14, 16, 18 as printed, in plain float64.

    The apex (t1, y1) is taken from eq. 12 as the paper does (t1 = atan(cp vy0) /
    (k1 cp g), y1 = eq. 12 at t1). Eq. 18 subtracts ``vz0 t`` (the paper's vz0 = v1);
    z0 is added. Overflow and 0/0 are returned as inf and nan, as a user of the printed
    form would get them.
    """
    t = np.asarray(t, dtype=float)
    x0, y0, z0, vx0, vy0, vz0 = map(float, state)
    k1, k2, k3, k4 = map(float, k)
    with np.errstate(all="ignore"):
        x = np.log(np.abs(k3 * cp**2 * g * vx0 * t + 1)) / (k3 * cp**2 * g) + x0
        t1 = np.arctan(cp * vy0) / (k1 * cp * g)

        def eq12(tt):
            return (np.log(cp * vy0 * np.sin(k1 * cp * g * tt) + np.cos(k1 * cp * g * tt))
                    / (g * k1 * cp**2) + y0)

        y1 = eq12(t1)
        eq14 = (1.0 / (cp**2 * k2 * g) * np.log(2.0 / (np.exp(2 * k2 * g * cp * (t - t1)) + 1))
                + (t - t1) / cp + y1)
        y = np.where(t <= t1, eq12(t), eq14)
        z = np.log(np.abs(k4 * cp**2 * g * vz0 * t + 1)) / (k4 * cp**2 * g) - vz0 * t + z0
    return np.column_stack([x, y, z])
