"""Motion prediction and the choice of the straw among moving blobs (internal).

:class:`Predictor` extrapolates the last clean positions with a least-squares
polynomial in time (quadratic from 6 points on, linear below, constant for one point);
its weights depend only on the time offsets, so they are cached and each prediction is
two small dot products.

:class:`Acquirer` finds the straw when it is not being followed: every moving blob
starts a tentative tracklet; a tracklet that is seen in ``confirm`` consecutive frames,
moves, and moves steadily (its last point where its earlier points said) is a
candidate. A static blob (a ghost in the background, a machine part that shifted) never
qualifies; nor does a flickering one; nor, while a larger one is steady too, a tiny one
(a few noise pixels by the rotor). Blobs brighter and darker than the background are
kept apart (a bright straw riding a dark blade is its own blob). Among candidates the
one nearest the stream's centre line wins when a centre line is given, else the
fastest: the straw leaves the tip of the blade at the tip's speed, faster than the
centroid of any part of the rotor.
"""

import numpy as np

#: Most clean points used for a prediction (a long baseline keeps the extrapolation
#: through a crossing, tens of frames, from running away).
HISTORY = 16


class Predictor:
    """Polynomial extrapolation of the recent clean positions.

    Times are in frames (source index, or time / nominal frame interval).
    """

    def __init__(self, *, history=HISTORY, max_degree=2):
        self.t = []
        self.p = []
        self.history = int(history)
        self.max_degree = int(max_degree)
        self._cache = {}

    def __len__(self):
        return len(self.t)

    def reset(self):
        self.t.clear()
        self.p.clear()

    def add(self, t, u, v):
        self.t.append(float(t))
        self.p.append((float(u), float(v)))
        if len(self.t) > self.history:
            del self.t[0]
            del self.p[0]

    def _weights(self, offsets):
        key = np.round(offsets, 6).tobytes()
        w = self._cache.get(key)
        if w is None:
            m = len(offsets)
            deg = min(self.max_degree, 2 if m >= 6 else (1 if m >= 2 else 0))
            a = np.vander(np.asarray(offsets, float), deg + 1, increasing=True)
            w = np.linalg.pinv(a)  # (deg+1, m): coefficients = w @ positions
            if deg < 2:
                w = np.vstack([w, np.zeros((2 - deg, m))])
            if len(self._cache) > 4096:
                self._cache.clear()
            self._cache[key] = w
        return w

    def state(self, t):
        """Predicted position, velocity (px/frame) and acceleration at time ``t``.

        Returns
        -------
        (numpy.ndarray, numpy.ndarray, numpy.ndarray) or None
            Position ``(u, v)``, velocity and acceleration; None without history.
        """
        if not self.t:
            return None
        offsets = np.asarray(self.t) - t
        coef = self._weights(offsets) @ np.asarray(self.p)
        return coef[0], coef[1], 2.0 * coef[2]

    def predict(self, t):
        """Predicted ``(u, v)`` at ``t`` (None without history)."""
        s = self.state(t)
        return None if s is None else s[0]


class Tracklet:
    """A tentative sequence of detections of one moving blob."""

    __slots__ = ("points", "blobs")

    def __init__(self, t, blob):
        self.points = [(t, blob.u, blob.v)]
        self.blobs = [blob]

    @property
    def last_t(self):
        return self.points[-1][0]

    def predict(self, t):
        if len(self.points) == 1:
            return np.array(self.points[-1][1:])
        (t1, u1, v1), (t2, u2, v2) = self.points[-2], self.points[-1]
        dt = max(t2 - t1, 1e-9)
        vel = np.array([(u2 - u1) / dt, (v2 - v1) / dt])
        return np.array([u2, v2]) + vel * (t - t2)

    def speed(self):
        """Mean speed (px/frame) over the tracklet."""
        (t0, u0, v0), (t1, u1, v1) = self.points[0], self.points[-1]
        return float(np.hypot(u1 - u0, v1 - v0) / max(t1 - t0, 1e-9))

    def add(self, t, blob):
        self.points.append((t, blob.u, blob.v))
        self.blobs.append(blob)

    def steady(self, confirm, *, min_motion):
        """Seen ``confirm`` times in a row, moving, and the last point where predicted."""
        if len(self.points) < confirm:
            return False
        pts = np.array(self.points[-confirm:])
        if np.any(np.diff(pts[:, 0]) > 1.5):
            return False
        step = np.hypot(*(pts[-1, 1:] - pts[0, 1:])) / max(pts[-1, 0] - pts[0, 0], 1e-9)
        if step < min_motion:
            return False
        # constant-velocity check of the last point from the two before it
        if confirm >= 3:
            (t0, u0, v0), (t1, u1, v1), (t2, u2, v2) = pts[-3], pts[-2], pts[-1]
            pu = u1 + (u1 - u0) * (t2 - t1) / max(t1 - t0, 1e-9)
            pv = v1 + (v1 - v0) * (t2 - t1) / max(t1 - t0, 1e-9)
            tol = 1.5 + 0.3 * step
            if np.hypot(u2 - pu, v2 - pv) > tol:
                return False
        areas = np.array([b.mask_area for b in self.blobs[-confirm:]], float)
        return areas.max() <= 2.5 * max(areas.min(), 1.0)


def line_distance(u, v, line):
    """Distance (px) of a point from the line through two pixel points."""
    (a0, b0), (a1, b1) = line
    du, dv = a1 - a0, b1 - b0
    norm = np.hypot(du, dv)
    if norm == 0:
        return float(np.hypot(u - a0, v - b0))
    return float(abs((u - a0) * dv - (v - b0) * du) / norm)


