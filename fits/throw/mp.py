"""The quadratic-drag throw in arbitrary precision (mpmath): truth for benchmarks.

The textbook forms of the solution (Chen 2018 eqs. 12, 14, 16, 18, generalised to any
sign of the velocities and to the coth branch) evaluated with ``dps`` significant digits.
At 50 digits the cancellation that ruins them in float64 as cp -> 0 (terms of order
1/cp^2) still leaves over 30 correct digits for cp >= 1e-9 s/m, and nothing overflows.
This shares no code with ``fits.throw``.
"""

import mpmath as mp
import numpy as np

__all__ = ["position_mp"]


def _y(t, y0, vy0, a, d, c):
    if vy0 > 0:
        if c == 0:
            t1, y1 = vy0 / a, y0 + vy0**2 / (2 * a)
        else:
            t1 = mp.atan(c * vy0) / (a * c)
            y1 = y0 + mp.log(1 + c**2 * vy0**2) / (2 * a * c**2)
        if t <= t1:
            if c == 0:
                return y0 + vy0 * t - a * t**2 / 2
            s = a * c * t
            return y0 + mp.log(mp.cos(s) + c * vy0 * mp.sin(s)) / (a * c**2)
        tau, ya, speed = t - t1, y1, mp.mpf(0)
    else:
        tau, ya, speed = t, y0, -vy0
    if c == 0:
        return ya - speed * tau - d * tau**2 / 2
    u, w0 = d * c * tau, c * speed
    return ya - mp.log(mp.cosh(u) + w0 * mp.sinh(u)) / (d * c**2)


def _drag(t, x0, v0, b, frame_speed):
    if b == 0 or v0 == 0:
        return x0 + (v0 - frame_speed) * t
    s = 1 if v0 > 0 else -1
    return x0 + s * mp.log(1 + b * abs(v0) * t) / b - frame_speed * t


def position_mp(t, state, k, cp, *, g=9.80665, v1=0.0, dps=50):
    """Positions (N, 3) of the quadratic-drag throw, computed with ``dps`` digits.

    Arguments as ``fits.throw.position`` (quadratic model only); returns float64.
    """
    with mp.workdps(dps):
        x0, y0, z0, vx0, vy0, vz0 = (mp.mpf(float(v)) for v in state)
        k1, k2, k3, k4 = (mp.mpf(float(v)) for v in k)
        c, g, v1 = mp.mpf(float(cp)), mp.mpf(float(g)), mp.mpf(float(v1))
        out = np.empty((len(t), 3))
        for i, ti in enumerate(np.asarray(t, dtype=float)):
            ti = mp.mpf(float(ti))
            out[i] = (float(_drag(ti, x0, vx0, k3 * g * c**2, 0)),
                      float(_y(ti, y0, vy0, k1 * g, k2 * g, c)),
                      float(_drag(ti, z0, vz0, k4 * g * c**2, v1)))
    return out
