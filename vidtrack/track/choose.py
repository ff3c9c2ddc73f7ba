"""Step 3 of the flight tracker: the object is the chain of detections a flight explains.

A **chain** holds at most one detection per frame. It is grown from a seed (a
tracklet's central frames, a whole tracklet, or the detection at the user's ``target``
pixel) both ways in time: the next frame's
position is extrapolated by a quadratic in time through the chain's last
``predict_frames`` points, and the detection taken is the one nearest it within a gate
of ``max(gate_px, gate_sizes * size)`` pixels (half again for every frame missed), its
distance weighed by how much its size and its contrast differ from the chain's. A chain
ends after ``max_gap`` frames without one.
Where two chains take one detection over a run of frames and are apart before and after
it (two things that cross, seen as one: :func:`mark_merged`, over every chain grown,
before those through the same detections are made one), those frames are each chain's
``merged``: they are seen but tell neither's flight (its score fits and scores round
them) and are flagged MERGED. Two chains that take the same detections over a run of
frames and part again (two things side by side, seen as one, each chain following the
pair and leaving it on either) are also scored with their parts after the run
exchanged (:func:`_swapped`): the flight says which thing went on where.
Chains through the same detections are one; two chains that one flight explains across
a gap (the object hidden behind something for longer than ``max_gap``) are joined when
each one's path, carried over the gap, meets the other's, their joint score exceeds
both of theirs, and they are not of opposite polarities
(:func:`vidtrack.track.detect.polarity`: a light rod going behind a post, a dark one
coming out, are two objects). Another chain that flies before or after the
object, with half its score or more, is named in a note (:func:`others_note`).

Each chain's **flight score** is the length of the path of its flight (the longest span
one cubic in time explains, :func:`flight_segment`: free flight with a smoothly changing
drag) times the share of that span's frames that a local quadratic through their
neighbours predicts within ``flight_residual_px`` (or ``flight_residual_sizes`` of its
size), seen whole, not shadow-like (:mod:`vidtrack.track.detect`) and of the flight's
own contrast (within ``LEVEL_RATIO``: a chain that went over to a dimmer rod where the
two crossed keeps only the frames of one of them); a chain whose flight is shorter than
``min_travel_sizes`` of its own sizes scores nothing (something resting, rocking in
place, a person shifting, is not thrown). Where no chain scores and some are shadow-like
(a dark object on a plain wall: no texture tells it from a shadow), they are scored with
their shadow-like frames counted: nothing else flies to cast them. The chain with the
highest score is the object. When a second chain seen at the same time (in half its
frames or more), not a shadow and sharing no detection, scores within
``ambiguity_ratio`` of it with a signal (summed weight) within the same ratio, the
choice is the user's: :class:`~vidtrack.errors.TrackError` lists both with the
``target`` line that picks each. With a ``target``, the chain grown from the detection
at that pixel in that frame is the object, whatever else moves.
"""

import numpy as np

from vidtrack.errors import TrackError
from vidtrack.track.detect import polarity
from vidtrack.track.measure import MINOR_FLOOR_PX, moment_axes
from vidtrack.track.path import TUKEY, extrapolate, local_quadratic, robust_path, runs

__all__ = ["Chain", "grow", "choose", "flight_segment", "mark_merged", "others_note"]

#: Two chains are one when they share more than this share of the shorter's detections;
#: two chains are seen at once when both have detections in this share of the shorter's
#: frames; a chain is a shadow when this share of its frames are shadow-like.
MAJORITY = 0.5

#: Two chains joined across a gap must score this many times the better of them, and
#: keep at least MAJORITY of each one's flight.
JOIN_GAIN = 1.1

#: Two chains whose points in a frame lie within this distance (px) share a detection.
SAME_PX = 1.0

#: A chain's frames whose contrast (the 90th percentile of the detection's difference
#: from the background) lies within this factor of the flight's median are the same
#: object's; growing, a detection's cost grows with how far its contrast is from the
#: chain's.
LEVEL_RATIO = 1.5

#: A chain's flight is looked for from at most this many seeds along it.
SEEDS_MAX = 16

#: A chain's robust path (:func:`_on_its_path`) is fitted through its neighbours within
#: this many ``path_window`` frames either side of each frame (48 by default, as the
#: trend of a rod's profile, :func:`vidtrack.track.joined.hold_profile`): a run of
#: frames on something else up to about a third of that window long has no say in it.
PATH_WINDOWS = 8

