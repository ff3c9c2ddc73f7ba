"""Step 5 of the flight tracker: every frame judged by statistics, with its reason.

Against the chain's own clean frames, two tests with one threshold, ``k_flag``:

- **path**: each frame's distance from the local quadratic path through its neighbours
  (:func:`vidtrack.track.path.local_quadratic`, ``path_window`` frames either side, the
  frame itself left out), studentized (over ``sqrt(1 + h)``, ``h`` the prediction's own
  variance factor: the ends of a path are predicted from one side), beyond ``k_flag``
  times their scatter (per axis: their median over 1.1774, as for a 2-D normal law;
  and beyond ``flag_floor_px``): OUTLIER;
- **appearance** (first: the path test starts from the frames that pass it): the log of
  each frame's size (pixels) and of its spreads along its major and minor axes (a
  part touching it far out, a blade, stretches them) against the median of its
  neighbours' within twice ``path_window`` frames; the log of its weight measured by
  its shape's fit (its coverage) short of its neighbours' within four times
  ``path_window`` (scatter at least ``weight_floor``: part of it hidden); and the share
  of its weight that the fit left out (:mod:`vidtrack.track.measure`) against the
  chain's, over its robust scatter (at least ``size_floor``): beyond ``k_flag``
  (grown or shrunk at a stroke: something touching, part hidden), APPEARANCE; so is a
  shadow-like detection (:mod:`vidtrack.track.detect`) in a chain that is not one.

A detection touching the frame's border is BORDER; frames inside the chain's span
without a detection are LOST.

The **release** (front views): on the rotor the straw's path bends far more sharply
than in flight. Every clean frame's local acceleration (a quadratic through it and the
``2 * path_window`` frames after it, so that no frame before it counts) is tested against the flight's (the median over the chain's second
half), in units of its own standard error (the path's scatter times the fit's variance
factor): the run of frames from the chain's start beyond ``k_flag`` of them is on the
rotor, and the first frame after it is the release; before it, PRE_RELEASE.
"""

import numpy as np

from vidtrack.track._flags import APPEARANCE, BORDER, LOST, OUTLIER, PRE_RELEASE
from vidtrack.track.choose import MAJORITY
from vidtrack.track.measure import residual_outliers
from vidtrack.track.path import local_quadratic, robust_scale

__all__ = ["judge", "REASONS"]

#: The median of the distance of a 2-D normal point from its centre, in its sigmas: a
#: distance's median over this is the per-axis scatter.
RAYLEIGH_MEDIAN = 1.1774100225154747

#: A short reason code per flag bit, for tracks.csv.
REASONS = {BORDER: "border", LOST: "lost", OUTLIER: "off-path", APPEARANCE: "appearance",
           PRE_RELEASE: "pre-release"}


def _path_outliers(idx, uv, settings, start):
    """Frames (positions in idx) off their neighbours' path, and the scatter (px);
    ``start``: the frames trusted at first (those of the object's own size)."""
    ok = start.copy()
    scatter = float("nan")
    for _ in range(5):
        pred, _acc, h, _ha = local_quadratic(idx, uv, settings.path_window,
                                             weights=ok.astype(float), leverage=True)
        # (the residual studentized: a point predicted from one side, at the ends,
        # is predicted less well)
        res = np.hypot(*(pred - uv).T) / np.sqrt(1.0 + np.where(np.isfinite(h), h, 0.0))
        scatter = float(np.median(res[ok & np.isfinite(res)])) / RAYLEIGH_MEDIAN if ok.any() \
            else float("nan")
        new = ~(res > max(settings.k_flag * scatter, settings.flag_floor_px))
        new &= np.isfinite(res) | (idx.size < 4)
        if np.array_equal(new, ok):
            break
        ok = new
    return ~ok, scatter


def _size_outliers(size, settings, window, floor=None, deficit_only=False):
    """Frames whose log size differs from their neighbours' median beyond ``k_flag``
    robust scatters of those differences (at least ``floor``, default ``size_floor``)."""
    logs = np.log(np.maximum(size, 1e-9))
    n = logs.size
    med = np.empty(n)
    for i in range(n):
        lo, hi = max(0, i - window), min(n, i + window + 1)
        nb = np.r_[logs[lo:i], logs[i + 1:hi]]
        med[i] = np.median(nb) if nb.size else logs[i]
    dev = logs - med
    scale = robust_scale(dev, floor=settings.size_floor if floor is None else floor)
    if deficit_only:
        return -dev > settings.k_flag * scale
    return np.abs(dev) > settings.k_flag * scale


def _release(idx, uv, settings, scatter):
    """Position (in idx) of the first frame of free flight: after the run of frames at
    the chain's start whose local acceleration differs from the flight's by more than
    ``k_flag`` of its own standard error (``scatter`` times the fit's variance factor);
    0 when the chain starts in flight."""
    if idx.size < 4 * settings.path_window or not np.isfinite(scatter) or scatter <= 0:
        return 0
    # each frame's acceleration from it and the frames after it: the frames on the
    # rotor bend it, those after the release do not
    _pred, acc, _h, ha = local_quadratic(idx, uv, settings.path_window, leave_out=False,
                                         leverage=True, ahead=True)
    ref = np.nanmedian(acc[idx.size // 2:], axis=0)
    err = scatter * np.sqrt(np.where(np.isfinite(ha) & (ha > 0), ha, np.inf))
    z = np.hypot(*(acc - ref).T) / err
    sharp = np.where(np.isfinite(z), z > settings.k_flag, False)
    if not sharp[:3].any():
        return 0
    # the run of sharp frames from the start (a frame or two of noise inside it allowed)
    end = int(np.flatnonzero(sharp[:3])[0])
    for k in range(end + 1, idx.size // 2):
        if sharp[k]:
            end = k
        elif k - end > 2:
            break
    return int(min(end + 1, idx.size - 1))


def judge(chain, detections, n, settings, *, find_release=True, residual=None,
          weight=None):
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
    if weight is not None:
        # the object's measured weight (its coverage inside its kernel) short of its
        # neighbours': part of it hidden (more than its own is the residual's test)
        grown |= _size_outliers(np.maximum(weight[idx], 1e-3), settings,
                                4 * settings.path_window, floor=settings.weight_floor,
                                deficit_only=True)
    for measure in (chain.size, chain.major, chain.minor):
        grown |= _size_outliers(np.maximum(measure[idx], 0.3), settings,
                                2 * settings.path_window)
    flags[idx[grown]] |= APPEARANCE
    off, scatter = _path_outliers(idx, uv, settings, ~grown)
    flags[idx[off]] |= OUTLIER
    if find_release:
        good = ~off & ~grown
        on = idx[good]
        start = _release(on, uv[good], settings, scatter)
        if start > 0:
            release = int(on[start])
            flags[idx[idx < release]] |= PRE_RELEASE
            notes.append(f"release: the path's sharp bend ends at frame position {release}")
    if chain.shadow[idx].mean() <= MAJORITY:
        flags[idx[chain.shadow[idx]]] |= APPEARANCE
    first, last = idx[0], idx[-1]
    flags[:first] = LOST
    flags[last + 1:] = LOST
    return flags, release, scatter, notes
