"""Step 4 of the flight tracker: each frame of the object measured by its own shape.

A detection is whatever is connected: the object, and anything touching it (a blade it
rides, its shadow, a hand). The object's shape is known from its chain: the robust median
of its detections' spreads along their major and minor axes (px). Each frame's point is
the fit of that shape to the frame's pixels: an ellipse of those spreads, its
orientation and centre free, moved to the weighted centroid of the pixels it holds (each
pixel weighted by its share of the object, :func:`vidtrack.track.detect.pixel_weights`)
until it stops (a mean shift with the object's own elliptical kernel, a robust
M-estimate: the pixels beyond ``kernel_sigmas`` of the ellipse are outliers with no
weight). An object alone is measured as its detection was (its kernel holds all of it);
something touching it is left out.

Each frame's **residual** is the share of the weight near the object (within twice the
kernel) that lies outside the kernel: 0 for the object alone, large where something
touches it. :mod:`vidtrack.track.flag` tests it against the chain's clean frames.
"""

from typing import NamedTuple

import cv2
import numpy as np

from vidtrack.track.detect import CLEAR_SIGMAS, nonzero_2d, pixel_weights
from vidtrack.track.ellipse import fit_ellipse
from vidtrack.track.rod import fit_rod
from vidtrack.track.path import robust_scale

__all__ = ["Shape", "Measured", "measure_frame", "fit_shape", "SHAPE_FRAMES", "rod_at",
           "chain_shape", "has_highlight", "beside_its_shadow", "BAR_COLUMNS", "bar_moments",
           "moment_axes", "explained_frames"]

#: The per-frame bar of a rod (:func:`measure_frame`): half length, half width (px),
#: coverage, misfit, angle (rad), blurs across and along (px).
BAR_COLUMNS = ("h", "w", "a", "misfit", "angle", "s", "s2", "foot")

#: A rod's bar is fitted to the pixels within its kernel reaching along it at least
#: this far (px) beyond the half length last fitted to it: the kernel is of the chain's
#: median length, short of a rod turning to lie across the view, whose ends it cut off
#: (``vidtrack synth``'s sample run, top view: 0.064 px RMS from the truth, 0.28 at
#: most, all of it along the straw; 0.054 and 0.12 with the ends).
END_MARGIN_PX = 2.0

#: Iterations of the mean shift at most, and the step (px) below which it has converged.
_ITERATIONS = 12
_CONVERGED_PX = 0.005

_KERNEL3 = np.ones((3, 3), np.uint8)

#: A compact object's ellipse has its orientation fitted only where it is at least this
#: many times longer than wide (a round one has none to fit); else it keeps its kernel's,
#: from the frame's coverage moments.
ELONGATED = 1.5

#: The residual share is taken over the pixels within this many kernels of the object.
NEAR_KERNELS = 2.0

#: A rod (its spread along at least this many times its spread across: a straw, not a
#: bear) is measured by the bar fitted to it (:mod:`vidtrack.track.rod`): the pixels of
#: what touches it, inside its kernel too, weigh little.
ROD_ASPECT = 3.0


class Measured(NamedTuple):
    """One frame of the object measured (:func:`measure_frame`)."""

    #: The centroid (px).
    u: float
    v: float
    #: The weight inside the kernel.
    weight: float
    #: Its second central moments (px^2).
    muu: float
    mvv: float
    muv: float
    #: The share of the weight near the object that lies outside its kernel.
    residual: float
    #: For an object measured by its model (a rod's bar, a compact object's ellipse):
    #: ``(half length, half width, coverage, misfit, angle, blurs)``
    #: (:data:`BAR_COLUMNS`), else None.
    bar: object
    #: Pixels touching the object that the shadow test took for its shadow (left out).
    shaded: int


class Shape:
    """The object's shape: spreads (px, standard deviations) along its major and minor
    axes, the robust medians of its chain's detections; for a rod, the profile of the
    bar last fitted to it (half width, coverage, blurs across and along: where the next
    frame's fit starts) and its half length (px: how far along the next frame's pixels
    reach, :data:`END_MARGIN_PX`), None before the first."""

    __slots__ = ("major", "minor", "profile", "half")

    def __init__(self, major, minor):
        self.major, self.minor = float(major), float(minor)
        self.profile = None
        self.half = None


