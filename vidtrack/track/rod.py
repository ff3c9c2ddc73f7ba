"""A rod's image as a model: a blurred bar fitted to the pixels round it.

The flight tracker measures an elongated object (a straw, a stick: its spread along at
least :data:`vidtrack.track.measure.ROD_ASPECT` times its spread across) by fitting

    c(x, y) = a * B(w, r, s) * B(h, q, s2),
    B(w, r, s) = G(w - r + 1/2) - G(w - r - 1/2) - G(-w - r + 1/2) + G(-w - r - 1/2),
    G(x) = s * (z Phi(z) + phi(z)),  z = x / s

(a bar ``2w`` by ``2h`` blurred by a normal law and seen through the pixel's unit box:
``G`` is the integral of the blurred step) to each pixel's coverage ``c`` (its
difference from the background over the object's own contrast there, not clipped: noise
stays unbiased), with ``q, r`` a pixel centre's
distance along and across the bar of centre ``(u, v)`` and angle ``theta``; ``h`` and
``w`` the bar's half length and half width, ``a`` its coverage (1 for an opaque rod),
``s`` its blur across (optics, the pixel), ``s2`` along (motion blur). The bar's centre
is a uniform rod's coverage centroid. The fit is robust (scipy's least squares with the
soft-l1 loss at :data:`BAR_F_SCALE` of full coverage): the pixels of what touches the rod
or lies beside it (a blade, a second straw, a shadow), which the bar does not explain,
weigh little, where a centroid weighs every pixel alike.
"""

import math

import numpy as np

__all__ = ["fit_rod", "F_SCALE", "BAR_F_SCALE", "MIN_LENGTH_PX", "FOOTPRINT_SHARE",
           "END_COLUMNS"]

#: A rod's track's columns for its two ends (px): the ends of the bar fitted to it
#: (:func:`vidtrack.track.flight.rod_ends`).
END_COLUMNS = ("end1_u_px", "end1_v_px", "end2_u_px", "end2_v_px")

#: The robust loss of the fits (scipy's ``least_squares``), and the scale of the
#: residuals it is taken at (coverage) for a compact object's ellipse
#: (:mod:`vidtrack.track.ellipse`) ...
LOSS = "soft_l1"
F_SCALE = 0.1

#: ... and for a rod's bar. A bar is placed along its length by its two ends alone,
#: where compression's ringing makes residuals of a few tenths: at 0.1 those pixels
#: weighed little and the point wandered along the straw (the sample run's settings at
#: MJPG quality 40, seed 10's front view: 0.036 px RMS from the truth, all of it along;
#: 0.026 at 0.2, 0.023 at 0.3). At 0.3 the end of a dark straw just off the blade of its
#: own polarity, in line with it, pulled one frame to 0.51 px
#: (``tests/test_synth_distractors.py``, ``dark``).
BAR_F_SCALE = 0.2

#: A rod shorter than this (px, twice its half length) is not fitted: nearly end on, its
#: length and its blur cannot be told apart.
MIN_LENGTH_PX = 5.0

#: Bounds of the half width, the coverage, the blur across and along (px, 1, px, px).
_WIDTH = (0.15, 20.0)
_COVER = (0.05, 1.5)
_BLUR = (0.2, 3.0)
_BLUR_ALONG = (0.2, 8.0)

#: The bar's footprint, where its misfit is taken: the pixels it covers at least this
#: share of its coverage ``a`` (half: its core, not its blurred fringe, where a neighbour
#: beside it would count).
FOOTPRINT_SHARE = 0.5

#: The fitted centre may lie at most this many half lengths from the start: beyond, the
#: fit ran off (the start is kept).
MAX_SHIFT = 0.5

_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)


def _phi(z):
    return _INV_SQRT_2PI * np.exp(-0.5 * z * z)


#: The edges (+1/2, -1/2 px: the pixel's box) of the four blurred ramps that make a bar
#: seen through the pixel's box, the ramps at ``+half`` first, then at ``-half``, with
#: signs ``+, -, -, +``.
_EDGES = np.array([0.5, -0.5, 0.5, -0.5])[:, None]
_HALF = np.array([1.0, 1.0, -1.0, -1.0])


