"""Step 3 of the flight tracker: the object is the chain of detections a flight explains.

A **chain** holds at most one detection per frame. It is grown from a seed (a tracklet,
or the detection at the user's ``target`` pixel) both ways in time: the next frame's
position is extrapolated by a quadratic in time through the chain's last
``predict_frames`` points, and the detection taken is the one nearest it within a gate
of ``max(gate_px, gate_sizes * size)`` pixels (half again for every frame missed), its
distance weighed by how much its size differs from the chain's. A chain ends after ``max_gap`` frames without one.
Chains through the same detections are one.

Each chain's **flight score** is the distance it travels between consecutive frames that
a local quadratic in time through their neighbours predicts within ``flight_residual_px``
(or ``flight_residual_sizes`` of its size), each step weighted by how little of it is
shadow-like (:mod:`vidtrack.track.detect`); a chain that travels less than
``min_travel_sizes`` of its own sizes scores nothing (something rocking in place, a
person shifting, is not thrown). The chain with the highest score is the object. When a
second chain seen at the same time (in half its frames or more), not a shadow and
sharing no detection, scores within ``ambiguity_ratio`` of it with a signal (summed
weight) within the same ratio, the choice is the user's: :class:`~vidtrack.errors.TrackError` lists both with the
``target`` line that picks each. With a ``target``, the chain grown from the detection at
that pixel in that frame is the object, whatever else moves.
"""

import numpy as np

from vidtrack.errors import TrackError
from vidtrack.track.path import local_quadratic

__all__ = ["Chain", "grow", "choose"]