def chain_shape(chain):
    """The :class:`Shape` of a chain's detections (robust medians) over the frames its
    flight explains (all its frames where none is marked): what the chain took before
    or after the flight (a bounce, the object's shadow joined to it) does not size it."""
    idx = explained_frames(chain)
    return Shape(np.nanmedian(chain.major[idx]), np.nanmedian(chain.minor[idx]))


def explained_frames(chain):
    """The frame positions a chain's flight explains (all its frames where none is)."""
    idx = np.flatnonzero(chain.explained)
    return idx if idx.size else chain.frames


def is_rod(shape):
    """Whether a chain's object is a rod (measured by a bar): its spread along it at
    least :data:`ROD_ASPECT` times its spread across."""
    return shape.major > ROD_ASPECT * shape.minor


def has_highlight(dets, settings):
    """Whether a chain's object is a body with a highlight: of two polarities, its body's
    level on one side of the background, in at least ``highlight_frames`` of its
    frames. Else its frames of two polarities are an object of several tones (a white
    and grey cup, a toy), weighed by their bounded difference."""
    if not dets:
        return False
    body = [bool(d["mixed"]) and np.isfinite(d["body_level"]) for d in dets]
    return float(np.mean(body)) >= settings.highlight_frames


def beside_its_shadow(dets, settings):
    """Whether a body with a highlight (:func:`has_highlight`) is a bright object beside
    its shadow: in at least ``highlight_frames`` of its frames, its brighter part is not
    inside its darker part and the darker part is all dimmed by a shadow's factor
    (:func:`vidtrack.track.detect.Detector`, ``highlight_enclosed``)."""
    return bool(dets) and float(np.mean([bool(d["beside_shadow"]) for d in dets])) >= \
        settings.highlight_frames


