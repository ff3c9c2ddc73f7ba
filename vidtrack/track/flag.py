"""Step 5 of the flight tracker: every frame judged by statistics, with its reason.

Against the chain's own clean frames, two tests with one threshold, ``k_flag``:

- **path**: each frame's distance from the local quadratic path through its neighbours
  (:func:`vidtrack.track.path.local_quadratic`, ``path_window`` frames either side, the
  frame itself left out), beyond ``k_flag`` times the robust scatter of those distances
  (and beyond ``flag_floor_px``): OUTLIER;
- **appearance** (first: the path test starts from the frames that pass it): the log of
  each frame's size (pixels) and of its spreads along its major and minor axes (a
  part touching it far out, a blade, stretches them) against the median of its
  neighbours' within twice ``path_window`` frames, and the share of its weight that
  its shape's fit left out (:mod:`vidtrack.track.measure`) against the chain's, over its robust scatter (at least ``size_floor``): beyond ``k_flag``
  (grown or shrunk at a stroke: something touching, part hidden), APPEARANCE; so is a
  shadow-like detection (:mod:`vidtrack.track.detect`) in a chain that is not one.

A detection touching the frame's border is BORDER; frames inside the chain's span
without a detection are LOST.

The **release** (front views): on the rotor the straw's path bends far more sharply
than in flight. The local acceleration of every frame on the path is tested against the flight's
(the median over the chain's second half, its robust scatter): the frames at the start
of the chain whose acceleration lies beyond ``k_flag`` scatters are on the rotor, and
the first frame after the last of them is the release; before it, PRE_RELEASE.
"""

import numpy as np

from vidtrack.track._flags import APPEARANCE, BORDER, LOST, OUTLIER, PRE_RELEASE
from vidtrack.track.measure import residual_outliers
from vidtrack.track.path import local_quadratic, robust_scale

__all__ = ["judge", "REASONS"]

#: A short reason code per flag bit, for tracks.csv.
REASONS = {BORDER: "border", LOST: "lost", OUTLIER: "off-path", APPEARANCE: "appearance",
           PRE_RELEASE: "pre-release"}


def _path_outliers(idx, uv, settings, start):
    """Frames (positions in idx) off their neighbours' path, and the scatter (px);
    ``start``: the frames trusted at first (those of the object's own size)."""
    ok = start.copy()
    for _ in range(3):
        pred, _acc = local_quadratic(idx, uv, settings.path_window, weights=ok.astype(float))
        res = np.hypot(*(pred - uv).T)
        scatter = robust_scale(res[ok])
        new = ~(res > max(settings.k_flag * scatter, settings.flag_floor_px))
        new &= np.isfinite(res) | (idx.size < 4)
        if np.array_equal(new, ok):
            break
        ok = new
    return ~ok, scatter


def _size_outliers(size, settings, window):
    """Frames whose log size differs from their neighbours' median beyond the test."""
    logs = np.log(np.maximum(size, 1e-9))
    n = logs.size
    med = np.empty(n)
    for i in range(n):
        lo, hi = max(0, i - window), min(n, i + window + 1)
        nb = np.r_[logs[lo:i], logs[i + 1:hi]]
        med[i] = np.median(nb) if nb.size else logs[i]
    dev = logs - med
    scale = robust_scale(dev, floor=settings.size_floor)
    return np.abs(dev) > settings.k_flag * scale


def _release(idx, uv, settings):
    """Position (in idx) of the first frame of free flight: after the sharply bending
    start, if the chain has one; else 0."""
    if idx.size < 4 * settings.path_window:
        return 0
    _pred, acc = local_quadratic(idx, uv, settings.path_window, leave_out=False)
    a = np.hypot(*acc.T)
    half = a[idx.size // 2:]
    ref = float(np.nanmedian(half))
    scale = robust_scale(half, floor=0.05 * max(ref, 1e-3))
    sharp = a > ref + settings.k_flag * scale
    first_part = np.arange(idx.size) < idx.size // 2
    on = np.flatnonzero(sharp & first_part)
    if on.size == 0 or on[0] > settings.path_window:
        return 0
    # the run of sharp frames from the start (gaps of a few frames inside it allowed)
    end = on[0]
    for k in on[1:]:
        if k - end > settings.path_window:
            break
        end = k
    return int(min(end + settings.path_window // 2 + 1, idx.size - 1))


def judge(chain, detections, n, settings, *, find_release=True, residual=None):
    """Flags, reasons and the release of a chosen chain.

    Returns
    -------
    flags : numpy.ndarray of int
        Per frame position (LOST where the chain has no detection).
    release : int or None
        Frame position of the release, None when not looked for or not seen.
    scatter_px : float
        Robust scatter of the clean frames about their local path.
    notes : list of str
    """
    flags = np.full(n, LOST, np.int64)
    idx = chain.frames
    notes = []
    if idx.size == 0:
        return flags, None, float("nan"), notes
    flags[idx] = 0
    for i in idx:
        if detections[i][chain.pick[i]]["border"]:
            flags[i] |= BORDER
    uv = np.column_stack([chain.u[idx], chain.v[idx]])
    release = None
    grown = np.zeros(idx.size, bool)
    if residual is not None:
        grown |= residual_outliers(residual[idx], settings)
    for measure in (chain.size, chain.major, chain.minor):
        grown |= _size_outliers(np.maximum(measure[idx], 0.3), settings,
                                2 * settings.path_window)
    flags[idx[grown]] |= APPEARANCE
    off, scatter = _path_outliers(idx, uv, settings, ~grown)
    flags[idx[off]] |= OUTLIER
    if find_release:
        good = ~off & ~grown
        on = idx[good]
        start = _release(on, uv[good], settings)
        if start > 0:
            release = int(on[start])
            flags[idx[idx < release]] |= PRE_RELEASE
            notes.append(f"release: the path's sharp bend ends at frame position {release}")
    if chain.shadow[idx].mean() <= 0.5:
        flags[idx[chain.shadow[idx]]] |= APPEARANCE
    first, last = idx[0], idx[-1]
    flags[:first] = LOST
    flags[last + 1:] = LOST
    return flags, release, scatter, notes