class Chain:
    """A chain: ``pick[i]`` is the index of its detection in frame position ``i`` (-1:
    none), with its positions, sizes, shadow marks, weights and the spreads along its
    major and minor axes (px) per frame (NaN, False and 0 where it has none)."""

    def __init__(self, pick, detections):
        self.pick = pick
        n = pick.size
        self.u = np.full(n, np.nan)
        self.v = np.full(n, np.nan)
        self.size = np.full(n, np.nan)
        self.weight = np.zeros(n)
        self.shadow = np.zeros(n, bool)
        self.major = np.full(n, np.nan)
        self.minor = np.full(n, np.nan)
        for i in np.flatnonzero(pick >= 0):
            d = detections[i][pick[i]]
            self.u[i], self.v[i] = d["u"], d["v"]
            self.size[i] = np.sqrt(max(int(d["area"]), 1))
            self.weight[i] = d["weight"]
            self.shadow[i] = d["shadow"]
            half = 0.5 * (float(d["muu"]) + float(d["mvv"]))
            root = float(np.hypot(0.5 * (float(d["muu"]) - float(d["mvv"])), float(d["muv"])))
            self.major[i] = np.sqrt(max(half + root, 0.0))
            self.minor[i] = np.sqrt(max(half - root, 0.0))
        self.frames = np.flatnonzero(pick >= 0)
        self.score = 0.0
        self.explained = np.zeros(n, bool)

    @property
    def signal(self):
        """Summed weight of its detections (px^2 of coverage)."""
        return float(self.weight.sum())

    def middle(self):
        """(frame position, (u, v)) of the chain's middle detection."""
        i = int(self.frames[self.frames.size // 2])
        return i, (float(self.u[i]), float(self.v[i]))


def _step(chain_f, chain_u, chain_v, chain_s, fi, settings, dets):
    """The detection of frame ``fi`` that continues the chain (index or -1)."""
    if len(dets) == 0:
        return -1, None
    k = settings.predict_frames
    tf = np.asarray(chain_f[-k:], float)
    tu = np.asarray(chain_u[-k:])
    tv = np.asarray(chain_v[-k:])
    order = min(2, tf.size - 1)
    if order >= 1 and tf.size >= 3 and tf[-1] - tf[0] >= 2:
        cu = np.polyfit(tf - tf[-1], tu, order)
        cv = np.polyfit(tf - tf[-1], tv, order)
        pu, pv = np.polyval(cu, fi - tf[-1]), np.polyval(cv, fi - tf[-1])
    elif tf.size >= 2:
        r = (fi - tf[-1]) / (tf[-1] - tf[-2])
        pu, pv = tu[-1] + r * (tu[-1] - tu[-2]), tv[-1] + r * (tv[-1] - tv[-2])
    else:
        pu, pv = tu[-1], tv[-1]
    size = float(np.median(chain_s[-k:]))
    gap = fi - chain_f[-1]
    gate = max(settings.gate_px, settings.gate_sizes * size) * (1.0 + 0.5 * (gap - 1))
    dist = np.hypot(dets["u"] - pu, dets["v"] - pv)
    ds = np.sqrt(np.maximum(dets["area"], 1).astype(float))
    cost = dist * (1.0 + np.abs(np.log(ds / size)))
    cost = np.where(dist <= gate, cost, np.inf)
    j = int(np.argmin(cost))
    if not np.isfinite(cost[j]):
        return -1, None
    return j, float(dist[j])


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
        fi = f[-1] + direction
        while 0 <= fi < n and abs(fi - f[-1]) <= settings.max_gap + 1:
            ff = f if direction == 1 else [-x for x in f]
            j, _err = _step(ff, cu, cv, cs, fi * direction, settings, detections[fi])
            if j >= 0:
                det = detections[fi][j]
                pick[fi] = j
                f.append(fi)
                cu.append(float(det["u"]))
                cv.append(float(det["v"]))
                cs.append(float(np.sqrt(max(int(det["area"]), 1))))
            fi += direction
    return pick


def _score(chain, settings):
    """The chain's explained travel (px); sets ``explained``.

    A frame is explained when the local quadratic path through its neighbours predicts
    it; the score is the distance travelled between consecutive explained frames, each
    step weighted by how little of it is shadow-like. A thrown object travels far along
    a smooth path; something rocking or shifting in place, a shadow, does not.
    """
    idx = chain.frames
    if idx.size < 3:
        return 0.0
    u, v = chain.u[idx], chain.v[idx]
    size = float(np.median(chain.size[idx]))
    pred, _ = local_quadratic(idx, np.column_stack([u, v]), settings.path_window)
    res = np.hypot(*(pred - np.column_stack([u, v])).T)
    ok = res <= max(settings.flight_residual_px, settings.flight_residual_sizes * size)
    travel = np.hypot(u - u[0], v - v[0])
    if not ok.any() or float(np.nanmax(travel)) < settings.min_travel_sizes * size:
        return 0.0
    chain.explained[idx[ok]] = True
    step = np.hypot(np.diff(u), np.diff(v))
    both = ok[1:] & ok[:-1]
    w = 1.0 - 0.5 * (chain.shadow[idx][1:].astype(float) + chain.shadow[idx][:-1])
    return float(np.sum(step * both * w))


def _seeds(detections, tracklets, settings):
    """Seeds from the tracklets that travel most (their central frames)."""
    good = [tr for tr in tracklets if len(tr) >= settings.link_min_frames]
    good.sort(key=lambda tr: (tr.travel() / max(np.median(tr.size), 1.0)) * len(tr),
              reverse=True)
    seeds = []
    for tr in good[:settings.seeds_max]:
        k = min(len(tr), settings.predict_frames)
        mid = len(tr) // 2
        a = max(0, mid - k // 2)
        seeds.append(list(zip(tr.frames[a:a + k], tr.index[a:a + k])))
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
        raise TrackError(f"target: nothing moving at ({tu:.0f}, {tv:.0f}) px in frame {frame} "
                         f"(the nearest detection is {dist[j]:.0f} px away); give a pixel on "
                         f"{what}")
    return [(fi, j)]


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
        chain.score = _score(chain, settings)
        return chain, []
    chains = []
    for seed in _seeds(detections, tracklets, settings):
        if any(c.pick[f] == j for c in chains for f, j in seed[:1]):
            continue
        chain = Chain(grow(detections, seed, settings), detections)
        if any(np.count_nonzero((c.pick == chain.pick) & (c.pick >= 0))
               > 0.5 * min(c.frames.size, chain.frames.size) for c in chains):
            continue
        chain.score = _score(chain, settings)
        chains.append(chain)
    chains = [c for c in chains if c.score > 0]
    if not chains:
        moving = sum(1 for tr in tracklets if len(tr) >= settings.link_min_frames)
        raise TrackError(f"{what} not found: of {moving} things followed over "
                         f"{settings.link_min_frames} frames or more, none travelled "
                         f"{settings.min_travel_sizes:g} of its sizes along a smooth path; "
                         f"add target = {{ frame = F, at_px = [u, v] }} for {what} to the "
                         f"view's table in scene.toml")
    chains.sort(key=lambda c: c.score, reverse=True)
    best = chains[0]
    r = settings.ambiguity_ratio
    for other in chains[1:]:
        both = (other.pick >= 0) & (best.pick >= 0)
        shared = np.any(both & (np.abs(other.u - best.u) < 1.0)
                        & (np.abs(other.v - best.v) < 1.0))
        at_once = np.count_nonzero(both) >= 0.5 * min(other.frames.size, best.frames.size)
        if shared or not at_once or other.score * r < best.score:
            continue
        if other.shadow[other.frames].mean() > 0.5 or other.signal * r < best.signal:
            continue
        lines = []
        for c in (best, other):
            fi, (u, v) = c.middle()
            lines.append(f"target = {{ frame = {int(frame_numbers[fi])}, at_px = "
                         f"[{u:.0f}, {v:.0f}] }} (flies over {c.frames.size} frames)")
        raise TrackError(f"two things fly alike and either may be {what}: add to the view's "
                         f"table in scene.toml " + " or ".join(lines))
    return best, chains[1:]