def measure_frame(frame, background, sigma, det, shape, settings, shadow_test=None,
                  held=None):
    """The object's point in one frame, by its shape's fit.

    Parameters
    ----------
    frame : numpy.ndarray
        The grey frame.
    background, sigma : numpy.ndarray
        The background image and each pixel's noise (float32).
    det : numpy.void
        The frame's detection of the object (:data:`~vidtrack.track.detect.DETECTION_DTYPE`).
    shape : Shape
    settings : vidtrack.track.settings.TrackerSettings
        ``kernel_sigmas``, ``k_grow``.
    shadow_test : vidtrack.track.detect.ShadowTest, optional
        Given, the pixels it takes for a shadow's are none of the object's.
    held : array of 8 floats, optional
        A rod's bar (:func:`vidtrack.track.rod.fit_rod`'s parameters) whose half length,
        half width and blurs are held (:data:`HELD`) in the fit, its centre, angle and
        coverage free (:func:`vidtrack.track.joined.hold_profile`).

    Returns
    -------
    Measured
        The centroid (px), the weight inside the kernel, its second central moments
        (px^2), the residual share, for an object measured by its model (a rod's
        bar, a compact object's ellipse) the model's ``(half length, half width,
        coverage, misfit, angle, blurs)`` (px, px, 1, 1, rad from +u towards +v, px; see
        :func:`vidtrack.track.rod.fit_rod`), else None, and how many pixels touching
        the object the shadow test took for its shadow (left out).
    """
    k = settings.kernel_sigmas
    cu, cv = float(det["u"]), float(det["v"])
    (a, b), ((r0, c0), bg, sg, d, fg, shade, (n_lab, lab)) = _object_crop(
        frame, background, sigma, (cu, cv), shape, settings, shadow_test, det=det)
    grown = cv2.dilate(fg, _KERNEL3) != 0
    shaded = _shaded(shade, grown)
    ys, xs = nonzero_2d(grown)
    if ys.size == 0:
        return Measured(cu, cv, 0.0, np.nan, np.nan, np.nan, np.nan, None, shaded)
    level = float(det["level"]) if np.isfinite(det["level"]) and det["level"] > 0 else 1.0
    obj, mixed = float(det["obj_level"]), bool(det["mixed"])
    grow = settings.k_grow * sg
    w = pixel_weights(d[ys, xs], bg[ys, xs], sg[ys, xs], level, obj, mixed, grow[ys, xs])
    inner = None
    if mixed and np.isfinite(obj):
        # (a highlight inside the object is the object's, and where its blur cancels
        # the body's contrast too)
        inner = _highlight_interior(d, bg, grow, obj, ys, xs, w, settings.highlight_core)
        if inner is not None:
            w = np.where(np.isfinite(inner[ys, xs]), inner[ys, xs], w)
    if shade is not None:
        w = np.where(shade[ys, xs], 0.0, w)
    rim = _beyond_rim(d, bg, det, settings)
    if rim is not None:
        w = np.where(rim[ys, xs], 0.0, w)
    x = xs + c0 + 0.0
    y = ys + r0 + 0.0
    muu, mvv, muv = float(det["muu"]), float(det["mvv"]), float(det["muv"])
    theta = 0.5 * np.arctan2(2.0 * muv, muu - mvv)
    inside = np.zeros(x.size, bool)
    for _ in range(_ITERATIONS):
        c, s = np.cos(theta), np.sin(theta)
        du, dv = x - cu, y - cv
        along = du * c + dv * s
        across = -du * s + dv * c
        m2 = (along / a) ** 2 + (across / b) ** 2
        inside = m2 <= k * k
        wi = w * inside
        sw = wi.sum()
        if sw <= 0:
            break
        nu, nv = float(np.sum(wi * x) / sw), float(np.sum(wi * y) / sw)
        eu, ev = x - nu, y - nv
        iuu, ivv = np.sum(wi * eu * eu) / sw, np.sum(wi * ev * ev) / sw
        iuv = np.sum(wi * eu * ev) / sw
        # (the orientation from the object's own coverage, not its detection's: a
        # detection over backgrounds of two levels weighs the one of more contrast)
        theta = 0.5 * np.arctan2(2.0 * iuv, iuu - ivv)
        step = np.hypot(nu - cu, nv - cv)
        cu, cv = nu, nv
        if step < _CONVERGED_PX:
            break
    wi = w * inside
    sw = float(wi.sum())
    if sw <= 0:
        return Measured(float(det["u"]), float(det["v"]), 0.0, np.nan, np.nan, np.nan, np.nan,
                        None, shaded)
    eu, ev = x - cu, y - cv
    c, s = np.cos(theta), np.sin(theta)
    m2 = ((eu * c + ev * s) / a) ** 2 + ((-eu * s + ev * c) / b) ** 2
    near = m2 <= (NEAR_KERNELS * k) ** 2
    out = float(np.sum(w * (near & ~inside)))
    residual = out / (out + sw)
    bar = None
    if np.isfinite(obj):
        # its centre from the model fitted to the pixels in its kernel (another
        # object's apart from it left out), robustly: a rod's bar, a compact object's
        # ellipse; the mean shift's where the fit fails or does not explain it
        cover, told = _cover(d, bg, sg, det)
        if rim is not None:
            cover = np.where(rim, np.nan, cover)
        rod = is_rod(shape)
        if inner is not None:
            cover = np.where(np.isfinite(inner), inner, cover)
            told = np.where(np.isfinite(inner), 1.0, told)
        along = a
        if rod and shape.half is not None:
            # (out to the ends of a rod longer than the chain's median)
            along = max(a, (shape.half + END_MARGIN_PX) / k)
        px, py, pc, measured, pt = _kernel_pixels(cover, fg, n_lab, lab, (r0, c0),
                                                  (cu, cv, theta), (along, b), k, inner,
                                                  told)
        if rod and held is not None:
            fit = fit_rod(px, py, pc, (cu, cv, theta, held[3], held[4]), profile=held[4:],
                          measured=measured, cap_px=settings.bar_cap_px, hold=HELD)
        elif rod:
            fit = fit_rod(px, py, pc, (cu, cv, theta, np.sqrt(3.0) * shape.major,
                                       np.sqrt(3.0) * max(shape.minor, 0.3)),
                          profile=shape.profile, measured=measured,
                          cap_px=settings.bar_cap_px)
        else:
            fit = fit_ellipse(px, py, pc, (cu, cv, theta), (shape.major, shape.minor),
                              turn=shape.major > ELONGATED * shape.minor,
                              max_misfit=settings.model_max_misfit, weight=pt,
                              noise=_noise(sg, det))
        if fit is not None:
            cu, cv, fitted, misfit = fit[:4]
            if rod and held is None and _like(fitted, shape):
                shape.profile = fitted[4:].copy()
                shape.half = float(fitted[3])
            blur = [float(x) for x in fitted[6:8]] + [np.nan] * (8 - len(fitted))
            # (the footprint's own misfit: a rod's bar's alone)
            bar = (float(fitted[3]), float(fitted[4]), float(fitted[5]), misfit,
                   float(fitted[2]), *blur, fit[4] if rod else np.nan)
    eu, ev = x - cu, y - cv
    muu = float(np.sum(wi * eu * eu) / sw)
    mvv = float(np.sum(wi * ev * ev) / sw)
    muv = float(np.sum(wi * eu * ev) / sw)
    return Measured(cu, cv, sw, muu, mvv, muv, residual, bar, shaded)