def _profiles(half, t, s):
    """Bars of half widths ``half`` (2,) blurred by ``s`` (2,), each integrated over the
    pixel's unit box round its row of ``t`` (2, n); per bar its value and derivatives
    by ``t``, ``half`` and ``s``, as four (2, n) arrays.

    The bar across the rod and the bar along it are worked out together (one call of
    ``ndtr`` and of ``exp`` for both: the profiles cost a fit most of its time), and the
    four ramps of each are combined one after another, ``((r0 - r1) - r2) + r3``, as a
    sum over them with their signs adds them: the same numbers bit for bit.
    """
    from scipy.special import ndtr

    z = (half[:, None, None] * _HALF[None, :, None] - t[:, None, :] + _EDGES) / s[:, None, None]
    cdf = ndtr(z)
    pdf = np.multiply(z, -0.5)
    pdf *= z
    np.exp(pdf, out=pdf)
    pdf *= _INV_SQRT_2PI
    g = z * cdf
    g += pdf
    val = s[:, None] * (((g[:, 0] - g[:, 1]) - g[:, 2]) + g[:, 3])
    d_t = -(((cdf[:, 0] - cdf[:, 1]) - cdf[:, 2]) + cdf[:, 3])
    d_half = ((cdf[:, 0] - cdf[:, 1]) + cdf[:, 2]) - cdf[:, 3]
    d_s = ((pdf[:, 0] - pdf[:, 1]) - pdf[:, 2]) + pdf[:, 3]
    return val, d_t, d_half, d_s


def _parts(p, x, y):
    u, v, th, h, w, _a, s, s2 = p
    ca, sa = math.cos(th), math.sin(th)
    dx, dy = x - u, y - v
    qr = np.empty((2, x.size))
    q, r = qr[1], qr[0]
    np.add(dx * ca, dy * sa, out=q)
    np.subtract(dy * ca, dx * sa, out=r)
    # (across the rod: half width w along r, blur s; along it: half length h along q,
    # blur s2)
    val, d_t, d_half, d_s = _profiles(np.array([w, h]), qr, np.array([s, s2]))
    return (ca, sa, q, r, (val[0], d_t[0], d_half[0], d_s[0]),
            (val[1], d_t[1], d_half[1], d_s[1]))


def _model(p, x, y):
    *_, across, along = _parts(p, x, y)
    return p[5] * across[0] * along[0]


def _jacobian(p, x, y, parts=None):
    a = p[5]
    ca, sa, q, r, (ac, ac_r, ac_w, ac_s), (al, al_q, al_h, al_s) = (
        _parts(p, x, y) if parts is None else parts)
    # (column-major, as least squares was always handed it: a column taken out by
    # indexing is; its sums over the pixels then add in the same order)
    jac = np.empty((8, x.size)).T
    # (dq/du = -cos, dq/dv = -sin, dr/du = sin, dr/dv = -cos; dq/dth = r, dr/dth = -q)
    jac[:, 0] = a * (ac_r * sa * al - ac * al_q * ca)
    jac[:, 1] = a * (-ac_r * ca * al - ac * al_q * sa)
    jac[:, 2] = a * (-ac_r * q * al + ac * al_q * r)
    jac[:, 3] = a * ac * al_h
    jac[:, 4] = a * ac_w * al
    jac[:, 5] = ac * al
    jac[:, 6] = a * ac_s * al
    jac[:, 7] = a * ac * al_s
    return jac


class _Cached:
    """The model and its Jacobian at the last parameters (least squares asks for both at
    each point it tries: the bar's profiles are computed once)."""

    def __init__(self, x, y, cover):
        self.x, self.y, self.cover = x, y, cover
        self.p = None
        self.parts = None

    def _at(self, p):
        # (an element-wise test: np.array_equal's checks cost more than it, each call)
        if self.p is None or not (p == self.p).all():
            self.p = np.array(p, copy=True)
            self.parts = _parts(p, self.x, self.y)
        return self.parts

    def residual(self, p):
        *_, across, along = self._at(p)
        return p[5] * across[0] * along[0] - self.cover

    def jacobian(self, p):
        return _jacobian(p, self.x, self.y, self._at(p))


