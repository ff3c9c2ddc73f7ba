"""A compact object's image as a model: a blurred ellipse fitted to the pixels round it.

The flight tracker measures a compact object (a ball, a cup: its spread along less than
:data:`vidtrack.track.measure.ROD_ASPECT` times its spread across) by fitting

    c(x, y) = a * Phi(-d(x, y) / s),
    d = (rho^2 - 1) / |grad rho^2|,  rho^2 = (q / A)^2 + (r / B)^2

to each pixel's coverage ``c`` (its difference from the background over the object's
own contrast there, not clipped), with ``q, r`` a pixel centre's distance along and
across the ellipse of centre ``(u, v)`` and angle ``theta``, ``A`` and ``B`` its
semi-axes, ``a`` its coverage (1 for an opaque object) and ``s`` its blur (optics,
motion; with the pixel's box). The semi-axes are not free: they follow from the
object's spreads over its chain and the blur, so a part hidden (behind a post) or
something touching the object is a misfit, not a smaller or larger ellipse. ``d`` is the
distance from the outline to first order (exact at the outline, the only place where
``Phi`` is not 0 or 1). The ellipse's centre is a uniform ellipse's coverage centroid.
The fit is robust (scipy's least squares, the soft-l1 loss at
:data:`~vidtrack.track.rod.F_SCALE` of full coverage): what touches the object (a
blade, a hand, its shadow), which the ellipse does not explain, weighs little, where a
centroid weighs every pixel alike. Each residual may be weighed by how well its
pixel tells the coverage (the object's contrast against the wall there over its full
contrast): a pixel over a patch of the wall of the object's own level tells little. With
its spreads free, the fit measures the object's shape (in frames where it is seen whole).

An object that is no ellipse (a shuttlecock, a bear) is not measured by one: the fit is
kept only where its misfit over the best-explained :data:`EXPLAINED_SHARE` of the
ellipse's footprint is at most ``max_misfit`` (the setting ``model_max_misfit``).
"""

import math

import numpy as np

from vidtrack.track.rod import F_SCALE, FOOTPRINT_SHARE, LOSS

__all__ = ["fit_ellipse"]

#: The fitted centre may lie at most this many of the object's minor spreads (and at
#: least a pixel) from the start: beyond, the fit ran off (the start is kept).
MAX_SHIFT = 1.0

#: The ellipse explains the object when the RMS residual over the best-explained share
#: of its footprint (this share) is within ``max_misfit``: an outlier region of up to the
#: rest (a highlight's blur inside a ball, the end of something touching it) is left to
#: the robust fit, as the fit itself leaves it. Measured as that RMS (median, over the
#: frames): the synthetic dark ball with a highlight 0.062 (its whole footprint's RMS
#: 0.197, the fit's centre within 0.33 px), the balltoss ball 0.060; not ellipses: the
#: badminton shuttlecocks 0.144, the launcher's 5 px ball beside its shadow 0.46, the
#: diabolo 0.34, the bears 0.48 and 0.97.
EXPLAINED_SHARE = 0.9

#: The blur of the pixel's box (px, a standard deviation: its width over sqrt(12)).
_BOX_BLUR = math.sqrt(1.0 / 12.0)

#: Bounds of the coverage and the blur (px).
_COVER = (0.05, 1.5)
_BLUR = (0.3, 4.0)

#: The least spread (px) a fit of the object's shape may give.
_SPREAD_MIN = 0.3


def _axes(spread, blur):
    """A uniform ellipse's semi-axis from its blurred image's spread along it: the
    variance of a uniform disk's image is ``R^2 / 4`` plus the blur's ``s^2`` and the
    pixel's box's ``1 / 12``."""
    return 2.0 * np.sqrt(np.maximum(spread ** 2 - blur ** 2 - 1.0 / 12.0, 0.0625))


def _unpack(p, theta, spreads):
    """``(u, v, theta, a, s, spreads)`` from the parameters ``p``: ``(u, v, [theta], a,
    s, [spread along, spread across])``, the angle where ``theta`` is None, the spreads
    where ``spreads`` is None."""
    p = list(p)
    if spreads is None:
        spreads = (p.pop(), p.pop())[::-1]
    if theta is None:
        u, v, th, a, s = p
    else:
        (u, v, a, s), th = p, theta
    return u, v, th, a, s, spreads


