"""An object at rest where the background was taken leaves a ghost when it goes.

The background is the median of frames from the first part of the footage. An object
resting in view over most of them (a ball held before it is dropped, footage that
starts long before the release) is part of it: when it leaves, the place it left shows
the wall, unlike the background, a still "object" of the other polarity. A pass that
took the object while it was coming out of its ghost may stay with the ghost (still,
of about its size, where the prediction of a slow start says), and its track is then
the ghost's place, tens of pixels from the object, unflagged.

After a pass whose object started at rest or nearly (:func:`slow_start`) or stood
still for a while (:func:`still_run`), the background from the last part of the
footage (:func:`tail_background`) is compared with the first part's
(:func:`changed`); where the object lay over places where they differ, the view is
tracked again against the last part's, and that pass is taken where what the first
followed stood still there while the object moved in the second, or where the two
part and the second's object lies less over those places (:func:`tail_wins`)
(:func:`vidtrack.track.tracker.track_parts`). A thrown object pays nothing for it.

Internal to the tracker.
"""

import numpy as np

from vidtrack.track.background import sample_background

#: A run of at least this many consecutive clean frames ...
STILL_FRAMES = 20
#: ... whose points stay within this distance (px) of the first is still.
STILL_PX = 1.0
#: The last part of the footage the second background is taken from (its share).
TAIL_SHARE = 0.4


def still_run(ps):
    """``(first, last, u, v)`` of the longest run of consecutive clean frames of the pass
    ``ps`` whose points stay within ``STILL_PX`` of its first, at least ``STILL_FRAMES``
    long (``u, v``: their median); None where there is none."""
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


def disc_radius(areas, q=50):
    """The radius (px, at least 2) of the disc of the ``q``-th percentile of ``areas``
    (the median by default)."""
    return max(2.0, float(np.sqrt(np.nanpercentile(areas, q) / np.pi)))


def slow_start(ps, *, count=10):
    """Whether the object of pass ``ps`` went less than its radius (and 2 px) over its
    first ``count`` clean frames: it started at rest or nearly (or it is a ghost, or a
    ghost with the object), where a ghost can be; a thrown object cannot."""
    idx = np.flatnonzero(ps.clean & np.isfinite(ps.u))[:count]
    if idx.size < count:
        return False
    return float(np.hypot(ps.u[idx[-1]] - ps.u[idx[0]], ps.v[idx[-1]] - ps.v[idx[0]])) \
        < disc_radius(ps.area[idx])


def tail_background(source, *, samples=25):
    """Background of the last ``TAIL_SHARE`` of ``source``'s frames (random access);
    None where that part is shorter than ``samples``."""
    n = len(source)
    first = int(n * (1.0 - TAIL_SHARE))
    if n - first < samples:
        return None
    return sample_background(source, samples=samples, first=first)


def moved_over(ps, first, last, radius):
    """Whether the object of pass ``ps`` travelled more than ``radius`` (and 3 px) over
    its clean frames ``first..last`` (what the first pass followed there stayed within
    ``STILL_PX``)."""
    idx = np.flatnonzero(ps.clean[first:last + 1] & np.isfinite(ps.u[first:last + 1])) + first
    if idx.size < 3:
        return False
    return float(np.hypot(ps.u[idx[-1]] - ps.u[idx[0]], ps.v[idx[-1]] - ps.v[idx[0]])) \
        > max(radius, 3.0 * STILL_PX)


def changed(first, last, *, k_sigma):
    """Where the two backgrounds differ by more than the first's detection threshold
    (bool image): what rested in view over the frames of one and not the other."""
    return np.abs(first.image - last.image) > first.threshold(k=k_sigma)