class Acquirer:
    """Tentative tracklets of moving blobs; hands over the straw when one is steady.

    Parameters
    ----------
    confirm : int
        Consecutive detections needed.
    max_step : float
        Largest motion between frames (px) a blob may make and still be associated.
    min_motion : float
        Least mean motion (px/frame) that counts as moving.
    centre_line : ((u0, v0), (u1, v1)) or None
        The stream's centre line in pixels.
    tiny_px : int
        A candidate with a blob of fewer pixels than this is dropped while one without
        is steady too.
    """

    def __init__(self, *, confirm, max_step, min_motion, centre_line=None, tiny_px=0):
        self.confirm = confirm
        self.tiny_px = tiny_px
        self.max_step = max_step
        self.min_motion = min_motion
        self.centre_line = centre_line
        self.tracklets = []

    def reset(self):
        self.tracklets = []

    def update(self, t, blobs, *, accept=None):
        """Associate this frame's blobs; return the chosen steady tracklet or None.

        Parameters
        ----------
        t : float
            Time of the frame in frames.
        blobs : list of Blob
        accept : callable, optional
            ``accept(tracklet) -> bool``: a further test a candidate must pass (e.g.
            consistency with where a lost straw should be).
        """
        live = [tr for tr in self.tracklets if t - tr.last_t <= 1.5]
        used = set()
        pairs = []
        for i, tr in enumerate(live):
            p = tr.predict(t)
            pol = tr.blobs[-1].polarity
            for j, b in enumerate(blobs):
                if b.polarity != pol:
                    continue
                dist = float(np.hypot(b.u - p[0], b.v - p[1]))
                gate = self.max_step if len(tr.points) == 1 else max(
                    3.0, 0.5 * np.hypot(*(np.array(tr.points[-1][1:])
                                          - np.array(tr.points[-2][1:]))) + 3.0)
                if dist <= gate:
                    pairs.append((dist, i, j))
        pairs.sort()
        taken_tr = set()
        for _dist, i, j in pairs:
            if i in taken_tr or j in used:
                continue
            live[i].add(t, blobs[j])
            taken_tr.add(i)
            used.add(j)
        fresh = [Tracklet(t, b) for j, b in enumerate(blobs) if j not in used]
        kept = [tr for i, tr in enumerate(live) if i in taken_tr]
        self.tracklets = kept + fresh
        ready = [tr for tr in kept if tr.steady(self.confirm, min_motion=self.min_motion)
                 and (accept is None or accept(tr))]
        if not ready:
            return None
        # a few noise pixels by the rotor can drift steadily for 3 frames: while a
        # candidate of some size is steady too, a tiny one is not the straw
        sizes = [min(b.mask_area for b in tr.blobs[-self.confirm:]) for tr in ready]
        if max(sizes) >= self.tiny_px:
            ready = [tr for tr, s in zip(ready, sizes) if s >= self.tiny_px]
        if self.centre_line is not None:
            return min(ready, key=lambda tr: line_distance(tr.points[-1][1], tr.points[-1][2],
                                                           self.centre_line))
        return max(ready, key=lambda tr: tr.speed())


class Intruders:
    """Other moving blobs of the straw's polarity near it (a second straw), followed.

    While such a blob's predicted position is within touching distance of the straw
    the straw's blob cannot be trusted, even when the two look like one rod (crossing
    end to end): those frames are flagged. A blob that merges into the straw is
    predicted on from its own motion until it is seen again or leaves.
    """

    #: Frames an intruder is predicted without being seen before it is forgotten.
    MAX_UNSEEN = 120

    def __init__(self):
        self.items = []   # [Predictor, length_px, last_seen_t]

    def update(self, t, blobs, *, min_area=0):
        """Associate this frame's other blobs with the known intruders."""
        blobs = [b for b in blobs if b.mask_area >= min_area]
        used = set()
        for item in self.items:
            p = item[0].predict(t)
            best, best_d = None, np.inf
            for j, b in enumerate(blobs):
                if j in used:
                    continue
                d = float(np.hypot(b.u - p[0], b.v - p[1]))
                if d < best_d:
                    best, best_d = j, d
            if best is not None and best_d <= 4.0 + 0.5 * item[1]:
                b = blobs[best]
                item[0].add(t, b.u, b.v)
                item[1] = b.length if np.isfinite(b.length) else item[1]
                item[2] = t
                used.add(best)
        for j, b in enumerate(blobs):
            if j not in used:
                pr = Predictor(max_degree=1)
                pr.add(t, b.u, b.v)
                self.items.append([pr, b.length if np.isfinite(b.length) else 10.0, t])
        # a blob seen fewer than 3 times is not followed when it disappears (noise,
        # a flicker); a static one is not a straw
        keep = []
        for it in self.items:
            pr = it[0]
            if t - it[2] > (self.MAX_UNSEEN if len(pr) >= 3 else 0.5):
                continue
            if len(pr) >= 3:
                span = pr.t[-1] - pr.t[0]
                moved = np.hypot(pr.p[-1][0] - pr.p[0][0], pr.p[-1][1] - pr.p[0][1])
                if moved < 0.2 * max(span, 1.0):
                    continue
            keep.append(it)
        self.items = keep

    def near(self, t, u, v, length, *, margin=3.0):
        """An intruder predicted within touching distance of a rod at (u, v)?"""
        for pr, ln, _ in self.items:
            p = pr.predict(t)
            if p is not None and np.hypot(p[0] - u, p[1] - v) <= 0.5 * (length + ln) + margin:
                return True
        return False

    def closer_to_intruder(self, t, blob, own):
        """The blob is nearer some intruder's prediction than the straw's."""
        d_own = float(np.hypot(blob.u - own[0], blob.v - own[1]))
        for pr, _, _ in self.items:
            p = pr.predict(t)
            if p is not None and np.hypot(blob.u - p[0], blob.v - p[1]) < d_own:
                return True
        return False