#: The object's shape is measured by its model in at most this many of its chain's
#: frames (spread evenly over those its flight explains) ...
SHAPE_FRAMES = 15

#: ... and taken where at least this share of them (and at least 3) are explained by
#: it. Measured (of 15): the synthetic balls, camouflaged or not, 13-15; the balltoss
#: ball 15; the badminton shuttlecocks 8 and 9, the bear with its balloon 6, the
#: launcher's small ball and the diabolo 0 (measured by the detections' spreads).
SHAPE_EXPLAINED = 2.0 / 3.0


def fit_shape(frames, dets, shape, background, sigma, settings, shadow_test=None):
    """The object's :class:`Shape` measured by its model: the median spreads of the
    ellipse fitted with its spreads free (:func:`vidtrack.track.ellipse.fit_ellipse`)
    to ``frames`` (grey) at their detections ``dets`` (of one level, each pixel
    weighed by how well it tells its coverage). A detection's spreads are short of the
    object's where part of it shows the wall's own level (camouflage); the fit leaves
    those pixels out. ``shape`` (the detections' median) where too few frames are
    explained by an ellipse (:data:`SHAPE_EXPLAINED`: a shuttlecock, a bear) or the
    object is a rod."""
    if is_rod(shape):
        return shape
    fitted = []
    for frame, det in zip(frames, dets):
        if not np.isfinite(det["obj_level"]) or det["mixed"]:
            continue
        cu, cv = float(det["u"]), float(det["v"])
        (a, b), ((r0, c0), bg, sg, d, fg, _shade, (n_lab, lab)) = _object_crop(
            frame, background, sigma, (cu, cv), shape, settings, shadow_test)
        cover, told = _cover(d, bg, sg, det)
        rim = _beyond_rim(d, bg, det, settings)
        if rim is not None:
            cover = np.where(rim, np.nan, cover)
        theta = 0.5 * np.arctan2(2.0 * float(det["muv"]), float(det["muu"] - det["mvv"]))
        px, py, pc, _, pt = _kernel_pixels(cover, fg, n_lab, lab, (r0, c0), (cu, cv, theta),
                                           (a, b), settings.kernel_sigmas, None, told)
        fit = fit_ellipse(px, py, pc, (cu, cv, theta), (shape.major, shape.minor),
                          turn=True, max_misfit=settings.model_max_misfit, weight=pt,
                          free_spreads=True, noise=_noise(sg, det))
        if fit is not None:
            fitted.append(sorted(fit[2][-2:], reverse=True))
    if len(fitted) < max(3, SHAPE_EXPLAINED * len(frames)):
        return shape
    major, minor = np.median(np.asarray(fitted), axis=0)
    return Shape(major, minor)


#: A rod's bar fitted to a frame is of the object's own shape where its spreads along
#: and across (the bar's and its blur's) are at most this factor of the chain's: only
#: then is its profile the next frame's start (a bar fitted to what the rod touched, a
#: blade's arm, is not; a rod turning end on, shorter, is).
PROFILE_RATIO = 1.5


def bar_moments(bar):
    """A bar's weight and second central moments ``(weight, muu, mvv, muv)`` (px^2): its
    covered area, and its length and width as a uniform bar's (a row of
    :data:`BAR_COLUMNS`)."""
    h, w, a, _misfit, angle = bar[:5]
    c, s = np.cos(angle), np.sin(angle)
    along, across = (2.0 * h) ** 2 / 12.0, (2.0 * w) ** 2 / 12.0
    return (4.0 * a * h * w, along * c * c + across * s * s,
            along * s * s + across * c * c, (along - across) * c * s)


