"""Motion prediction and the choice of the straw among moving blobs (internal).

:class:`Predictor` extrapolates the last clean positions with a least-squares
polynomial in time (quadratic from 4 points on, linear below, constant for one point);
its weights depend only on the time offsets, so they are cached and each prediction is
two small dot products.

:class:`Acquirer` finds the object when it is not being followed: every moving blob
starts a tentative tracklet; a tracklet that is seen in ``confirm`` consecutive frames,
moves, and moves steadily (its last point where its earlier points said) is a
candidate. A static blob (a ghost in the background, a machine part that shifted) never
qualifies; nor does a flickering one; nor, while a larger one is steady too, a tiny one
(a few noise pixels by the rotor). Blobs brighter and darker than the background are
kept apart (a bright straw riding a dark blade is its own blob), and an object showing
both polarities is also seen whole. The one thing moving is taken once steady and of
constant size; among several, only one that *flies* (:meth:`Tracklet.flying`: a thrown
object travels twice its size along a quadratic path in time, keeping its size; a
person's limbs swing about a place and change shape). Pieces of a larger blob moving
with it, shadows and reflections of another candidate give way; two objects tied
together are one compound. Among what is left the one nearest the stream's centre
line wins when a centre line is given, else the fastest by half again (the straw
leaves the tip of the blade at the tip's speed, faster than the centroid of any part
of the rotor); otherwise the choice is ambiguous (:attr:`Acquirer.ambiguous`).
"""

import numpy as np