def disc_share(mask, u, v, radius):
    """The share of the disc of ``radius`` about ``(u, v)`` that ``mask`` covers."""
    rows, cols = mask.shape
    r = int(np.ceil(radius))
    x0, x1 = max(0, int(u) - r), min(cols, int(u) + r + 2)
    y0, y1 = max(0, int(v) - r), min(rows, int(v) + r + 2)
    if x1 <= x0 or y1 <= y0:
        return 0.0
    yy, xx = np.mgrid[y0:y1, x0:x1]
    disc = (xx - u) ** 2 + (yy - v) ** 2 <= radius * radius
    return float(mask[y0:y1, x0:x1][disc].mean()) if disc.any() else 0.0


def radii(ps):
    """Per frame, the radius of the disc of the pass's object's area (px, at least 2)."""
    return np.fmax(2.0, np.sqrt(np.where(np.isfinite(ps.area), ps.area, 0.0) / np.pi))


def overlaps(ps, mask, *, share=0.2):
    """Whether the object of pass ``ps`` lies, in any clean frame, with at least ``share``
    of its disc where ``mask`` is set."""
    r = radii(ps)
    for i in np.flatnonzero(ps.clean & np.isfinite(ps.u)):
        if disc_share(mask, ps.u[i], ps.v[i], r[i]) >= share:
            return True
    return False


def tail_wins(first, last, mask):
    """Whether, where the passes ``first`` (against the first frames' background) and
    ``last`` (the last frames') both have clean frames and put the object apart (by half
    its radius and 2 px), the last's object lies less where the backgrounds differ
    (``mask``) in most of those frames, and in at least 3: its measurement does not
    turn on which background holds what rested there, the first's does."""
    both = np.flatnonzero(first.clean & last.clean & np.isfinite(first.u)
                          & np.isfinite(last.u))
    r1, r2 = radii(first), radii(last)
    votes = []
    for i in both:
        if np.hypot(first.u[i] - last.u[i], first.v[i] - last.v[i]) <= max(2.0, 0.5 * r1[i]):
            continue
        votes.append(disc_share(mask, last.u[i], last.v[i], r2[i])
                     < disc_share(mask, first.u[i], first.v[i], r1[i]))
    return len(votes) >= 3 and sum(votes) > 0.5 * len(votes)


#: A frame whose object lay within its radius of where it is in more than this share of
#: the frames the background was taken from is held by the background: the median of
#: the pixel at its centre is then the object, not the wall. (At 40 %, a ball held for
#: 60 of 300 frames and then dropped was flagged over 117 frames measured within
#: 0.04 px, a median: below half, the median is the wall's.)
HELD_SHARE = 0.5


def held(ps):
    """Clean frames of the pass ``ps`` where its background holds the object (bool per
    frame): it lay within its radius (of its larger frames' area) of the frame's point
    in more than :data:`HELD_SHARE` of the background's frames (where it was measured in
    them, or in a frame at most 2 away). An object moving less than its size over the
    frames the background comes from (tens of frames) is seen there against itself, a
    crescent a part of its size off; a thrown one is at any place in a frame or two."""
    out = np.zeros(ps.n, bool)
    frames = np.array([j for j in ps.background.frames if 0 <= j < ps.n], int)
    seen = np.isfinite(ps.u) & np.isfinite(ps.v)
    if frames.size < 5 or not np.isfinite(ps.area).any():
        return out
    radius = disc_radius(ps.area, q=90)
    pos = []
    for j in frames:
        near = [k for k in (j, j - 1, j + 1, j - 2, j + 2) if 0 <= k < ps.n and seen[k]]
        pos.append((ps.u[near[0]], ps.v[near[0]]) if near else (np.nan, np.nan))
    pos = np.array(pos)
    idx = np.flatnonzero(ps.clean & seen)
    if idx.size == 0:
        return out
    d = np.hypot(ps.u[idx, None] - pos[None, :, 0], ps.v[idx, None] - pos[None, :, 1])
    share = np.count_nonzero(d <= radius, axis=1) / frames.size
    out[idx] = share > HELD_SHARE
    return out
