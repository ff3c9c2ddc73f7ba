"""A compact object measured by its own appearance: its matte over the walls it crosses.

An object that keeps its look as it flies (a toy, a ball that does not turn) carries its
image with it while the wall passes under it. Over frames of its chain aligned on the
object (crops centred on its points), each object-relative pixel ``x`` follows

    C_j(x) = a(x) + beta(x) * B_j(x)        (a = alpha * F, beta = 1 - alpha)

with ``C_j`` the frame's crop and ``B_j`` the background's under it: triangulation
matting (Smith and Blinn 1996) over many backgrounds, fitted by least squares across
the frames, ``beta`` drawn towards 1 (the wall) where the wall under ``x`` does not
vary. A shadow dims the wall (``a`` near 0, ``beta`` in ``[shadow_ratio_min, 1)``) and
has no coverage; elsewhere the coverage is ``1 - beta``, of every tone alike (parts of
the object of the wall's own level included, which a difference from the background
misses), and the object's centre is the coverage centroid of the region round the
crop's centre. Each frame's shift ``s`` is then fitted (Gauss-Newton, Huber weights):
``C_i(x) ~ a(x - s) + beta(x - s) * B_i(x)``. The sample is aligned by the shifts and
the matte fitted again, :data:`ROUNDS` times.

The matte measures the object only where it is the object's model and a better one than
the outline's (the settings): over the sample, the median RMS residual at the matte's
shifts (over the object's region) is at most ``matte_misfit_max`` times the pixel noise
(it keeps its look), and the median of each frame's residual at its point (moved by the
points' mean offset from the matte's) over that at the matte's shift is at least
``matte_gain_min``. An object that turns or changes (a tumbling straw, a shuttlecock, a
bear) or a shadow that moves under it leaves the matte a misfit of several noises; an
object its outline measures well (a ball of one tone) leaves it no gain: both keep the
outline's points.
"""

import cv2
import numpy as np

__all__ = ["Matte", "Placer", "fit_matte", "fit_sample", "crop", "MATTE_FRAMES"]

#: Sample frames the matte is fitted over (spread over the chain's explained frames).
MATTE_FRAMES = 48

#: Rounds of fitting the matte and aligning the sample by its shifts.
ROUNDS = 3

#: The rounds lower a matte's misfit by aligning the sample: from the outline's points
#: to the matte's own, the textured toys' went from 1.8-2.6 to 0.97-1.19 noises. A round
#: whose misfit is beyond this many times the misfit wanted ends the fit (the real
#: clips: 6-40 noises; the bear under its balloon: one round, 10 % of its tracking's CPU
#: against 14 % for three).
ROUNDS_LOWER = 3.0

#: Room (px) round each sample frame's crop for the shifts of the rounds.
PAD = 6

#: The crop's half size in the object's half extents (twice its spread along): room for
#: the object whole where its points are off by a part of its size, and its shifts.
REACH = 2.0

#: Where the wall under a pixel varies little across the sample, ``beta`` is drawn
#: towards 1 with this weight (in noise variances): a plain wall tells nothing of it.
RIDGE = 4.0

#: Huber's constant of the shift's fit, in robust scatters of the residual.
HUBER = 2.5

#: The shift's fit stops when its step is below this (px), or after :data:`SHIFT_ITERS`.
SHIFT_TOL = 1e-3
SHIFT_ITERS = 8

#: A pixel that dims the wall (``beta`` in ``[ratio_min, 1)``) is a shadow's where its
#: ``a`` is nought within this many of its standard errors plus :data:`SHADOW_NOISE`
#: pixel noises (a shadow adds no light of its own).
SHADOW_SE = 3.0
SHADOW_NOISE = 2.0

#: The region round the crop's centre: the connected pixels of coverage above this.
REGION_COVER = 0.2

#: The object's region for the gain: its coverage above :data:`REGION_COVER`, grown by
#: this many px (its blurred rim).
REGION_PAD = 2