#: An object's spread across is taken at least this much (px: a thin rod seen edge on
#: still has one): for its area, and for whether a point lies within its extent.
MINOR_FLOOR_PX = 0.5


def moment_axes(muu, mvv, muv):
    """The angle (rad from +u towards +v) of the major axis of second central moments
    ``muu, mvv, muv`` (px^2), and the variances along the major and minor axes (px^2,
    at least 0): :func:`bar_moments` the other way."""
    half = 0.5 * (muu + mvv)
    root = np.hypot(0.5 * (muu - mvv), muv)
    return (0.5 * np.arctan2(2.0 * muv, muu - mvv), max(half + root, 0.0),
            max(half - root, 0.0))


def _like(fitted, shape):
    """Whether a bar's spreads along and across are at most the object's
    (:data:`PROFILE_RATIO`)."""
    along = np.sqrt(fitted[3] ** 2 / 3.0 + fitted[7] ** 2)
    across = np.sqrt(fitted[4] ** 2 / 3.0 + fitted[6] ** 2)
    return (along <= PROFILE_RATIO * max(shape.major, 0.5)
            and across <= PROFILE_RATIO * max(shape.minor, 0.5))


#: :func:`rod_at` holds the rod's half length, half width and blurs across and along
#: (of the bar's parameters ``u, v, theta, h, w, a, s, s2``) at the chain's own.
HELD = (3, 4, 6, 7)


def rod_at(frame, background, sigma, det, pose, bar, shape, settings, shadow_test=None):
    """A rod's bar of the chain's own profile fitted to one frame at a predicted pose:
    its centre, angle and coverage free, its length, width and blurs held
    (:data:`HELD`), so that what the rod is joined to (a blade it rides) is not taken
    for more of it.

    Parameters
    ----------
    frame, background, sigma : numpy.ndarray
        As :func:`measure_frame`'s.
    det : numpy.void
        A detection of the object itself (its levels: the pixels' coverage is read
        against them).
    pose : (float, float, float)
        The predicted centre (px) and angle (rad).
    bar : array of 8 floats
        The bar's parameters (:func:`vidtrack.track.rod.fit_rod`) of the chain's clean
        frames: the length, width and blurs held, the rest a start.
    shape : Shape
    settings : TrackerSettings
    shadow_test : vidtrack.track.detect.ShadowTest, optional

    Returns
    -------
    (float, float, numpy.ndarray, float) or None
        As :func:`vidtrack.track.rod.fit_rod`.
    """
    cu, cv, theta = pose
    (a, b), ((r0, c0), bg, sg, d, fg, _shade, (n_lab, lab)) = _object_crop(
        frame, background, sigma, (cu, cv), shape, settings, shadow_test)
    cover, _ = _cover(d, bg, sg, det)
    px, py, pc, _, _ = _kernel_pixels(cover, fg, n_lab, lab, (r0, c0), (cu, cv, theta),
                                      (a, b), settings.kernel_sigmas, None)
    return fit_rod(px, py, pc, (cu, cv, theta, bar[3], bar[4]), profile=bar[4:],
                   cap_px=settings.bar_cap_px, hold=HELD)


def _object_crop(frame, background, sigma, centre, shape, settings, shadow_test, det=None):
    """The kernel's spreads ``(a, b)`` (the shape's, each at least a pixel: blur,
    sampling) and :func:`_crop` round ``centre``, reaching twice the kernel along."""
    a = np.hypot(max(shape.major, 0.5), 0.5)
    b = np.hypot(max(shape.minor, 0.5), 0.5)
    reach = int(np.ceil(2.0 * settings.kernel_sigmas * a)) + 2
    return (a, b), _crop(frame, background, sigma, centre, reach, max(2.0 * a, 3.0),
                         settings, shadow_test, det=det)


#: A point lies in a detection within this many of its spreads (square roots of its
#: second moments, along each of their axes) from its centroid: an ellipse of uniform
#: cover ends at 2.
OWN_SPREADS = 2.0


def spreads_sq(du, dv, muu, mvv, muv):
    """The squared distance of the offsets ``(du, dv)`` from a centroid in spreads of
    the second moments ``muu, mvv, muv`` (the Mahalanobis distance squared; the
    moments' determinant taken at least 1e-6)."""
    return ((mvv * du * du - 2.0 * muv * du * dv + muu * dv * dv)
            / np.maximum(muu * mvv - muv * muv, 1e-6))