from vidtrack.track._rods import rodlike, rodlike_run

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
            deg = min(self.max_degree, 2 if m >= 4 else (1 if m >= 2 else 0))
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

    __slots__ = ("points", "blobs", "parts")

    def __init__(self, t, blob):
        self.points = [(t, blob.u, blob.v)]
        self.blobs = [blob]
        self.parts = ()

    @property
    def last_t(self):
        return self.points[-1][0]

    @property
    def polarity(self):
        return self.blobs[-1].polarity

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

    def velocity(self, n=4):
        """Mean velocity (px/frame) over the last ``n`` points."""
        pts = self.points[-n:]
        (t0, u0, v0), (t1, u1, v1) = pts[0], pts[-1]
        dt = max(t1 - t0, 1e-9)
        return np.array([(u1 - u0) / dt, (v1 - v0) / dt])

    def add(self, t, blob):
        self.points.append((t, blob.u, blob.v))
        self.blobs.append(blob)
        if len(self.points) > MAX_POINTS:
            del self.points[0]
            del self.blobs[0]

    def size(self, n=8):
        """Typical linear size (px): the square root of the median mask area."""
        return float(np.sqrt(np.median([b.mask_area for b in self.blobs[-n:]])))

    def travel(self):
        """Farthest distance (px) of any point from the first."""
        p = np.array([q[1:] for q in self.points])
        return float(np.max(np.hypot(*(p - p[0]).T)))

    def path_rms(self, n=12):
        """RMS distance (px) of the last ``n`` points from a quadratic in time (NaN below 5)."""
        pts = np.array(self.points[-n:])
        if len(pts) < 5:
            return float("nan")
        t = pts[:, 0] - pts[-1, 0]
        a = np.vander(t, 3)
        coef, *_ = np.linalg.lstsq(a, pts[:, 1:], rcond=None)
        r = pts[:, 1:] - a @ coef
        return float(np.sqrt(np.sum(r * r) / max(len(pts) - 3, 1)))

    def area_ratio(self, n=8):
        a = np.array([b.mask_area for b in self.blobs[-n:]], float)
        return float(a.max() / max(a.min(), 1.0))

    def steady(self, confirm, *, min_motion, slow=False):
        """Seen ``confirm`` times in a row (a frame missed between them allowed: only a
        tracklet of any shape but a rod's is picked up over one), moving, and the last
        point where predicted."""
        if len(self.points) < confirm:
            return False
        pts = np.array(self.points[-confirm:])
        if np.any(np.diff(pts[:, 0]) > 2.5):
            return False
        step = np.hypot(*(pts[-1, 1:] - pts[0, 1:])) / max(pts[-1, 0] - pts[0, 0], 1e-9)
        if step < min_motion and not (slow and self.slow_but_moving()):
            return False
        # constant-velocity check of the last point from the two before it
        if confirm >= 3:
            (t0, u0, v0), (t1, u1, v1), (t2, u2, v2) = pts[-3], pts[-2], pts[-1]
            pu = u1 + (u1 - u0) * (t2 - t1) / max(t1 - t0, 1e-9)
            pv = v1 + (v1 - v0) * (t2 - t1) / max(t1 - t0, 1e-9)
            tol = 1.5 + 0.3 * step + 0.05 * self.size(confirm)
            if np.hypot(u2 - pu, v2 - pv) > tol:
                return False
        areas = np.array([b.mask_area for b in self.blobs[-confirm:]], float)
        return areas.max() <= 2.5 * max(areas.min(), 1.0)

    def slow_but_moving(self):
        """Moving, too slowly for the frame-to-frame test (an object filmed at 10 000
        frames/s, 0.1 px a frame): over its last :data:`SLOW_SPAN` points (frames, with
        none missed) it went at least :data:`SLOW_MIN_PX` along a straight line, its
        points off that line by at most 1/8 of the way (a still blob's centroid jitters
        about a place)."""
        pts = np.array(self.points[-SLOW_SPAN:])
        if len(pts) < SLOW_SPAN // 2 or np.any(np.diff(pts[:, 0]) > 1.5):
            return False
        t = pts[:, 0] - pts[0, 0]
        a = np.column_stack([t, np.ones_like(t)])
        coef, *_ = np.linalg.lstsq(a, pts[:, 1:], rcond=None)
        way = float(np.hypot(*coef[0])) * float(t[-1])
        off = float(np.sqrt(np.mean(np.sum((pts[:, 1:] - a @ coef) ** 2, axis=1))))
        return way >= SLOW_MIN_PX and off <= way / 8.0

    def flying(self, *, min_points=5):
        """Moving like a thrown object: far, smoothly, keeping its size.

        It has travelled at least twice its own size (a person's limb or a machine part
        swings about a place; a thrown object leaves it), its last points lie on a
        quadratic in time within ``max(0.75 px, 0.08 x size)`` (a free flight seen
        over a few frames; the centroid of a limb changing shape jitters) and its mask
        area changed by less than a factor of 2.
        """
        if len(self.points) < min_points:
            return False
        size = self.size()
        if self.travel() < max(2.0 * size, 8.0):
            return False
        rms = self.path_rms()
        if not rms <= max(0.75, 0.08 * size):
            return False
        return self.area_ratio() <= 2.0

    def almost_flying(self):
        """Half way to :meth:`flying`: travelled its own size, smoothly, keeping it."""
        if len(self.points) < 4:
            return False
        size = self.size()
        if self.travel() < max(size, 4.0):
            return False
        rms = self.path_rms()
        if np.isfinite(rms) and not rms <= max(0.75, 0.08 * size):
            return False
        return self.area_ratio() <= 2.0

    def sharpness(self, n=6):
        """(contrast, edge width) medians over the last ``n`` blobs (NaN if unknown); the
        edge width without what touches a blob in the other polarity."""
        c = [b.contrast for b in self.blobs[-n:] if np.isfinite(b.contrast)]
        w = [b.edge_w_alone for b in self.blobs[-n:] if np.isfinite(b.edge_w_alone)]
        return (float(np.median(c)) if c else np.nan, float(np.median(w)) if w else np.nan)

    def describe(self, origin=0):
        """``frame F at (u, v)`` of the last point (F a source index plus ``origin``)."""
        t, u, v = self.points[-1]
        return int(round(t)) + origin, (float(u), float(v))


#: Points (frames) over which a tracklet too slow for the acquirer's frame-to-frame
#: motion is seen to move (:meth:`Tracklet.slow_but_moving`), and the least way it must
#: go in them (px): 0.05 px a frame at least.
SLOW_SPAN = 40
SLOW_MIN_PX = 2.0
#: Most points a tracklet keeps.
MAX_POINTS = 256


def line_distance(u, v, line):
    """Distance (px) of a point from the line through two pixel points."""
    (a0, b0), (a1, b1) = line
    du, dv = a1 - a0, b1 - b0
    norm = np.hypot(du, dv)
    if norm == 0:
        return float(np.hypot(u - a0, v - b0))
    return float(abs((u - a0) * dv - (v - b0) * du) / norm)