class Matte:
    """An object's matte: ``a`` and ``beta`` per crop pixel, its coverage and its
    shadow's pixels; ``centre`` is the coverage centroid relative to the crop's centre
    (px, u then v)."""

    __slots__ = ("a", "beta", "cover", "shadow", "centre", "_grads", "_region")

    def __init__(self, a, beta, cover, shadow):
        self.a, self.beta, self.cover, self.shadow = a, beta, cover, shadow
        self.centre = _centroid(cover)
        near = cv2.dilate((cover > REGION_COVER).astype(np.uint8),
                          np.ones((2 * REGION_PAD + 1,) * 2, np.uint8)) > 0
        self._region = near[2:-2, 2:-2]
        gy_a, gx_a = np.gradient(a)
        gy_b, gx_b = np.gradient(beta)
        self._grads = (gx_a, gy_a, gx_b, gy_b)

    def residual(self, c, b, s):
        """``c - (a(x - s) + beta(x - s) * b)`` over the crop's inner pixels."""
        a, beta = _warp(self.a, s), _warp(self.beta, s)
        return (c - (a + beta * b))[2:-2, 2:-2]

    def rms(self, c, b, s):
        """The RMS residual at shift ``s`` (grey levels) over the object's region (its
        coverage above :data:`REGION_COVER`, grown by :data:`REGION_PAD`): the wall
        round it, explained alike at any shift, does not dilute it."""
        r = self.residual(c, b, s)[self._region]
        return float(np.sqrt(np.mean(r * r))) if r.size else 0.0

    def shift(self, c, b):
        """The shift (px, u then v) of the object in crop ``c`` over wall ``b``."""
        s = np.zeros(2)
        for _ in range(SHIFT_ITERS):
            r = self.residual(c, b, s).ravel()
            gx_a, gy_a, gx_b, gy_b = (_warp(g, s) for g in self._grads)
            inner = np.s_[2:-2, 2:-2]
            jx = -(gx_a + gx_b * b)[inner].ravel()
            jy = -(gy_a + gy_b * b)[inner].ravel()
            scale = 1.4826 * np.median(np.abs(r)) + 1e-6
            w = np.minimum(1.0, HUBER * scale / np.maximum(np.abs(r), 1e-12))
            j = np.column_stack([jx, jy])
            h = j.T @ (j * w[:, None])
            try:
                step = np.linalg.solve(h + 1e-6 * np.eye(2), j.T @ (w * r))
            except np.linalg.LinAlgError:
                break
            s = s + step
            if not np.isfinite(s).all():
                return np.zeros(2)
            if np.hypot(*step) < SHIFT_TOL:
                break
        return s


def crop(image, u, v, size):
    """The ``size`` x ``size`` crop of ``image`` centred on ``(u, v)`` (float64; an 8-bit
    frame is interpolated as it is, not converted whole first)."""
    image = np.asarray(image)
    if image.dtype not in (np.uint8, np.float32):
        image = image.astype(np.float32)
    return cv2.getRectSubPix(image, (size, size), (float(u), float(v)),
                             patchType=cv2.CV_32F).astype(np.float64)


def fit_matte(c, b, noise, ratio_min):
    """The :class:`Matte` of crops ``c`` over walls ``b`` (``(n, size, size)``), the
    pixel noise ``noise`` (grey levels), a shadow dimming to no less than ``ratio_min``."""
    n = c.shape[0]
    mb, mc = b.mean(0), c.mean(0)
    db, dc = b - mb, c - mc
    lam = RIDGE * noise ** 2
    beta = ((db * dc).sum(0) + lam) / ((db * db).sum(0) + lam)
    a = mc - beta * mb
    res = dc - beta * db
    s2 = (res * res).sum(0) / max(n - 2, 1)
    se_a = np.sqrt(s2 * (1.0 / n + mb ** 2 / ((db * db).sum(0) + lam)))
    dims = (beta >= ratio_min) & (beta < 1)
    shadow = dims & (np.abs(a) <= SHADOW_SE * se_a + SHADOW_NOISE * noise)
    cover = np.clip(1.0 - beta, 0.0, 1.0)
    cover[shadow] = 0.0
    return Matte(a, beta, cover, shadow)


def _warp(z, s):
    """``z(x - s)``: the crop moved by ``s`` (px), its edge repeated."""
    size = z.shape[1], z.shape[0]
    m = np.float32([[1, 0, s[0]], [0, 1, s[1]]])
    return cv2.warpAffine(z.astype(np.float32), m, size, flags=cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_REPLICATE).astype(np.float64)