def _parts(p, x, y, spreads, theta):
    """The model's intermediate quantities at ``p`` (what the model and its Jacobian
    share)."""
    u, v, th, a, s, spreads = _unpack(p, theta, spreads)
    big, small = _axes(spreads[0], s), _axes(spreads[1], s)
    ca, sa = math.cos(th), math.sin(th)
    dx, dy = x - u, y - v
    q = dx * ca + dy * sa
    r = dy * ca - dx * sa
    g = (q / big) ** 2 + (r / small) ** 2 - 1.0
    root = np.maximum(np.sqrt((q / big ** 2) ** 2 + (r / small ** 2) ** 2), 5e-10)
    dist = g / (2.0 * root)
    sig = math.hypot(s, _BOX_BLUR)
    z = -dist / sig
    from scipy.special import ndtr

    return (u, v, th, a, s, big, small, ca, sa, q, r, g, root, dist, sig, z, ndtr(z),
            spreads)


def _model(p, x, y, spreads, theta):
    parts = _parts(p, x, y, spreads, theta)
    return parts[3] * parts[-2]


def _jacobian(p, x, y, spreads, theta):
    """The model's derivatives by its parameters (u, v, [theta], a, s, [spreads])."""
    free = spreads is None
    (u, v, th, a, s, big, small, ca, sa, q, r, g, root, dist, sig, z,
     cdf, spreads) = _parts(p, x, y, spreads, theta)
    pdf = np.exp(-0.5 * z * z) / math.sqrt(2.0 * math.pi)
    c_dist = -a * pdf / sig
    # dist = g / (2 root): its derivatives by q, r and the semi-axes
    grad = 2.0 * root

    def d_dist(dg, droot):
        return (dg * grad - g * 2.0 * droot) / (grad * grad)

    dq = d_dist(2.0 * q / big ** 2, q / (big ** 4 * root))
    dr = d_dist(2.0 * r / small ** 2, r / (small ** 4 * root))
    dbig = d_dist(-2.0 * q * q / big ** 3, -2.0 * q * q / (big ** 5 * root))
    dsmall = d_dist(-2.0 * r * r / small ** 3, -2.0 * r * r / (small ** 5 * root))
    # (the semi-axes shrink as the blur grows: A = 2 sqrt(spread^2 - s^2 - 1/12))
    floor = 2.0 * math.sqrt(0.0625)
    big_s = -4.0 * s / big if big > floor else 0.0
    small_s = -4.0 * s / small if small > floor else 0.0
    cols = [c_dist * (-dq * ca + dr * sa), c_dist * (-dq * sa - dr * ca)]
    if theta is None:
        cols.append(c_dist * (dq * r - dr * q))
    cols.append(cdf)
    cols.append(c_dist * (dbig * big_s + dsmall * small_s) + a * pdf * dist * s / sig ** 3)
    if free:
        # (A = 2 sqrt(spread^2 - s^2 - 1/12): dA / dspread = 4 spread / A)
        cols.append(c_dist * dbig * (4.0 * spreads[0] / big if big > floor else 0.0))
        cols.append(c_dist * dsmall * (4.0 * spreads[1] / small if small > floor else 0.0))
    return np.column_stack(cols)