def _co_moving(a, b):
    """Two tracklets moving together, side by side, over their last (up to 6) common
    frames (one of them may have missed one)."""
    pa = {round(p[0], 3): p for p in a.points[-8:]}
    common = [k for k in (round(p[0], 3) for p in b.points[-8:]) if k in pa][-6:]
    if len(common) < 3:
        return False
    pb = {round(p[0], 3): p for p in b.points[-8:]}
    ta = np.array([pa[k] for k in common])
    tb = np.array([pb[k] for k in common])
    dt = max(ta[-1, 0] - ta[0, 0], 1e-9)
    va, vb = (ta[-1, 1:] - ta[0, 1:]) / dt, (tb[-1, 1:] - tb[0, 1:]) / dt
    speed = max(float(np.hypot(*va)), float(np.hypot(*vb)), 1e-9)
    if np.hypot(*(va - vb)) > 0.3 * speed + 1.0:
        return False
    d = np.hypot(*(ta[:, 1:] - tb[:, 1:]).T)
    reach = 1.5 * (a.size() + b.size()) + 4.0
    return bool(np.all(d <= reach)) and float(np.ptp(d)) <= 0.25 * reach + 2.0


def _touch(a, b, gap=2):
    """The boxes of two blobs touch (within ``gap`` px)."""
    ax0, ay0, ax1, ay1 = a.bbox
    bx0, by0, bx1, by1 = b.bbox
    return ax0 <= bx1 + gap and bx0 <= ax1 + gap and ay0 <= by1 + gap and by0 <= ay1 + gap


def _inside(a, b, gap=2):
    """``a``'s box lies within ``b``'s (grown by ``gap`` px)."""
    ax0, ay0, ax1, ay1 = a.bbox
    bx0, by0, bx1, by1 = b.bbox
    return bx0 - gap <= ax0 and by0 - gap <= ay0 and ax1 <= bx1 + gap and ay1 <= by1 + gap


def on_body(part, whole):
    """``part`` lies on ``whole``'s body (a highlight on a ball or a straw, a straw held
    by a blade): when ``whole`` is a rod, ``part``'s centre within its band (half its
    width and a pixel from its axis) and ``part``'s box within its length (and 1.5 px)
    along it; else ``part``'s centre within the disc of ``whole``'s area round its
    centre and its box within ``whole``'s (and a pixel). Not a piece beyond a rod's
    end (the blade's tip that threw it)."""
    if not (np.isfinite(whole.u) and np.isfinite(whole.v)):
        return False
    du, dv = part.u - whole.u, part.v - whole.v
    x0, y0, x1, y1 = part.bbox
    if (np.isfinite(whole.angle) and np.isfinite(whole.length) and np.isfinite(whole.width)
            and rodlike(whole)):
        ca, sa = np.cos(whole.angle), np.sin(whole.angle)
        across = abs(-du * sa + dv * ca)
        along = [(x - whole.u) * ca + (y - whole.v) * sa
                 for x in (x0, x1) for y in (y0, y1)]
        return bool(across <= 0.5 * whole.width + 1.0
                    and max(abs(a) for a in along) <= 0.5 * whole.length + 1.5)
    wx0, wy0, wx1, wy1 = whole.bbox
    r = np.sqrt(max(whole.mask_area, 1) / np.pi)
    return bool(wx0 - 1 <= x0 and wy0 - 1 <= y0 and x1 <= wx1 + 1 and y1 <= wy1 + 1
                and np.hypot(du, dv) <= r)


#: A part of the other polarity lying on an object of any shape but a rod's at least this
#: many times its size is of it (:func:`held`).
HELD_RATIO = 3.0