def _crop(frame, background, sigma, centre, reach, near_px, settings, shadow_test,
          det=None):
    """The frame round ``centre`` (``reach`` px each way): its origin (row, column), the
    background (dimmed where the shadow test finds a shadow) and noise there, the
    difference, the foreground (beyond ``k_grow``; no shadow's) as the connected
    pixels that hold the most of the detection's own (``det``: within
    :data:`OWN_SPREADS` of its moments' ellipse; without one, within ``near_px`` of the
    centre): another object's, apart from the object, are not its own even where they
    lie within its kernel, and where the object shows faint, a brighter one beside it
    within the kernel is still not it; the shadow's pixels (or None) and the labelling
    ``(count, labels)``."""
    rows, cols = frame.shape
    cu, cv = centre
    r0, r1 = max(int(cv) - reach, 0), min(int(cv) + reach + 1, rows)
    c0, c1 = max(int(cu) - reach, 0), min(int(cu) + reach + 1, cols)
    f = frame[r0:r1, c0:c1].astype(np.float64)
    bg = background[r0:r1, c0:c1].astype(np.float64)
    sg = sigma[r0:r1, c0:c1].astype(np.float64)
    d = f - bg
    fg = (np.abs(d) > settings.k_grow * sg).astype(np.uint8)
    shade = None
    if shadow_test is not None:
        shade, light = shadow_test(f.astype(np.float32), (fg > 0) & (d < 0),
                                   window=(r0, r1, c0, c1), regions=True)
        if light is None:
            shade = None
        else:
            # (the object read against the background as its shadow dims it)
            fg[shade] = 0
            bg = bg * light
            d = f - bg
    n_lab, lab = cv2.connectedComponents(fg, connectivity=8)
    if n_lab > 2:
        ly, lx = nonzero_2d(lab != 0)
        du, dv = lx + c0 - cu, ly + r0 - cv
        if det is None:
            near = np.hypot(du, dv) <= near_px
        else:
            # (a pixel's square added to each moment: the blur and the grid)
            near = spreads_sq(du, dv, float(det["muu"]) + 1.0, float(det["mvv"]) + 1.0,
                              float(det["muv"])) <= OWN_SPREADS ** 2
        counts = np.bincount(lab[ly[near], lx[near]], minlength=n_lab)
        counts[0] = 0
        fg = (lab == int(np.argmax(counts))).astype(np.uint8) if counts.any() else fg
    return (r0, c0), bg, sg, d, fg, shade, (n_lab, lab)


def _shaded(shade, grown):
    """How many pixels the shadow test took for a shadow (``shade``, or None) in the
    regions of them that touch the object (``grown``: its foreground and a pixel
    round it)."""
    if shade is None or not np.any(shade & grown):
        return 0
    n_lab, lab = cv2.connectedComponents(shade.astype(np.uint8), connectivity=8)
    touching = np.unique(lab[shade & grown])
    return int(np.count_nonzero(np.isin(lab, touching[touching > 0])))


def _noise(sg, det):
    """A pixel's noise (the median of ``sg``, the crop's) over the object's contrast (the
    detection's ``level``)."""
    level = float(det["level"]) if np.isfinite(det["level"]) and det["level"] > 0 else 1.0
    return float(np.median(sg)) / level


def _beyond_rim(d, bg, det, settings):
    """The crop's pixels (bool) dimmed by no more than a shadow's factor farther than
    ``shadow_rim_px`` from those the object dims more, for a dark object of one level
    darker than a shadow could make any pixel of the wall round it (below
    ``shadow_ratio_min`` of the crop's darkest background); else None."""
    obj = float(det["obj_level"])
    if det["mixed"] or not np.isfinite(obj) or det["contrast"] >= 0:
        return None
    r = settings.shadow_ratio_min
    if obj >= r * float(bg.min()):
        return None
    ratio = (d + bg) / np.maximum(bg, 1.0)
    core = (ratio < r).astype(np.uint8)
    if not core.any():
        return None
    far = cv2.distanceTransform(1 - core, cv2.DIST_L2, 3) > settings.shadow_rim_px
    return far & (ratio >= r) & (d < 0)