def fit_ellipse(x, y, cover, start, spreads, turn=True, max_misfit=0.12, weight=None,
                free_spreads=False, noise=0.0):
    """The ellipse of the object's spreads fitted to the coverage ``cover`` at pixel
    centres ``(x, y)`` from ``start = (u, v, theta)``; None where the fit fails, runs
    off, its coverage is pinned at its bound, or it does not explain the object (the RMS
    residual over the best-explained :data:`EXPLAINED_SHARE` of its footprint beyond
    ``max_misfit``, ``model_max_misfit``).

    Parameters
    ----------
    x, y, cover : numpy.ndarray
    start : (float, float, float)
    spreads : (float, float)
        The object's spreads (px, standard deviations of its image) along its major and
        minor axes, from its chain: the semi-axes follow from them and the fitted blur
        (:func:`_axes`), so that a part hidden or something touching the object does
        not shrink or grow the ellipse: it is a misfit.
    turn : bool
        Whether its angle is fitted (False: a round object's is kept).
    max_misfit : float
        The largest RMS residual over the best-explained :data:`EXPLAINED_SHARE` of its
        footprint (a share of its coverage) at which it explains the object.
    weight : numpy.ndarray, optional
        Each pixel's weight (0..1, default 1): how well its difference tells its
        coverage, the object's contrast against the background there over its full
        contrast. The residuals are then in grey levels (over the full contrast): a
        pixel whose background is near the object's own level (a patch of the wall of
        its brightness) tells little, and weighs little, in the fit and in its misfit.
    free_spreads : bool
        Whether the spreads are fitted too (``spreads`` then the start): the object's
        own shape, measured in frames where it is seen whole.
    noise : float
        A pixel's noise (its difference from the background's) over the object's full
        contrast: the misfit tested against ``max_misfit`` is what the residuals hold
        beyond it (a faint object's coverage is noisy, not misfitted).

    Returns
    -------
    (float, float, numpy.ndarray, float) or None
        The centre (u, v), the ellipse ``(u, v, theta, A, B, a, s)`` (followed by the
        fitted spreads with ``free_spreads``) and the misfit:
        the RMS residual over the ellipse's footprint (the pixels it covers at least
        :data:`~vidtrack.track.rod.FOOTPRINT_SHARE` of its coverage) over ``a``.
    """
    from scipy.optimize import least_squares

    u0, v0, th0 = start
    if x.size < 12:
        return None
    theta = None if turn else th0
    p0 = [u0, v0] + ([th0] if turn else []) + [1.0, 0.7]
    lo = [-np.inf, -np.inf] + ([-np.inf] if turn else []) + [_COVER[0], _BLUR[0]]
    hi = [np.inf, np.inf] + ([np.inf] if turn else []) + [_COVER[1], _BLUR[1]]
    ia = len(p0) - 2                       # (the index of the coverage; the blur's next)
    given = spreads
    if free_spreads:
        p0 += [float(spreads[0]), float(spreads[1])]
        lo += [_SPREAD_MIN, _SPREAD_MIN]
        hi += [np.inf, np.inf]
        given = None
    wt = np.ones_like(cover) if weight is None else weight
    try:
        res = least_squares(lambda p: wt * (_model(p, x, y, given, theta) - cover), p0,
                            jac=lambda p: wt[:, None] * _jacobian(p, x, y, given, theta),
                            bounds=(lo, hi), loss=LOSS, f_scale=F_SCALE, xtol=1e-5,
                            ftol=1e-5, max_nfev=60)
    except (ValueError, np.linalg.LinAlgError):
        return None
    if not (res.success and np.isfinite(res.x).all()):
        return None
    u, v = float(res.x[0]), float(res.x[1])
    if free_spreads:
        spreads = (float(res.x[-2]), float(res.x[-1]))
    if math.hypot(u - u0, v - v0) > max(MAX_SHIFT * min(spreads), 1.0):
        return None
    if res.x[ia] >= _COVER[1] * (1.0 - 1e-6):
        # (pinned at its bound: the pixels are not those of the object's level, one of
        # another object's joined to it)
        return None
    model = _model(res.x, x, y, given, theta)
    a, s = res.x[ia], res.x[ia + 1]
    foot = model >= FOOTPRINT_SHARE * a
    if not foot.any():
        return None
    resid = (wt * np.abs(model - cover))[foot] / a
    told = wt[foot] ** 2
    misfit = float(np.sqrt(np.sum(resid ** 2) / max(np.sum(told), 1e-12)))
    order = np.argsort(resid)[:max(int(EXPLAINED_SHARE * resid.size), 1)]
    kept = np.sum(resid[order] ** 2) / max(np.sum(told[order]), 1e-12)
    if math.sqrt(max(kept - noise * noise, 0.0)) > max_misfit:
        return None
    th = res.x[2] if turn else th0
    out = [u, v, th, _axes(spreads[0], s), _axes(spreads[1], s), a, s]
    return u, v, np.array(out + (list(spreads) if free_spreads else [])), misfit