def _centroid(cover):
    """The coverage centroid (px from the crop's centre) of the connected region of
    coverage above :data:`REGION_COVER` at the centre (of all coverage where none)."""
    size = cover.shape[0]
    yy, xx = np.mgrid[0:size, 0:size] - (size - 1) / 2.0
    _, lab = cv2.connectedComponents((cover > REGION_COVER).astype(np.uint8))
    w = cover
    at = lab[size // 2, size // 2]
    if at > 0:
        w = np.where(lab == at, cover, 0.0)
    total = w.sum()
    if total <= 0:
        return np.zeros(2)
    return np.array([(w * xx).sum() / total, (w * yy).sum() / total])


def fit_sample(get, sample, u, v, bg, noise, major, ratio_min, misfit_max=np.inf):
    """The object's matte over the frames ``sample`` and how much better it explains
    them than the points ``u, v`` (see the module's text).

    Parameters
    ----------
    get : callable
        Frame position -> its frame (steadied).
    sample : numpy.ndarray
        The frame positions the matte is fitted over.
    u, v : numpy.ndarray
        The points by the outline's model (px), per frame position.
    bg : numpy.ndarray
        The background image.
    noise : float
        The pixel noise (grey levels).
    major : float
        The object's spread along its major axis (px).
    ratio_min : float
        The least factor by which a shadow dims the wall.
    misfit_max : float, optional
        The misfit (noises) the matte is wanted within: a round whose misfit is beyond
        :data:`ROUNDS_LOWER` times it ends the fit (its gain NaN).

    Returns
    -------
    Placer
        The matte, its crop size, the points' mean offset from the matte's, the gain and
        the misfit (the median RMS residual at the matte's shifts, in noises).
    """
    size = 2 * int(np.ceil(REACH * 2.0 * major)) + 1
    pts = np.column_stack([u[sample], v[sample]]).astype(np.float64)
    # (each frame read once: a crop with room for the shifts, cropped again each round)
    room = size + 2 * PAD
    held = [crop(get(int(i)), *p, room) for i, p in zip(sample, pts)]
    mid = (room - 1) / 2.0
    cur = pts.copy()
    for _ in range(ROUNDS):
        c = np.array([crop(h, *(q - p + mid), size) for h, q, p in zip(held, cur, pts)])
        b = np.array([crop(bg, *q, size) for q in cur])
        m = fit_matte(c, b, noise, ratio_min)
        shifts = np.array([m.shift(ci, bi) for ci, bi in zip(c, b)])
        at_shift = np.array([m.rms(ci, bi, s) for ci, bi, s in zip(c, b, shifts)])
        misfit = float(np.median(at_shift)) / max(noise, 1e-9)
        cur = cur + shifts
        if misfit > ROUNDS_LOWER * misfit_max:
            # (no rounds of aligning make this the object's model)
            return Placer(m, size, np.zeros(2), float("nan"), misfit, 0.0)
    # (the gain: each sample frame's residual at its own point, moved by the mean
    # offset of the matte's points from them, over that at the matte's shift)
    offset = np.mean(cur - pts, axis=0)
    own = pts + offset - (cur - shifts)
    at_own = np.array([m.rms(ci, bi, o) for ci, bi, o in zip(c, b, own)])
    gain = float(np.median(at_own / np.maximum(at_shift, 1e-9)))
    return Placer(m, size, offset, gain, misfit, max(2.0 * major, 1.0))


class Placer:
    """A matte fitted over a sample (:func:`fit_sample`): places the object in a frame
    from its point by the outline's model."""

    __slots__ = ("matte", "size", "offset", "gain", "misfit", "reach")

    def __init__(self, matte, size, offset, gain, misfit, reach):
        self.matte, self.size, self.offset, self.gain = matte, size, offset, gain
        self.misfit, self.reach = misfit, reach

    def place(self, frame, bg, u, v):
        """The object's centre (px) in ``frame`` near the outline's point ``(u, v)``: its
        matte's shift there and the matte's centre (the point moved by the mean offset
        where the shift runs beyond the object's half extent)."""
        p = np.array([u, v]) + self.offset
        s = self.matte.shift(crop(frame, *p, self.size), crop(bg, *p, self.size))
        if not np.hypot(*s) <= self.reach:
            s = np.zeros(2)
        return p + s + self.matte.centre