def _cover(d, bg, sg, det):
    """Each pixel's coverage by the object: its difference from the background over the
    object's own contrast there (``obj_level``), or over the detection's ``level`` where
    that contrast is within ``CLEAR_SIGMAS`` of the noise (for an object of one level,
    NaN there: it cannot tell); and how well it tells it, the object's contrast there
    over its full contrast (the detection's ``level``), at most 1."""
    level = float(det["level"]) if np.isfinite(det["level"]) and det["level"] > 0 else 1.0
    span = float(det["obj_level"]) - bg
    clear = np.abs(span) > CLEAR_SIGMAS * sg
    sign = 1.0 if det["contrast"] >= 0 else -1.0
    told = np.where(np.isfinite(span), np.minimum(np.abs(span) / level, 1.0), 1.0)
    if np.isfinite(det["obj_level"]):
        # (where the background is of the object's own level, a pixel cannot tell
        # whether the object covers it: no data, not an uncovered pixel)
        return np.where(clear, d / np.where(clear, span, 1.0), np.nan), told
    return np.where(clear, d / np.where(clear, span, 1.0), sign * d / level), told


def _highlight_interior(d, bg, grow, obj, ys, xs, w, core):
    """A mixed object's weights where its body's coverage does not tell them, over
    the crop (NaN elsewhere). Its highlight (its pixels of the other polarity than its
    body beyond ``grow``) and the pixels beside it (3 x 3: where the highlight's blur
    cancels the body's contrast) cover fully inside the convex hull of its core (the
    pixels its body covers at least ``core``, ``highlight_core``: a dimmer object
    touching it is not in it); a highlight's pixel outside it is read against the
    highlight's own level (the 90th percentile of its ``|d|``). None where there is no
    highlight or no core."""
    # (of the other polarity than the body against the background under it: a grey
    # object over a wall and a floor is of one level, darker than the one and lighter
    # than the other)
    hl = np.sign(obj - bg[ys, xs]) * d[ys, xs] < -grow[ys, xs]
    body = (w >= core) & ~hl
    if not hl.any() or np.count_nonzero(body) < 3:
        return None
    inside = np.zeros(d.shape, np.uint8)
    cv2.fillConvexPoly(inside, cv2.convexHull(np.column_stack((xs[body], ys[body]))
                                              .astype(np.int32)), 1)
    light = np.zeros(d.shape, np.uint8)
    light[ys[hl], xs[hl]] = 1
    out = np.full(d.shape, np.nan)
    out[(inside > 0) & (cv2.dilate(light, _KERNEL3) > 0)] = 1.0
    top = float(np.percentile(np.abs(d[ys, xs][hl]), 90))
    edge = hl & (inside[ys, xs] == 0)
    out[ys[edge], xs[edge]] = np.minimum(np.abs(d[ys[edge], xs[edge]]) / top, 1.0)
    return out


def _kernel_pixels(cover, fg, n_lab, lab, origin, pose, spreads, k, inner, told=None):
    """The centres, ``cover``, measured-or-filled and ``told`` (None if not given) of
    the crop's pixels within the kernel at ``pose`` (another detection's pixels apart
    from the object's left out; ``inner``: the filled-in cover of a highlight, NaN
    elsewhere, or None)."""
    r0, c0 = origin
    cu, cv, theta = pose
    a, b = spreads
    rr, cc = np.mgrid[0:cover.shape[0], 0:cover.shape[1]]
    x, y = cc + c0 + 0.0, rr + r0 + 0.0
    c, s = np.cos(theta), np.sin(theta)
    du, dv = x - cu, y - cv
    m2 = ((du * c + dv * s) / a) ** 2 + ((-du * s + dv * c) / b) ** 2
    use = (m2 <= k * k) & np.isfinite(cover)
    if n_lab > 2:
        use &= (lab == 0) | (fg > 0)
    measured = None if inner is None else ~np.isfinite(inner[use])
    return x[use], y[use], cover[use], measured, None if told is None else told[use]


def residual_outliers(residual, settings):
    """Frames whose residual share lies beyond ``k_flag`` robust scatters of the chain's
    (at least ``residual_floor``) above its median (False where NaN)."""
    r = np.asarray(residual, float)
    med = float(np.nanmedian(r)) if np.isfinite(r).any() else 0.0
    scale = robust_scale(r, floor=settings.residual_floor)
    with np.errstate(invalid="ignore"):
        return r > med + settings.k_flag * scale