#: At most this many rounds of taking a chain again along its robust path.
PATH_ROUNDS = 4

#: A detection holds a point within this many of its spreads (its second moments'
#: ellipse; a rod's end lies at 1.73 along): one off a chain's robust path that holds
#: the path's point there holds the object, touched by something (a blade just left),
#: and is kept for the measurement to take apart.
REACH_SPREADS = 2.0


class Chain:
    """A chain: ``pick[i]`` is the index of its detection in frame position ``i`` (-1:
    none), with its positions, sizes, shadow marks, weights and the spreads along its
    major and minor axes (px) per frame (NaN, False and 0 where it has none), its
    ``merged`` frames (:func:`mark_merged`), its ``off_path`` frames (its detection
    off its robust path, nothing on it: :func:`_on_its_path`), and whether it was taken
    although shadow-like (``shadow_like``: no other chain in flight, :func:`choose`)."""

    def __init__(self, pick, detections):
        self.pick = pick
        n = pick.size
        self.u = np.full(n, np.nan)
        self.v = np.full(n, np.nan)
        self.size = np.full(n, np.nan)
        self.weight = np.zeros(n)
        self.level = np.full(n, np.nan)
        self.shadow = np.zeros(n, bool)
        self.shadow_seen = np.zeros(n, bool)
        self.major = np.full(n, np.nan)
        self.minor = np.full(n, np.nan)
        self.polarity = np.zeros(n, np.int8)
        for i in np.flatnonzero(pick >= 0):
            self._take(i, detections[i][pick[i]])
        self.frames = np.flatnonzero(pick >= 0)
        self.score = 0.0
        self.explained = np.zeros(n, bool)
        self.merged = np.zeros(n, bool)
        self.off_path = np.zeros(n, bool)
        self.shadow_like = False

    def _take(self, i, d):
        self.u[i], self.v[i] = d["u"], d["v"]
        self.size[i] = np.sqrt(max(int(d["area"]), 1))
        self.weight[i] = d["weight"]
        self.level[i] = d["level"]
        self.shadow[i] = d["shadow"]
        self.shadow_seen[i] = d["shadow"] and d["textured"]
        self.polarity[i] = polarity(d)
        _angle, along, across = moment_axes(float(d["muu"]), float(d["mvv"]),
                                            float(d["muv"]))
        self.major[i], self.minor[i] = np.sqrt(along), np.sqrt(across)

    def take(self, i, j, detections, at=None):
        """Frame position ``i`` takes its detection ``j`` (at the point ``at``, default
        the detection's centroid)."""
        self.pick[i] = j
        self._take(i, detections[i][j])
        if at is not None:
            self.u[i], self.v[i] = at
        self.frames = np.flatnonzero(self.pick >= 0)

    @property
    def signal(self):
        """Summed weight of its detections (px^2 of coverage)."""
        return float(self.weight.sum())

    def middle(self):
        """(frame position, (u, v)) of the chain's middle detection."""
        i = int(self.frames[self.frames.size // 2])
        return i, (float(self.u[i]), float(self.v[i]))


def _step(chain_f, chain_u, chain_v, chain_s, fi, settings, dets, chain_l=None):
    """The detection of frame ``fi`` that continues the chain (index or -1)."""
    if len(dets) == 0:
        return -1, None
    k = settings.predict_frames
    pu, pv = extrapolate(chain_f[-k:], chain_u[-k:], chain_v[-k:], fi)
    size = _median(chain_s[-k:])
    gap = fi - chain_f[-1]
    gate = max(settings.gate_px, settings.gate_sizes * size) * (1.0 + 0.5 * (gap - 1))
    dist = np.hypot(dets["u"] - pu, dets["v"] - pv)
    ds = np.sqrt(np.maximum(dets["area"], 1).astype(float))
    cost = dist * (1.0 + np.abs(np.log(ds / size)))
    if chain_l is not None:
        # (and by how much its contrast differs: a dimmer rod crossing the object)
        lev = _median(chain_l[-k:])
        cost = cost * (1.0 + np.abs(np.log(np.maximum(dets["level"], 1e-3) / max(lev, 1e-3))))
    cost = np.where(dist <= gate, cost, np.inf)
    j = int(np.argmin(cost))
    if not np.isfinite(cost[j]):
        return -1, None
    return j, float(dist[j])


def _median(values):
    """``float(np.median(values))`` of a short list of floats, without numpy's overhead
    per call (this runs for every frame a chain is grown by): the middle value, or the
    mean of the middle two, ``(a + b) / 2``, as numpy takes it."""
    s = sorted(values)
    n = len(s)
    if n == 0 or any(x != x for x in s):
        return float(np.median(values))     # (empty, or a NaN: numpy's answer)
    m = n // 2
    return float(s[m]) if n % 2 else float((s[m - 1] + s[m]) / 2.0)


def grow(detections, seed, settings):
    """The chain grown both ways in time from ``seed`` (list of (frame position, index)).

    Returns
    -------
    numpy.ndarray of int
        ``pick``: per frame position the chosen detection's index, -1 where none.
    """
    n = len(detections)
    pick = np.full(n, -1, np.int64)
    seed = sorted(seed)
    for fi, j in seed:
        pick[fi] = j
    for direction in (1, -1):
        pts = seed if direction == 1 else seed[::-1]
        f = [p[0] for p in pts]
        d = [detections[p[0]][p[1]] for p in pts]
        cu = [float(x["u"]) for x in d]
        cv = [float(x["v"]) for x in d]
        cs = [float(np.sqrt(max(int(x["area"]), 1))) for x in d]
        cl = [float(x["level"]) for x in d]
        fi = f[-1] + direction
        while 0 <= fi < n and abs(fi - f[-1]) <= settings.max_gap + 1:
            # (backwards, time runs the other way: the last few frames, negated)
            ff = f if direction == 1 else [-x for x in f[-settings.predict_frames:]]
            j, _err = _step(ff, cu, cv, cs, fi * direction, settings, detections[fi],
                            chain_l=cl)
            if j >= 0:
                det = detections[fi][j]
                pick[fi] = j
                f.append(fi)
                cu.append(float(det["u"]))
                cv.append(float(det["v"]))
                cs.append(float(np.sqrt(max(int(det["area"]), 1))))
                cl.append(float(det["level"]))
            fi += direction
    return pick


def _cubic(t, y, ok, lo, hi, gap_frames, through=None):
    """The cubic in time through the ``ok`` points of ``y`` (N, 2) within [lo, hi]:
    (its 90th percentile residual in px, its path length in px from point to point, across
    no gap longer than ``gap_frames`` but where every point in the gap is ``through``,
    seen but not fitted); (0, 0) with fewer than 6 points."""
    m = ok & (t >= lo) & (t <= hi)
    if np.count_nonzero(m) < 6:
        return 0.0, 0.0
    half = max(0.5 * (hi - lo), 1.0)
    tc = (t[m] - 0.5 * (lo + hi)) / half
    a = np.vander(tc, 4)
    coef, *_ = np.linalg.lstsq(a, y[m], rcond=None)
    res = np.hypot(*(a @ coef - y[m]).T)
    # the path's length where it was seen (not across a gap, where nothing was)
    path = a @ coef
    step = np.hypot(*np.diff(path, axis=0).T)
    seen = np.diff(t[m]) <= gap_frames
    if through is not None and not seen.all():
        # (a gap of points seen but not fitted, two objects merged: the object was there)
        pos = np.flatnonzero(m)
        blocked = np.r_[0, np.cumsum(~through)]
        seen |= (blocked[pos[1:]] - blocked[pos[:-1] + 1]) == 0
    return float(np.percentile(res, 90)), float(np.sum(step[seen]))


def flight_segment(t, y, ok, settings, size, through=None):
    """The span of time, of the ``ok`` points, whose path one cubic in time explains
    (free flight with drag: gravity, a drag that changes smoothly) within
    ``flight_model_px + flight_residual_sizes * size`` (90th percentile) and that goes
    furthest.

    Each span is grown from a seed (the ``ok`` points round it, ``2 * path_window``
    frames either side), both ways at once while the cubic holds, then each way alone;
    the seeds lie every ``2 * path_window`` frames along the ``ok`` points (at most
    :data:`SEEDS_MAX`, evenly spread), so a chain that went on after its flight (a bounce,
    a roll, something else taken after the object left) still has its flight found. A
    circle (a blade going round) or a path that turns back on itself (a hand) is
    explained only in part.

    Returns
    -------
    (numpy.ndarray of bool, float)
        The ``ok`` points within the span, and the length (px) of the cubic's path over
        it: how far the flight goes (noise about a place at rest adds nothing).
    """
    idx = np.flatnonzero(ok)
    if idx.size < 6:
        return ok & False, 0.0
    tol = settings.flight_model_px + settings.flight_residual_sizes * size
    t0, t1 = float(t[idx[0]]), float(t[idx[-1]])
    half = 2 * settings.path_window
    mids = np.arange(t0 + half, t1 - half + 1e-9, 2 * half)
    if mids.size == 0:
        mids = np.array([float(t[idx[idx.size // 2]])])
    elif mids.size > SEEDS_MAX:
        mids = mids[np.linspace(0, mids.size - 1, SEEDS_MAX).round().astype(int)]
    best = (0.0, None)
    for mid in mids:
        span = _grow_span(t, y, ok, float(mid), t0, t1, tol, settings, through)
        if span is not None and span[2] > best[0]:
            best = (span[2], span)
    if best[1] is None:
        return ok & False, 0.0
    lo, hi, length = best[1]
    return ok & (t >= lo) & (t <= hi), length


def _grow_span(t, y, ok, mid, t0, t1, tol, settings, through=None):
    """(lo, hi, path length) of the span grown from ``mid``, or None where the cubic
    does not hold even round it."""
    gap = settings.max_gap + 1
    lo, hi = max(mid - 2 * settings.path_window, t0), min(mid + 2 * settings.path_window, t1)
    res, length = _cubic(t, y, ok, lo, hi, gap, through)
    if res > tol or length <= 0.0:
        return None
    step = 1.4
    while lo > t0 or hi < t1:
        w = max(mid - lo, hi - mid, 1.0) * step
        nlo, nhi = max(mid - w, t0), min(mid + w, t1)
        r, n_len = _cubic(t, y, ok, nlo, nhi, gap, through)
        if r > tol:
            break
        lo, hi, length = nlo, nhi, n_len
    for side in (-1, 1):
        while (lo > t0) if side < 0 else (hi < t1):
            w = max((hi - lo) * (step - 1.0), 1.0)
            nlo, nhi = (max(lo - w, t0), hi) if side < 0 else (lo, min(hi + w, t1))
            r, n_len = _cubic(t, y, ok, nlo, nhi, gap, through)
            if r > tol:
                break
            lo, hi, length = nlo, nhi, n_len
    return lo, hi, length


def _score(chain, settings, detections, shadows=False):
    """The chain's flight score (px); sets ``explained``.

    A frame is explained when the local quadratic path through its neighbours predicts
    it, it is whole in view (a detection cut by the frame's border is not measured), and
    it lies in the chain's flight segment (:func:`flight_segment`); the score is the
    length of the flight segment's path, times the share of its frames explained and not
    shadow-like (with ``shadows``, shadow-like or not). A thrown object travels far
    along one smooth path; something resting, rocking or shifting in place, a shadow, a
    blade going round, does not.
    """
    idx = chain.frames
    if idx.size < 3:
        return 0.0
    u, v = chain.u[idx], chain.v[idx]
    size = float(np.median(chain.size[idx]))
    uv = np.column_stack([u, v])
    alone = ~(chain.merged[idx] | chain.off_path[idx])
    pred, _ = local_quadratic(idx, uv, settings.path_window,
                              weights=None if alone.all() else alone.astype(float))
    res = np.hypot(*(pred - uv).T)
    ok = res <= max(settings.flight_residual_px, settings.flight_residual_sizes * size)
    ok &= ~np.array([bool(detections[i][chain.pick[i]]["border"]) for i in idx])
    # (a detection of two objects merged where they cross tells neither's flight, nor
    # does one off the chain's robust path)
    ok &= alone
    seg, length = flight_segment(idx.astype(float), uv, ok, settings, size,
                                 through=None if alone.all() else ~alone)
    if not seg.any() or length < settings.min_travel_sizes * size:
        return 0.0
    chain.explained[idx[seg]] = True
    inside = (idx >= idx[seg][0]) & (idx <= idx[seg][-1])
    # (of one object: a chain that went over to something of another contrast where
    # the two crossed keeps the frames of its own)
    lev = np.log(np.maximum(chain.level[idx], 1e-3))
    alike = np.abs(lev - np.median(lev[seg])) <= np.log(LEVEL_RATIO)
    lit = np.ones(idx.size, bool) if shadows else ~chain.shadow[idx]
    good = (np.count_nonzero(seg & alike & lit)
            / max(np.count_nonzero(inside & alone), 1))
    return float(length * good)


def mark_merged(chains, settings):
    """Each chain's ``merged`` frames: those whose detection another chain takes too,
    in a run of such frames that the other chain is seen apart from it on both sides of
    (in ``link_min_frames`` frames or more each side, its detection another, farther
    than their half lengths together): two objects seen as one where they cross. (A
    chain that shares the start or the end of another, then goes its own way, is one of
    them taken twice, not a crossing.) Returns whether any chain has such frames."""
    any_merged = False
    for c in chains:
        c.merged[:] = False
        for other in chains:
            if other is c:
                continue
            same = (c.pick >= 0) & (other.pick == c.pick)
            # (apart: farther than their half lengths together, so that no part of one
            # is the other's: two pieces of one object, seen apart where part of it is
            # lost against the wall, are not two things)
            with np.errstate(invalid="ignore"):
                reach = np.sqrt(3.0) * (c.major + other.major)
                apart = ((c.pick >= 0) & (other.pick >= 0) & (other.pick != c.pick)
                         & (np.hypot(c.u - other.u, c.v - other.v) > reach))
            for lo, hi in runs(same):
                if (np.count_nonzero(apart[:lo]) >= settings.link_min_frames
                        and np.count_nonzero(apart[hi:]) >= settings.link_min_frames):
                    c.merged[lo:hi] = True
        any_merged |= bool(c.merged.any())
    return any_merged


def _one_polarity(chain, frames):
    """The polarity (+1, -1) of a chain's ``frames`` where most of them are of it, else
    0 (:func:`vidtrack.track.detect.polarity`)."""
    p = chain.polarity[frames]
    for sign in (1, -1):
        if np.count_nonzero(p == sign) > MAJORITY * p.size:
            return sign
    return 0


def _joined(a, b, detections, settings):
    """The chain of ``a``'s flight then ``b``'s, when ``a``'s explained frames begin and
    end before ``b``'s (a few frames in common are split between them), most of each
    side's are not of opposite polarities, and their paths, each carried to the middle
    of the gap between them, meet there; else None."""
    ea, eb = np.flatnonzero(a.explained), np.flatnonzero(b.explained)
    if ea.size < 3 or eb.size < 3 or ea[0] >= eb[0] or ea[-1] >= eb[-1]:
        return None
    split = int(ea[-1]) if ea[-1] < eb[0] else (int(ea[-1]) + int(eb[0])) // 2
    ea, eb = ea[ea <= split], eb[eb > split]
    if ea.size < 3 or eb.size < 3 or _one_polarity(a, ea) * _one_polarity(b, eb) < 0:
        return None
    # each side's path from its frames a little way from the gap (those beside it may be
    # the object partly hidden), carried to the gap's middle: they must meet there
    k = settings.predict_frames
    pa, pb = ea[:-3][-3 * k:], eb[3:][:3 * k]
    if pa.size < 3 or pb.size < 3:
        return None
    mid = 0.5 * (ea[-1] + eb[0])
    size = float(np.median(np.r_[a.size[ea], b.size[eb]]))
    gap = float(pb[0] - pa[-1])
    gate = max(settings.gate_px, settings.gate_sizes * size) * (1.0 + 0.25 * gap)
    ends = []
    for src, pts in ((a, pa), (b, pb)):
        deg = min(2, pts.size - 1)
        ends.append([np.polyval(np.polyfit(pts - mid, src.u[pts], deg), 0.0),
                     np.polyval(np.polyfit(pts - mid, src.v[pts], deg), 0.0)])
    if np.hypot(ends[0][0] - ends[1][0], ends[0][1] - ends[1][1]) > gate:
        return None
    return _spliced(a, int(ea[-1]) + 1, b, int(eb[0]), detections)


def _spliced(first, upto, then, start, detections):
    """The chain of ``first`` before frame position ``upto`` and of ``then`` from
    ``start`` on (nothing between), each part with its ``merged`` frames."""
    pick = np.full(first.pick.size, -1, np.int64)
    pick[:upto] = first.pick[:upto]
    pick[start:] = then.pick[start:]
    chain = Chain(pick, detections)
    chain.merged[:upto] = first.merged[:upto]
    chain.merged[start:] = then.merged[start:]
    return chain


def _join(chains, detections, settings):
    """Chains one flight explains across a gap (the object hidden behind something for
    longer than ``max_gap`` frames) joined: a pair is joined when its joint flight score
    exceeds both of theirs by a tenth and holds most of each one's flight."""
    chains = list(chains)
    joined = True
    while joined:
        joined = False
        for i, a in enumerate(chains):
            for j, b in enumerate(chains):
                if i == j or a.score <= 0 or b.score <= 0:
                    continue
                both = _joined(a, b, detections, settings)
                if both is None:
                    continue
                both.score = _score(both, settings, detections)
                # (one flight through both: most of each one's flight is in the joint one)
                holds = all(np.count_nonzero(both.explained & c.explained)
                            >= MAJORITY * np.count_nonzero(c.explained) for c in (a, b))
                if holds and both.score > JOIN_GAIN * max(a.score, b.score):
                    chains = [c for k, c in enumerate(chains) if k not in (i, j)] + [both]
                    joined = True
                    break
            if joined:
                break
    return chains


def _swapped(chains, detections, settings):
    """Chains that leave a shared run the other way: where two chains take the same
    detections over a run of ``link_min_frames`` frames or more and each has
    ``link_min_frames`` frames of its own before it and after it (two things seen as one
    where they pass side by side, each chain following the pair's centroid and leaving
    it on either), the two chains with their parts after the run exchanged (and their
    ``merged`` frames with them). They are scored beside the chains grown: which thing
    went on where is the flight's to say."""
    out = []
    k = settings.link_min_frames
    for i, a in enumerate(chains):
        for b in chains[i + 1:]:
            same = (a.pick >= 0) & (b.pick == a.pick)
            own = (a.pick >= 0) & (b.pick >= 0) & (b.pick != a.pick)
            for lo, hi in runs(same):
                if (hi - lo < k or np.count_nonzero(own[:lo]) < k
                        or np.count_nonzero(own[hi:]) < k):
                    continue
                for first, then in ((a, b), (b, a)):
                    chain = _spliced(first, hi, then, hi, detections)
                    chain.score = _score(chain, settings, detections)
                    out.append(chain)
    return out


def _on_its_path(chain, detections, settings):
    """The chain, or the chain taken again along its own robust path where that
    scores higher.

    A chain grown frame by frame may go over to something beside the object for a
    while and come back (a rider a few pixels beside a straw, of about its contrast:
    the prediction, carried from a detection of the two merged, lands between them).
    Locally the frames on the other thing predict each other, and only the two jumps
    show. The chain's robust path (:func:`vidtrack.track.path.robust_path`, through its
    frames not merged with another chain's, :data:`PATH_WINDOWS` ``* path_window``
    either side, its scatter at least ``flag_floor_px``) sees through such a run. Each
    frame in the span of the chain's flight, with the chain's frames on both sides
    within ``path_window``, farther from that path than :data:`TUKEY`
    scatters (a weight of 0) whose detection does not reach the path's point there
    (:func:`_reaches`: a detection that does holds the object, touched by something)
    takes the detection nearest the path where one lies
    within that distance; else it keeps its detection, ``off_path``: the object is not
    seen apart there, and the frame, as a merged one, tells nothing of its flight (its
    score fits and scores round it) and is flagged OUTLIER. The new chain
    replaces the old where its flight score is higher, and is taken again along its
    own path, until the score no longer rises (a long run on the other thing pulls the
    first path towards it: each round frees more of it)."""
    for _ in range(PATH_ROUNDS):
        taken = _taken_on_path(chain, detections, settings)
        if taken is None or taken.score <= chain.score:
            break
        chain = taken
    return chain


def _reaches(det, point):
    """Whether a detection's extent (the ellipse of :data:`REACH_SPREADS` of its
    spreads, across at least ``MINOR_FLOOR_PX``) holds ``point``."""
    angle, along, across = moment_axes(float(det["muu"]), float(det["mvv"]),
                                       float(det["muv"]))
    du, dv = point[0] - det["u"], point[1] - det["v"]
    a = du * np.cos(angle) + dv * np.sin(angle)
    b = -du * np.sin(angle) + dv * np.cos(angle)
    return bool(a * a / max(along, MINOR_FLOOR_PX ** 2)
                + b * b / max(across, MINOR_FLOOR_PX ** 2) <= REACH_SPREADS ** 2)


def _taken_on_path(chain, detections, settings):
    """One round of :func:`_on_its_path`: the chain taken again, scored; None where no
    frame is off its path."""
    ex = np.flatnonzero(chain.explained)
    if ex.size < 3 or chain.score <= 0:
        return None
    own = chain.frames[~chain.merged[chain.frames]]
    if own.size < 3:
        return None
    uv = np.column_stack([chain.u[own], chain.v[own]])
    path, scatter = robust_path(own.astype(float), uv,
                                PATH_WINDOWS * settings.path_window,
                                floor=settings.flag_floor_px)
    reach = TUKEY * scatter
    # (a frame with the chain's own frames on both sides, within ``path_window``: at an
    # end, the path is carried on from one side)
    near = np.diff(own) <= settings.path_window
    flanked = np.r_[False, near] & np.r_[near, False]
    with np.errstate(invalid="ignore"):
        off = ((np.hypot(*(uv - path).T) > reach) & (own >= ex[0]) & (own <= ex[-1])
               & flanked)
    if not off.any():
        return None
    pick = chain.pick.copy()
    off_path = np.zeros(pick.size, bool)
    for k in np.flatnonzero(off):
        dets = detections[own[k]]
        if _reaches(dets[pick[own[k]]], path[k]):
            continue
        dist = np.hypot(dets["u"] - path[k, 0], dets["v"] - path[k, 1])
        j = int(np.argmin(dist))
        if dist[j] <= reach:
            pick[own[k]] = j
        else:
            off_path[own[k]] = True
    if np.array_equal(pick, chain.pick) and np.array_equal(off_path, chain.off_path):
        return None
    taken = Chain(pick, detections)
    taken.merged[:] = chain.merged
    taken.off_path[:] = off_path
    taken.score = _score(taken, settings, detections)
    return taken


def _seeds(detections, tracklets, settings):
    """Seeds from the tracklets that travel most, two from each longer than
    ``predict_frames``: its central ``predict_frames`` frames, from which the chain's
    own prediction grows it both ways, and the whole tracklet, grown beyond its ends (the
    linker's assignment, made over every moving thing at once, kept where it reaches:
    of two things side by side, the chain's prediction may go over to the other where
    the linker does not); the flight scores choose among the chains. Each as (seed,
    whole)."""
    good = [tr for tr in tracklets if len(tr) >= settings.link_min_frames]
    good.sort(key=lambda tr: (tr.travel() / max(np.median(tr.size), 1.0)) * len(tr),
              reverse=True)
    seeds = []
    for tr in good[:settings.seeds_max]:
        k = min(len(tr), settings.predict_frames)
        mid = len(tr) // 2
        a = max(0, mid - k // 2)
        seeds.append((list(zip(tr.frames[a:a + k], tr.index[a:a + k])), False))
        if len(tr) > k:
            seeds.append((list(zip(tr.frames, tr.index)), True))
    return seeds


def _target_seed(detections, target, frame_numbers, what):
    """The seed at the user's target pixel: the detection covering it (or nearest within
    its size) in the target frame."""
    frame, (tu, tv) = target
    hits = np.flatnonzero(np.asarray(frame_numbers) == int(frame))
    if hits.size == 0:
        raise TrackError(f"target: frame {frame} is not in the footage's frames "
                         f"{int(frame_numbers[0])}..{int(frame_numbers[-1])}")
    fi = int(hits[0])
    dets = detections[fi]
    if len(dets) == 0:
        raise TrackError(f"target: nothing differs from the background in frame {frame}: "
                         f"{what} is not seen moving there; give a frame where it flies")
    size = np.sqrt(np.maximum(dets["area"], 1).astype(float))
    dist = np.hypot(dets["u"] - tu, dets["v"] - tv)
    j = int(np.argmin(dist / np.maximum(size, 1.0)))
    if dist[j] > max(3.0 * size[j], 10.0):
        raise TrackError(f"target: nothing moves at the target ({tu:.0f}, {tv:.0f}) px in "
                         f"frame {frame} (the nearest detection is {dist[j]:.0f} px away); "
                         f"give a pixel on {what}")
    return [(fi, j)]


def _seen_at_once(a, b):
    """Whether two chains are seen at the same time: both have detections in at least
    :data:`MAJORITY` of the shorter's frames."""
    return (np.count_nonzero((a.pick >= 0) & (b.pick >= 0))
            >= MAJORITY * min(a.frames.size, b.frames.size))


def choose(detections, tracklets, settings, *, target=None, frame_numbers=None,
           what="the object"):
    """The object's chain.

    Parameters
    ----------
    detections : list of numpy.ndarray
        Per frame position, its detections.
    tracklets : list of vidtrack.track.link.Tracklet
    settings : vidtrack.track.settings.TrackerSettings
    target : (int, (float, float)), optional
        ``(file frame, (u_px, v_px))``: the object is the chain through that pixel.
    frame_numbers : array of int, optional
        File frame number of each frame position (for ``target`` and messages).
    what : str
        What the scene calls the object, for messages.

    Returns
    -------
    (Chain, list of Chain)
        The object's chain and the others considered (best first).

    Raises
    ------
    TrackError
        Nothing a flight explains; two chains explained about equally well (both named,
        with the ``target`` line that picks each).
    """
    n = len(detections)
    if frame_numbers is None:
        frame_numbers = np.arange(n)
    if target is not None:
        seed = _target_seed(detections, target, frame_numbers, what)
        chain = Chain(grow(detections, seed, settings), detections)
        chain.score = _score(chain, settings, detections)
        return _on_its_path(chain, detections, settings), []
    grown = []
    for seed, whole in _seeds(detections, tracklets, settings):
        # (a seed that a chain grown already holds adds nothing: its first detection, or
        # every one of a whole tracklet)
        if all(any(c.pick[f] == j for c in grown) for f, j in (seed if whole else seed[:1])):
            continue
        chain = Chain(grow(detections, seed, settings), detections)
        chain.score = _score(chain, settings, detections)
        grown.append(chain)
    if mark_merged(grown, settings):
        for chain in grown:
            if chain.merged.any():
                chain.score = _score(chain, settings, detections)
    grown += _swapped(grown, detections, settings)
    # chains through the same detections are one: the best scoring of them
    chains = []
    for chain in sorted(grown, key=lambda c: c.score, reverse=True):
        if not any(np.count_nonzero((c.pick == chain.pick) & (c.pick >= 0))
                   > MAJORITY * min(c.frames.size, chain.frames.size) for c in chains):
            chains.append(chain)
    chains = [_on_its_path(c, detections, settings)
              for c in _join(chains, detections, settings)]
    if chains and not any(c.score > 0 for c in chains):
        # (a dark object on a plain wall is shadow-like: with nothing else in flight to
        # cast it, the flight of a shadow-like chain is the object's)
        for chain in chains:
            chain.score = _score(chain, settings, detections, shadows=True)
            chain.shadow_like = chain.score > 0
    chains = [c for c in chains if c.score > 0]
    if not chains:
        moving = sum(1 for tr in tracklets if len(tr) >= settings.link_min_frames)
        raise TrackError(f"{what} never appears in flight in frames {int(frame_numbers[0])}.."
                         f"{int(frame_numbers[-1])}: of {moving} things followed over "
                         f"{settings.link_min_frames} frames or more, none travelled "
                         f"{settings.min_travel_sizes:g} of its sizes along a smooth path; "
                         f"add target = {{ frame = F, at_px = [u, v] }} for {what} to the "
                         f"view's table in scene.toml")
    chains.sort(key=lambda c: c.score, reverse=True)
    best = chains[0]
    r = settings.ambiguity_ratio
    for other in chains[1:]:
        both = (other.pick >= 0) & (best.pick >= 0)
        shared = np.any(both & (np.abs(other.u - best.u) < SAME_PX)
                        & (np.abs(other.v - best.v) < SAME_PX))
        if shared or not _seen_at_once(best, other) or other.score * r < best.score:
            continue
        if other.shadow[other.frames].mean() > MAJORITY or other.signal * r < best.signal:
            continue
        lines = []
        for c in (best, other):
            fi, (u, v) = c.middle()
            lines.append(f"target = {{ frame = {int(frame_numbers[fi])}, at_px = "
                         f"[{u:.0f}, {v:.0f}] }} (flies over {c.frames.size} frames)")
        raise TrackError(f"two things fly alike and either may be {what}: add to the view's "
                         f"table in scene.toml " + " or ".join(lines))
    return best, chains[1:]


def others_note(best, others, frame_numbers, what="the object"):
    """A note naming the other things that fly, not at the same time as the object
    (before or after it) with at least :data:`MAJORITY` of its flight score: a second
    object thrown, or one that came out where the object went behind something. Each
    with the ``target`` line that follows it instead; None where there is none."""
    lines = []
    for other in others:
        if _seen_at_once(best, other) or other.score < MAJORITY * best.score:
            continue
        fi, (u, v) = other.middle()
        lines.append(f"frames {int(frame_numbers[other.frames[0]])}.."
                     f"{int(frame_numbers[other.frames[-1]])} (to follow it instead: target "
                     f"= {{ frame = {int(frame_numbers[fi])}, at_px = [{u:.0f}, {v:.0f}] }})")
    if not lines:
        return None
    return (f"another object flies before or after {what}, not taken: "
            + "; ".join(lines))