def held(blob, blobs, *, ratio=2.0):
    """``blob`` lies on the body of a larger object of the other polarity in ``blobs``:
    a part of it, not the object. A rod at least ``ratio`` times its size and no
    narrower (a dark straw's highlight), or an object of any other shape at least
    :data:`HELD_RATIO` times its size (a steel ball's highlight: small, it had flown
    twice its own size before the ball had flown twice the ball's, and was taken, every
    frame of it then flagged MERGED with the ball). (Among the parts of a textured
    object, light on dark, the whole is chosen otherwise.)"""
    if blob.polarity == 0:
        return False
    return any(b is not blob and b.polarity == -blob.polarity and on_body(blob, b) and (
        (b.mask_area >= ratio * blob.mask_area and rodlike(b) and not blob.width > b.width)
        or (b.mask_area >= HELD_RATIO * blob.mask_area and not rodlike(b)))
        for b in blobs)


def _merged_blob(a, b):
    """One blob of two that fly together (their silhouettes' area-weighted centre)."""
    import copy

    def sil(x):
        if x.silhouette is not None:
            return x.silhouette
        return (x.u, x.v, x.area if np.isfinite(x.area) else float(x.mask_area),
                x.angle, x.length, x.width)

    sa, sb = sil(a), sil(b)
    wa, wb = max(sa[2], 1e-9), max(sb[2], 1e-9)
    m = copy.copy(a if a.mask_area >= b.mask_area else b)
    m.u = (wa * sa[0] + wb * sb[0]) / (wa + wb)
    m.v = (wa * sa[1] + wb * sb[1]) / (wa + wb)
    m.area = wa + wb
    m.mask_area = a.mask_area + b.mask_area
    m.bbox = (min(a.bbox[0], b.bbox[0]), min(a.bbox[1], b.bbox[1]),
              max(a.bbox[2], b.bbox[2]), max(a.bbox[3], b.bbox[3]))
    w, h = m.bbox[2] - m.bbox[0], m.bbox[3] - m.bbox[1]
    m.length, m.width = float(max(w, h)), float(min(w, h))
    m.angle = 0.0 if w >= h else np.pi / 2
    m.silhouette = (m.u, m.v, m.area, m.angle, m.length, m.width)
    m.polarity = 0
    m.merged = a.merged or b.merged
    m.touches_border = a.touches_border or b.touches_border
    m.contrast = np.nanmax([a.contrast, b.contrast])
    m.edge_w = np.nanmin([a.edge_w, b.edge_w])
    m.edge_w_alone = np.nanmin([a.edge_w_alone, b.edge_w_alone])
    return m


def _compound(a, b):
    """A tracklet of two that fly together (a bear under its balloon), over the frames
    both were seen."""
    tb = {round(t, 6): k for k, (t, _, _) in enumerate(b.points)}
    out = None
    for k, (t, _, _) in enumerate(a.points):
        j = tb.get(round(t, 6))
        if j is None:
            continue
        m = _merged_blob(a.blobs[k], b.blobs[j])
        if out is None:
            out = Tracklet(t, m)
        else:
            out.add(t, m)
    if out is not None:
        out.parts = (a, b)
    return out


def _part_of(part, whole):
    """``part``'s last blob lies inside ``whole``'s last box."""
    pb, wb = part.blobs[-1], whole.blobs[-1]
    x0, y0, x1, y1 = wb.bbox
    return x0 - 1 <= pb.u <= x1 + 1 and y0 - 1 <= pb.v <= y1 + 1 and pb.mask_area <= wb.mask_area


def _shadow_like(a, b):
    """``a`` looks like the shadow or reflection of ``b``: dimmer or darker, and blurred.

    A shadow darkens the background and has soft edges (the penumbra); a reflection is
    a dimmer copy. Both move with the object, at about its size. ``a`` counts as one when
    its area is 0.4 to 2.5 times ``b``'s and its edges are at least 1.6 times as wide as
    ``b``'s, or its contrast is below half of ``b``'s while its edges are no sharper.
    """
    ab, bb = a.blobs[-1], b.blobs[-1]
    if ((_inside(ab, bb) or _inside(bb, ab))
            and np.hypot(ab.u - bb.u, ab.v - bb.v) < 0.25 * np.sqrt(max(ab.mask_area,
                                                                       bb.mask_area))):
        return False       # one holds the other, centred: a highlight on a ball, not a
        # copy (a blurred shadow's box may hold a thin rod's: it lies beside it)
    ratio = a.blobs[-1].mask_area / max(b.blobs[-1].mask_area, 1)
    if not 0.4 <= ratio <= 2.5:
        return False       # a shadow or a reflection is a copy of the object's size
    ca, wa = a.sharpness()
    cb, wb = b.sharpness()
    if not (np.isfinite(ca) and np.isfinite(cb) and np.isfinite(wa) and np.isfinite(wb)):
        return False
    if wa >= 1.6 * wb and (a.polarity < 0 or ca <= cb):
        return True
    return ca < 0.5 * cb and wa >= wb


