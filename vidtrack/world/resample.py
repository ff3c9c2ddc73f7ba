"""Resampling a track in time: linear interpolation that does not bridge gaps, and a
track's frame step. Shared by the two-view merge, the shared-X check and the attitude."""

import numpy as np

__all__ = ["interp_gapless", "frame_step"]


def interp_gapless(t_new, t, y, max_step):
    """Linear interpolation of y(t) at t_new, NaN outside [t0, t1] or across gaps."""
    out = np.full(np.shape(t_new), np.nan)
    if t.size < 2:
        return out
    inside = (t_new >= t[0]) & (t_new <= t[-1])
    tn = t_new[inside]
    k = np.searchsorted(t, tn)
    exact = t[k] == tn
    before = np.maximum(k - 1, 0)
    ta, tb = t[before], t[k]
    with np.errstate(divide="ignore", invalid="ignore"):   # only where exact (tb = ta)
        val = y[before] + (tn - ta) / (tb - ta) * (y[k] - y[before])
    ok = exact | ((tb - ta) <= max_step)
    out[inside] = np.where(ok, np.where(exact, y[k], val), np.nan)
    return out


def frame_step(track):
    """The median time between a track's frames (s; 1 where it has none)."""
    t = track.data["t_s"].to_numpy(dtype=np.float64)
    steps = np.diff(t)
    steps = steps[steps > 0]
    if not steps.size:
        return 1.0
    return float(np.median(steps))