def _rms(r):
    return float(np.sqrt(np.mean(r * r))) if r.size else 0.0


def fit_rod(x, y, cover, start, profile=None, measured=None, cap_px=2.0, hold=()):
    """The bar fitted to the coverage ``cover`` at pixel centres ``(x, y)``, from
    ``start = (u, v, theta, half_length, half_width)`` and, where given, ``profile``
    (the half width, coverage and blurs across and along of the bar fitted to the frame
    before: a start nearer the answer); None when the rod is too short, the fit fails or
    runs off. ``measured`` (bool per pixel, default all): the pixels whose coverage was
    measured, not filled in (a highlight's): only they count towards the misfit.
    ``cap_px`` (``bar_cap_px``): how far beyond the bar's ends its misfit is also taken
    (something in line with an end moves it, and the centre along). ``hold``: the
    indices of the parameters (of ``u, v, theta, h, w, a, s, s2``) held at their start
    (the rod's own length, width and blurs, where what it is joined to could be taken
    for more of it).

    Returns
    -------
    (float, float, numpy.ndarray, float, float) or None
        The centre (u, v), the fitted parameters (u, v, theta, h, w, a, s, s2), the
        misfit: the RMS residual over the bar's footprint (the pixels it covers at least
        :data:`FOOTPRINT_SHARE` of its coverage ``a``, and the caps ``cap_px``
        beyond its ends) over ``a``, small for the rod alone, large where something
        overlaps it or lies in line with an end (beside it, outside the footprint, it
        does not count); and the footprint's own (the caps apart): where part of the rod
        is hidden, the bar fitted to the rest misfits its own pixels, while the caps
        vary with the ringing and blur at the ends.
    """
    from scipy.optimize import least_squares

    u0, v0, th0, h0, w0 = start
    if 2.0 * h0 < MIN_LENGTH_PX or x.size < 12:
        return None
    p0 = np.array([u0, v0, th0, h0, np.clip(w0, *_WIDTH), 1.0, 0.5, 0.7])
    if profile is not None:
        p0[4:] = profile
    lo = np.array([-np.inf, -np.inf, -np.inf, 0.5, _WIDTH[0], _COVER[0], _BLUR[0],
                   _BLUR_ALONG[0]])
    hi = np.array([np.inf, np.inf, np.inf, np.inf, _WIDTH[1], _COVER[1], _BLUR[1],
                   _BLUR_ALONG[1]])
    p0 = np.clip(p0, lo, hi)
    cached = _Cached(x, y, cover)
    free = np.setdiff1d(np.arange(p0.size), np.asarray(hold, int))

    def full(q):
        p = p0.copy()
        p[free] = q
        return p

    if free.size == p0.size:
        # (nothing held: the parameters are the free ones, no copies to make)
        fun, jac = cached.residual, cached.jacobian
    else:
        fun = lambda q: cached.residual(full(q))            # noqa: E731
        jac = lambda q: cached.jacobian(full(q))[:, free]   # noqa: E731
    try:
        res = least_squares(fun, p0[free], jac=jac,
                            bounds=(lo[free], hi[free]), loss=LOSS, f_scale=BAR_F_SCALE,
                            xtol=1e-5, ftol=1e-5, max_nfev=60)
    except (ValueError, np.linalg.LinAlgError):
        return None
    if not (res.success and np.isfinite(res.x).all()):
        return None
    res.x = full(res.x)
    u, v = float(res.x[0]), float(res.x[1])
    if math.hypot(u - u0, v - v0) > MAX_SHIFT * h0:
        return None
    resid = cached.residual(res.x)
    _, _, q, r, *_ = cached.parts
    h, w = res.x[3], res.x[4]
    foot = (resid + cover) >= FOOTPRINT_SHARE * res.x[5]
    caps = (np.abs(r) <= w) & (np.abs(q) > h) & (np.abs(q) <= h + cap_px)
    if measured is not None:
        foot &= measured
        caps &= measured
    own = _rms(resid[foot]) / res.x[5]
    return u, v, res.x, max(own, _rms(resid[caps]) / res.x[5]), own