class Acquirer:
    """Tentative tracklets of moving blobs; hands over the object when one is clear.

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
    slow : bool
        A tracklet slower than ``min_motion`` moves when it goes steadily over many
        frames (:meth:`Tracklet.slow_but_moving`): only where nothing moved faster in the
        whole footage (a rotor turning slowly would be taken).

    Notes
    -----
    A steady tracklet is handed over after ``confirm + 1`` frames when nothing else moves
    in the frame and its mask area stayed within a factor of 1.5.
    Otherwise (a person, a machine part, another object in view) only a tracklet that
    flies (:meth:`Tracklet.flying`) is: among several, shadows and reflections of
    another candidate are dropped, parts of one object of both polarities (a dark ball
    with a highlight) give way to the whole, the one nearest the centre line wins when
    one is given, else the fastest when it is at least 1.5 times as fast as the others
    (a straw leaves the blade's tip faster than any part of the rotor). Two that fly
    together, near each other (a bear under its balloon), are one compound object.
    Otherwise the
    choice is ambiguous: :attr:`ambiguous` lists the candidates and nothing is handed
    over.
    """

    def __init__(self, *, confirm, max_step, min_motion, centre_line=None, tiny_px=0,
                 slow=False):
        self.confirm = confirm
        self.slow = slow
        self.tiny_px = tiny_px
        self.max_step = max_step
        self.min_motion = min_motion
        self.centre_line = centre_line
        self.tracklets = []
        self.ambiguous = []
        self.waited = 0

    def reset(self):
        self.tracklets = []
        self.ambiguous = []
        self.waited = 0

    def _associate(self, t, blobs):
        # (a candidate of any shape but a rod's, missed in one frame, is picked up
        # again: a textured object's measurement can fail once)
        live = [tr for tr in self.tracklets if t - tr.last_t <= 1.5 or (
            t - tr.last_t <= 2.5 and not rodlike_run(tr.blobs))]
        if not live or not blobs:
            return live, set(), set()
        pu = np.array([b.u for b in blobs])
        pv = np.array([b.v for b in blobs])
        pa = np.array([max(b.mask_area, 1) for b in blobs], float)
        ppol = np.array([b.polarity for b in blobs])
        pred = np.array([tr.predict(t) for tr in live])
        gate = np.empty(len(live))
        area = np.empty(len(live))
        pol = np.empty(len(live))
        for i, tr in enumerate(live):
            area[i] = max(tr.blobs[-1].mask_area, 1)
            pol[i] = tr.polarity
            if len(tr.points) == 1:
                gate[i] = self.max_step
            else:
                step = np.hypot(*(np.array(tr.points[-1][1:]) - np.array(tr.points[-2][1:])))
                gate[i] = max(3.0, 0.5 * step + 3.0) + 0.1 * np.sqrt(area[i])
        dist = np.hypot(pu[None, :] - pred[:, 0:1], pv[None, :] - pred[:, 1:2])
        ratio = pa[None, :] / area[:, None]
        ok = ((dist <= gate[:, None]) & (ppol[None, :] == pol[:, None])
              & (ratio <= 4.0) & (ratio >= 0.25))
        ii, jj = np.nonzero(ok)
        order = np.argsort(dist[ii, jj], kind="stable")
        taken_tr, used = set(), set()
        for k in order:
            i, j = int(ii[k]), int(jj[k])
            if i in taken_tr or j in used:
                continue
            live[i].add(t, blobs[j])
            taken_tr.add(i)
            used.add(j)
        return live, taken_tr, used

    def update(self, t, blobs, *, accept=None):
        """Associate this frame's blobs; return the chosen tracklet or None.

        Parameters
        ----------
        t : float
            Time of the frame in frames.
        blobs : list of Blob
        accept : callable, optional
            ``accept(tracklet) -> bool``: a further test a candidate must pass (e.g.
            consistency with where a lost straw should be).
        """
        live, taken_tr, used = self._associate(t, blobs)
        fresh = [Tracklet(t, b) for j, b in enumerate(blobs) if j not in used]
        kept = [tr for i, tr in enumerate(live) if i in taken_tr]
        # (those missed in this frame are kept for the next, where :meth:`_associate`
        # picks up any but a rod's: picked up so, a dark straw riding its blade with a
        # rider was followed from 22 frames 0.5-3.4 px off, unflagged)
        missed = [tr for i, tr in enumerate(live) if i not in taken_tr]
        self.tracklets = kept + [tr for tr in missed if t - tr.last_t <= 1.5] + fresh
        self.ambiguous = []
        ready = [tr for tr in kept
                 if tr.steady(self.confirm, min_motion=self.min_motion, slow=self.slow)
                 and (accept is None or accept(tr))]
        # a part of a whole about to fly, missed in this frame only, does not take its
        # place
        wholes = ready + [tr for tr in missed if tr.almost_flying() and tr.steady(
            self.confirm, min_motion=self.min_motion, slow=self.slow)]
        if not ready:
            return None
        # a few noise pixels by the rotor can drift steadily for 3 frames: while a
        # candidate of some size is steady too, a tiny one is not the straw
        sizes = [min(b.mask_area for b in tr.blobs[-self.confirm:]) for tr in ready]
        if max(sizes) >= self.tiny_px:
            ready = [tr for tr, s in zip(ready, sizes) if s >= self.tiny_px]
        # a part lying on a larger rod of the other polarity (its highlight) is not
        # taken: the rod is
        ready = [tr for tr in ready if not held(tr.blobs[-1], blobs)]
        if not ready:
            return None
        if (len(ready) == 1 and len(ready[0].points) > self.confirm
                and ready[0].area_ratio() <= 1.5 and self._alone(ready[0], blobs)):
            # the one thing moving, keeping its size (a hand throwing changes shape)
            return ready[0]
        flying = [tr for tr in ready if tr.flying() and not self._part(tr, wholes)]
        # the shadow or reflection of a steady candidate beside it is not taken, even
        # when its path is the smoother (the object itself still rides a blade)
        flying = [tr for tr in flying
                  if not any(q is not tr and _co_moving(tr, q) and _shadow_like(tr, q)
                             for q in ready)]
        if not flying:
            return None
        flying = self._distinct(flying)
        flying = self._together(flying, ready)
        # a small piece moving beside a larger object that flies too is not the object
        # (the blade's tip beside the straw it throws)
        flying = [a for a in flying
                  if not any(b is not a and _co_moving(a, b)
                             and a.blobs[-1].mask_area < 0.5 * b.blobs[-1].mask_area
                             for b in flying)]
        if not flying:
            return None
        if self.centre_line is not None:
            return min(flying, key=lambda tr: line_distance(tr.points[-1][1], tr.points[-1][2],
                                                            self.centre_line))
        speeds = sorted(((tr.speed(), k) for k, tr in enumerate(flying)), reverse=True)
        if len(flying) > 1 and speeds[0][0] < 1.5 * speeds[1][0]:
            self.ambiguous = flying
            return None
        best = flying[speeds[0][1]]
        # another object about to fly as well, as fast: wait until it is clear
        # whether it does (two balls thrown together: the first to have travelled
        # twice its size is not therefore the one)
        members = {id(best)} | {id(q) for q in best.parts}
        # (one moving with it counts when it is more than twice its size: a small
        # piece beside a larger object is more likely part of the scene than the object)
        big = best.blobs[-1].mask_area
        rivals = [tr for tr in ready if id(tr) not in members and tr.almost_flying()
                  and tr.speed() * 1.5 > best.speed() and not self._part(tr, ready)
                  and (tr.blobs[-1].mask_area > 2.0 * big
                       or not any(_co_moving(tr, q) for q in (best, *best.parts)))]
        if rivals and self.waited < 4 * self.confirm:
            self.waited += 1
            return None
        self.waited = 0
        return best

    def _alone(self, tr, blobs):
        """Nothing but ``tr``'s blob (and its other-polarity views) moves in this frame."""
        own = tr.blobs[-1]
        x0, y0, x1, y1 = own.bbox
        for b in blobs:
            if b is own or b.mask_area < max(self.tiny_px, 0.1 * own.mask_area):
                continue
            bx0, by0, bx1, by1 = b.bbox
            if bx0 <= x1 + 2 and x0 <= bx1 + 2 and by0 <= y1 + 2 and y0 <= by1 + 2:
                continue      # the same object seen in the other polarity, or touching
            return False
        return True

    def _part(self, tr, ready):
        """``tr`` is a piece of a larger object that moves with it.

        A piece of the same polarity near a larger steady blob that moves with it (within
        a quarter of the larger one's size), or of the other polarity, no rod and at
        least a tenth of its size
        (an object split where it matches the background), or of the other polarity
        and at least a third of its size: the object is taken when the whole flies
        (its size sets how far it must travel first). A straw riding a large blade of
        the other polarity is not a piece of it.
        """
        own = tr.blobs[-1]
        for other in ready:
            ob = other.blobs[-1]
            if (other is tr or ob.mask_area <= own.mask_area
                    or not _touch(own, ob, gap=max(2.0, 0.25 * np.sqrt(ob.mask_area)))):
                continue
            if (ob.polarity != 0 and ob.polarity != own.polarity
                    and ob.mask_area > 3.0 * own.mask_area and not _inside(own, ob)
                    and (rodlike(own) or ob.mask_area > 10.0 * own.mask_area)):
                continue
            if _co_moving(tr, other) and not _shadow_like(other, tr):
                return True
        return False

    def _together(self, flying, ready):
        """Objects that fly together, tied or side by side within the larger one's
        size (a bear under its balloon), are one: their compound is taken. Not rods: a
        straw riding a blade moves with it until it leaves."""
        out = []
        for a in flying:
            if rodlike(a.blobs[-1]):     # a straw riding a blade is not tied to it
                out.append(a)
                continue
            partners = []
            for b in ready:
                if b is a or any(b is q for q in a.parts):
                    continue
                ab, bb = a.blobs[-1], b.blobs[-1]
                size = np.sqrt(max(ab.mask_area, bb.mask_area))
                if (bb.mask_area < 0.05 * ab.mask_area or rodlike(bb)
                        or _inside(bb, ab) or _inside(ab, bb)   # a part of it, or it of one
                        or not _touch(ab, bb, gap=size)
                        or not _co_moving(a, b) or _shadow_like(b, a) or _shadow_like(a, b)
                        or len(b.points) < self.confirm):
                    continue
                partners.append(b)
            c = a
            for b in sorted(partners, key=lambda q: -q.blobs[-1].mask_area):
                merged = _compound(c, b)
                if merged is None or len(merged.points) < self.confirm:
                    continue
                merged.parts = (*(c.parts or (c,)), b)
                c = merged
            out.append(c)
        # one compound per pair
        seen, uniq = [], []
        for tr in out:
            key = {id(q) for q in tr.parts} or {id(tr)}
            if any(key & k for k in seen):
                continue
            seen.append(key)
            uniq.append(tr)
        return uniq

    def _distinct(self, flying):
        """Drop shadows, reflections and parts of another candidate."""
        drop = set()
        for i, a in enumerate(flying):
            for j, b in enumerate(flying):
                if i == j or i in drop or j in drop or not _co_moving(a, b):
                    continue
                if _shadow_like(a, b):
                    drop.add(i)
                elif a.polarity != 0 and b.polarity == 0 and _part_of(a, b):
                    # a part of a two-polarity whole: the whole, unless the other
                    # part dwarfs this one (a straw riding a large blade)
                    others = [c for c in flying if c is not a and c.polarity == -a.polarity
                              and _part_of(c, b) and _co_moving(c, b)]
                    big = max((c.blobs[-1].mask_area for c in others), default=0)
                    if big <= 3.0 * a.blobs[-1].mask_area:
                        drop.add(i)
                elif a.polarity == 0 and b.polarity != 0 and _part_of(b, a):
                    others = [c for c in flying if c is not b and c.polarity == -b.polarity
                              and _part_of(c, a)]
                    if not others:
                        drop.add(i)   # a whole made of one part: the part itself
        return [tr for k, tr in enumerate(flying) if k not in drop]


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
