"""An object at rest where the background was taken leaves a ghost when it goes.

The background is the median of frames from the first part of the footage. An object
resting in view over most of them (a ball held before it is dropped, footage that
starts long before the release) is part of it: when it leaves, the place it left shows
the wall, unlike the background, a still "object" of the other polarity. A pass that
took the object while it was coming out of its ghost may stay with the ghost (still,
of about its size, where the prediction of a slow start says), and its track is then
the ghost's place, tens of pixels from the object, unflagged.

:func:`ghost_place` finds that case after a pass: a run of clean frames in which the
followed thing does not move, at a place where the background from the last part of
the footage (:func:`tail_background`) differs from the first part's. The tracker then
tracks the view again against the last part's background
(:func:`vidtrack.track.tracker.track_parts`).

Internal to the tracker.
"""

import numpy as np

from vidtrack.track.background import sample_background

#: A run of at least this many consecutive clean frames ...
STILL_FRAMES = 20
#: ... whose points stay within this distance (px) of their median is still.
STILL_PX = 1.0
#: The last part of the footage the second background is taken from (its share).
TAIL_SHARE = 0.4


def still_run(ps):
    """``(first, last, u, v)`` of the longest run of consecutive clean frames of the pass
    ``ps`` whose points stay within ``STILL_PX`` of their median, at least
    ``STILL_FRAMES`` long; None where there is none."""
    ok = ps.clean & np.isfinite(ps.u) & np.isfinite(ps.v)
    best = None
    i, n = 0, ps.n
    while i < n:
        if not ok[i]:
            i += 1
            continue
        j = i
        while j + 1 < n and ok[j + 1]:
            j += 1
        # within the clean run [i, j]: the longest still stretch, grown greedily
        k = i
        while k <= j:
            m = k
            while m + 1 <= j and np.hypot(ps.u[m + 1] - ps.u[k], ps.v[m + 1] - ps.v[k]) \
                    <= STILL_PX:
                m += 1
            if m - k + 1 >= STILL_FRAMES and (best is None or m - k > best[1] - best[0]):
                best = (k, m)
            k = m + 1
        i = j + 1
    if best is None:
        return None
    k, m = best
    return k, m, float(np.median(ps.u[k:m + 1])), float(np.median(ps.v[k:m + 1]))


def tail_background(source, *, samples=25):
    """Background of the last ``TAIL_SHARE`` of ``source``'s frames (random access);
    None where that part is shorter than ``samples``."""
    n = len(source)
    first = int(n * (1.0 - TAIL_SHARE))
    if n - first < samples:
        return None
    return sample_background(source, samples=samples, first=first)


def differs_at(first, last, u, v, radius, *, k_sigma):
    """Whether the two backgrounds differ over most of the disc of ``radius`` (px) about
    ``(u, v)``: by more than the detection threshold of the first there."""
    rows, cols = first.shape
    r = int(np.ceil(radius))
    x0, x1 = max(0, int(u) - r), min(cols, int(u) + r + 2)
    y0, y1 = max(0, int(v) - r), min(rows, int(v) + r + 2)
    if x1 <= x0 or y1 <= y0:
        return False
    yy, xx = np.mgrid[y0:y1, x0:x1]
    disc = (xx - u) ** 2 + (yy - v) ** 2 <= radius * radius
    if not disc.any():
        return False
    diff = np.abs(first.image[y0:y1, x0:x1] - last.image[y0:y1, x0:x1])
    thr = first.threshold(k=k_sigma)[y0:y1, x0:x1]
    return float(np.mean(diff[disc] > thr[disc])) >= 0.5


def moved_over(ps, first, last, radius):
    """Whether the object of pass ``ps`` travelled more than ``radius`` (and 3 px) over
    its clean frames ``first..last`` (what the first pass followed there stayed within
    ``STILL_PX``)."""
    idx = np.flatnonzero(ps.clean[first:last + 1] & np.isfinite(ps.u[first:last + 1])) + first
    if idx.size < 3:
        return False
    return float(np.hypot(ps.u[idx[-1]] - ps.u[idx[0]], ps.v[idx[-1]] - ps.v[idx[0]])) \
        > max(radius, 3.0 * STILL_PX)
