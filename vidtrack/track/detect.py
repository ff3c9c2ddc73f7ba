"""Step 1 of the flight tracker: what differs from the background, frame by frame.

Every pixel's foreground evidence is its difference from the background in units of its
own noise, ``z = |frame - background| / sigma`` (both polarities at once, so a highlight
on a dark object belongs to the object). A detection is a connected set of pixels beyond
``k_grow`` that holds at least one beyond ``k_sigma`` (hysteresis), grown by one pixel
for its measurement so that its faint edge is counted on every side alike.

Each detection is measured where it is found, in the one pass over the footage:

- its **weighted centroid and second moments**, each pixel weighted by its share of the
  object (its coverage), ``(f - b) / (L - b)`` with ``L`` the object's own grey level
  (the 90th percentile of its pixels, towards its polarity), for an object of one
  polarity; an object of both (a highlight on a dark ball, a cup of two tones) weighs
  each pixel by its difference from the background clipped at the detection's contrast
  (the 90th percentile of its differences), and its body's level (of the polarity most
  of its pixels show) is kept where it lies on one side of the background under
  (nearly) all of it: its chain decides whether it is a body with a highlight
  (:func:`vidtrack.track.measure.has_highlight`);
- the **photometric shadow test**, per pixel first: a shadow (or a dimming of the light)
  dims the background by a smooth factor and keeps its texture; an object hides it. A
  pixel darker than the background is a shadow's, and no foreground, where the
  background has texture round it (its standard deviation over the
  ``SHADOW_WINDOW_PX`` square at least ``TEXTURE_SIGMAS`` noises), the frame there is
  no darker than ``shadow_ratio_min`` times the background (means over the square), and
  the frame's texture there correlates with the background's at least
  ``shadow_texture_min`` (Pearson r over the square): an object touching its own shadow
  is detected alone, and its pixels beside the shadow are read against the background
  as the shadow dims it there (the mean dimming of the shadow's pixels in the square).
  Where the background is plain, a pixel cannot tell a shadow from a
  dark object; then the whole detection is judged: it is shadow-like when all its pixels
  are darker than the background by a factor no smaller than ``shadow_ratio_min``
  (frame / background, 10th percentile), and, where the background has texture there,
  the frame's texture still correlates with it (Pearson r of the two over the
  detection at least ``shadow_texture_min``).

A detection is kept when its signal-to-noise ratio, the sum of its pixels' ``z`` over the
square root of their count, is at least ``min_snr``: one pixel of compression noise
beyond ``k_sigma`` with a few beside it beyond ``k_grow`` is not an object.

A frame's detections are a small structured array (:data:`DETECTION_DTYPE`); nothing of
the image is kept, so memory does not grow with the footage's length.
"""

import cv2
import numpy as np

__all__ = ["Detector", "DETECTION_DTYPE", "MAX_DETECTIONS", "pixel_weights", "nonzero_2d",
           "polarity"]

#: At most this many detections are kept per frame: the most significant (by their
#: signal-to-noise ratio; a small object of strong contrast before a crowd whose
#: compression noise makes many large faint detections is kept).
MAX_DETECTIONS = 128

#: One detection: centroid (px), weight (coverage-like area, px^2), pixel count, second
#: central moments (px^2), contrast (grey levels, signed: + brighter than the
#: background), the share of the weight brighter than the background, the 10th
#: percentile of frame / background, the texture correlation, whether it is
#: shadow-like, whether the background under it has texture (then a shadow-like
#: detection has shown the texture kept, not only a dimming), whether it touches the
#: frame's border, its contrast (the 90th percentile of its |difference|), its own
#: grey level (NaN for an object of two polarities), whether it is of two polarities,
#: and its body's level (of the polarity most of its pixels beyond ``k_grow`` show)
#: where that lies on one side of the background under it (a dark ball with a
#: highlight; NaN otherwise).
DETECTION_DTYPE = np.dtype([("u", "f8"), ("v", "f8"), ("weight", "f8"), ("area", "i4"),
                            ("muu", "f8"), ("mvv", "f8"), ("muv", "f8"),
                            ("contrast", "f4"), ("bright_share", "f4"),
                            ("ratio_p10", "f4"), ("texture_r", "f4"),
                            ("snr", "f4"), ("shadow", "?"), ("textured", "?"), ("border", "?"),
                            ("level", "f4"), ("obj_level", "f4"), ("mixed", "?"),
                            ("body_level", "f4"), ("beside_shadow", "?"),
                            ("lit_level", "f4")])

_KERNEL3 = np.ones((3, 3), np.uint8)

#: A pixel's coverage is read against the object's own level only where that level
#: stands this many noises clear of the background there.
CLEAR_SIGMAS = 2.0

#: The background under a detection has texture when its standard deviation there is
#: at least this many noises (the shadow test then asks the texture to be kept).
TEXTURE_SIGMAS = 3.0

#: An object whose pixels of the other polarity (beyond ``k_grow``) hold at most this
#: share of its summed contrast has one grey level (a highlight holds more).
ONE_LEVEL_SHARE = 0.05

#: An object of two polarities against the wall is of one level where its pixels at
#: least this share of its contrast (the 90th percentile of its ``|difference|``) from
#: the wall (where it stands clear of it) ...
CLEAR_SHARE = 0.5

#: ... span an interquartile range of at most this share of its contrast ...
ONE_LEVEL_IQR = 0.25

#: ... over at least this many pixels.
FLAT_MIN_PIXELS = 9

#: The per-pixel shadow test looks at the square of this side round each pixel (px).
SHADOW_WINDOW_PX = 5


class ShadowTest:
    """The per-pixel photometric shadow test against one background.

    Parameters
    ----------
    background : numpy.ndarray
        The background image (float32).
    noise : float
        A static pixel's noise (grey levels).
    ratio_min, texture_min : float
        ``shadow_ratio_min`` and ``shadow_texture_min``.
    """

    def __init__(self, background, noise, ratio_min, texture_min):
        self.bg = np.ascontiguousarray(background, dtype=np.float32)
        self.ratio_min, self.texture_min = float(ratio_min), float(texture_min)
        self.noise = max(float(noise), 0.5)
        self.mean_b, self.var_b = _box_stats(self.bg)
        self.textured = self.var_b >= (TEXTURE_SIGMAS * self.noise) ** 2

    def __call__(self, f, candidates, window=None, regions=False):
        """The shadow's pixels among ``candidates`` of grey frame ``f`` (float32; a crop
        ``window = (r0, r1, c0, c1)`` of the background's frame), and the light there.

        A pixel is a shadow's where the square round it is dimmed by a shadow's factor
        (``shadow_ratio_min`` up to 1) with the background's texture kept
        (``shadow_texture_min``), and the pixel itself is dimmed no more than a shadow
        dims: at a dark object's edge the square holds enough background to pass, the
        pixel does not. With ``regions``, only shadow pixels that make a region at least
        3 px across are kept (an opening): a partly covered rim reads as dimmed too.

        Returns
        -------
        (numpy.ndarray of bool, numpy.ndarray or None)
            Which candidates are a shadow's, and the factor by which the shadow dims the
            background at each pixel (the mean frame / background ratio of the shadow's
            pixels in the square round it; 1 where there are none): an object's pixels
            beside its shadow are read against the background as the shadow dims it.
            None where no pixel is a shadow's.
        """
        rows, cols = self.bg.shape
        if window is None and not regions and min(rows, cols) >= SHADOW_WINDOW_PX:
            return self._sparse(f, candidates)
        if window is None:
            window = (0, rows, 0, cols)
        sl = np.s_[window[0]:window[1], window[2]:window[3]]
        cand = candidates & self.textured[sl]
        if not cand.any():
            return cand, None
        b = self.bg[sl]
        mean_b, var_b = _box_stats(b)
        shade, own = self._shade(f, b, mean_b, var_b, cand, regions)
        if not shade.any():
            return shade, None
        return shade, _light(shade, own)

    def _sparse(self, f, candidates):
        """:meth:`__call__` over the whole frame, worked out at the candidates only.

        A frame holds a few dozen candidates (textured, darker than the background) and
        fewer shadow pixels: the box means are taken at the candidates, and the light
        at the pixels within the box's half side of a shadow's (it is 1 elsewhere),
        each from the square round the pixel (:func:`_box_at`: the values the box
        filter over the whole frame gives there, bit for bit). Many candidates (a
        frame darkened all over) are tested over the whole frame.
        """
        rows, cols = cand_shape = candidates.shape
        area = SHADOW_WINDOW_PX * SHADOW_WINDOW_PX
        cand = candidates & self.textured
        ys, xs = nonzero_2d(cand)
        if ys.size == 0:
            return cand, None
        if ys.size * area > cand.size:
            return self(f, candidates, window=(0, rows, 0, cols))
        sq = _squares(ys, xs, rows, cols)
        fs = f[sq]
        bs = self.bg[sq]
        k = ys.size
        sums = _box_at(np.concatenate([fs, fs * bs, fs * fs]))
        mean_f, mean_fb, mean_ff = sums[:k], sums[k:2 * k], sums[2 * k:]
        mean_b, var_b = self.mean_b[ys, xs], self.var_b[ys, xs]
        cov = mean_fb - mean_f * mean_b
        var_f = np.maximum(mean_ff - mean_f * mean_f, 0.0)
        ratio = mean_f / np.maximum(mean_b, 1.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            r = cov / np.sqrt(var_f * var_b)
        own = f[ys, xs] / np.maximum(self.bg[ys, xs], 1.0)
        hit = ((ratio >= self.ratio_min) & (ratio < 1.0) & (r >= self.texture_min)
               & (own >= self.ratio_min))
        shade = np.zeros(cand_shape, bool)
        if not hit.any():
            return shade, None
        ys, xs = ys[hit], xs[hit]
        shade[ys, xs] = True
        # the light: at the pixels within the box's half side of a shadow's pixel
        half = SHADOW_WINDOW_PX // 2
        near = np.arange(-half, half + 1)
        ny = (ys[:, None, None] + near[None, :, None]).clip(0, rows - 1)
        nx = (xs[:, None, None] + near[None, None, :]).clip(0, cols - 1)
        mark = np.zeros(cand.size, bool)
        mark[(ny * cols + nx).ravel()] = True
        flat = np.flatnonzero(mark)
        if flat.size * area > cand.size:
            return shade, _light(shade, f / np.maximum(self.bg, 1.0))
        ty = flat // cols
        tx = flat - ty * cols
        # (what _light box-filters: the shadow's pixels, and their own dimming there)
        count = np.zeros(cand_shape, np.float32)
        count[ys, xs] = 1.0
        dim = np.zeros(cand_shape, np.float32)
        dim[ys, xs] = own[hit]
        sq = _squares(ty, tx, rows, cols)
        sums = _box_at(np.concatenate([dim[sq], count[sq]]), normalize=False)
        light = np.ones_like(f)
        light[ty, tx] = sums[:flat.size] / sums[flat.size:]
        return shade, light

    def _shade(self, f, b, mean_b, var_b, cand, regions):
        """The shadow's pixels among ``cand`` (textured candidates) over arrays of one
        shape (the frame's, or a crop's: ``mean_b``, ``var_b`` the background's box
        statistics there), and each pixel's own dimming ``f / b``."""
        box = (SHADOW_WINDOW_PX, SHADOW_WINDOW_PX)
        mean_f = cv2.boxFilter(f, -1, box)
        cov = cv2.boxFilter(f * b, -1, box) - mean_f * mean_b
        var_f = np.maximum(cv2.boxFilter(f * f, -1, box) - mean_f * mean_f, 0.0)
        ratio = mean_f / np.maximum(mean_b, 1.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            r = cov / np.sqrt(var_f * var_b)
        own = f / np.maximum(b, 1.0)
        shade = (cand & (ratio >= self.ratio_min) & (ratio < 1.0) & (r >= self.texture_min)
                 & (own >= self.ratio_min))
        if regions and shade.any():
            shade = cv2.morphologyEx(shade.astype(np.uint8), cv2.MORPH_OPEN,
                                     np.ones((3, 3), np.uint8)).astype(bool)
        return shade, own


def nonzero_2d(mask):
    """``np.nonzero`` of a 2-D boolean ``mask`` (rows, columns; in the same order), by
    its flat indices: several times faster than ``np.nonzero`` of a 2-D array (numpy
    2.x), which the tracker calls a few times each frame."""
    idx = np.flatnonzero(mask)
    ys = idx // mask.shape[1]
    return ys, idx - ys * mask.shape[1]


def _squares(ys, xs, rows, cols):
    """Index arrays (broadcasting to ``(k, side, side)``) of the ``SHADOW_WINDOW_PX``
    square round each pixel ``(ys, xs)`` of a frame of ``rows`` x ``cols``, reflected at
    the frame's edge as OpenCV's box filter reflects it (``BORDER_REFLECT_101``: row -1
    is row 1, row ``rows`` is row ``rows - 2``)."""
    half = SHADOW_WINDOW_PX // 2
    off = np.arange(-half, half + 1)

    def reflect(i, n):
        i = np.abs(i)
        return np.where(i >= n, 2 * (n - 1) - i, i)

    return (reflect(ys[:, None] + off, rows)[:, :, None],
            reflect(xs[:, None] + off, cols)[:, None, :])


def _box_at(squares, normalize=True):
    """``cv2.boxFilter`` (float32, ``SHADOW_WINDOW_PX`` square) at the centres of
    ``squares`` (``(k, side, side)``, each the square round a pixel of the frame), as
    over the whole frame.

    The squares are laid side by side in a strip one square high and box-filtered: the
    box round each square's centre is that square, whole, and OpenCV sums a box in
    double precision (exactly, for a frame's values: grey levels, their products with
    the background), so the centre's value is the whole frame's there bit for bit.
    """
    side = SHADOW_WINDOW_PX
    k = squares.shape[0]
    strip = np.ascontiguousarray(squares.transpose(1, 0, 2).reshape(side, side * k),
                                 dtype=np.float32)
    out = cv2.boxFilter(strip, -1, (side, side), normalize=normalize)
    return out[side // 2, side // 2::side]


def _light(shade, own):
    """The factor by which a shadow dims the background round each pixel: the mean
    ``own`` (frame / background) of the ``shade`` pixels in the square round it, 1
    where there are none."""
    box = (SHADOW_WINDOW_PX, SHADOW_WINDOW_PX)
    dim = np.where(shade, own, 0.0).astype(np.float32)
    count = cv2.boxFilter(shade.astype(np.float32), -1, box, normalize=False)
    near = count > 0
    light = np.ones_like(own)
    light[near] = cv2.boxFilter(dim, -1, box, normalize=False)[near] / count[near]
    return light


def _box_stats(img):
    """Mean and variance of ``img`` over the ``SHADOW_WINDOW_PX`` square round each
    pixel."""
    box = (SHADOW_WINDOW_PX, SHADOW_WINDOW_PX)
    mean = cv2.boxFilter(img, -1, box)
    return mean, np.maximum(cv2.boxFilter(img * img, -1, box) - mean * mean, 0.0)


def _percentile_by_label(values, labels, n, q):
    """The ``q`` quantile (0..1, lower) of ``values`` within each label ``0..n-1``."""
    # (sorted by value, then by label with a stable sort: the values of each label in
    # order, as np.lexsort((values, labels)) gives them; a small label type lets numpy
    # sort the labels by radix, several times faster than lexsort)
    order = np.argsort(values, kind="stable")
    small = labels.astype(np.int16) if n <= np.iinfo(np.int16).max else labels
    order = order[np.argsort(small[order], kind="stable")]
    counts = np.bincount(labels, minlength=n)
    starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
    idx = starts + np.floor(q * np.maximum(counts - 1, 0)).astype(np.int64)
    out = np.zeros(n, values.dtype)
    has = counts > 0
    out[has] = values[order][idx[has]]
    return out


def _beside_its_shadow(d, gl, dim, li, m, at, labels, enclosed):
    """Which detections are a bright object beside its shadow: their pixels darker than
    the background beyond ``gl`` are all dimmed by a shadow's factor (``dim``), and
    their brighter pixels beyond ``gl`` are not a highlight on that darker part (less
    than ``enclosed`` of the ring round them is the darker part: a highlight lies
    inside its body).

    ``at`` are the pixels' (row, column) in the crop whose image of detections
    ``labels`` (1..m, 0 for none) they come from; ``li`` their detection (0..m-1)."""
    bright, dark = d > gl, d < -gl
    n_dark = np.bincount(li, dark, m)
    maybe = (np.bincount(li, bright, m) > 0) & (n_dark > 0) & (
        np.bincount(li, dark & ~dim, m) <= ONE_LEVEL_SHARE * n_dark)
    if not maybe.any():
        return maybe
    rows, cols = at
    img = np.zeros(labels.shape, np.uint8)
    img[rows[bright], cols[bright]] = 1
    darkimg = np.zeros(labels.shape, bool)
    darkimg[rows[dark], cols[dark]] = True
    ring = (cv2.dilate(img, _KERNEL3) > 0) & (img == 0) & (labels > 0)
    rl = labels[ring].astype(np.int64) - 1
    share = np.bincount(rl, darkimg[ring], m) / np.maximum(np.bincount(rl, minlength=m), 1)
    return maybe & (share < enclosed)


def polarity(dets):
    """Each detection's polarity (int8): +1 brighter than the background, -1 darker, 0
    of two polarities (a highlight on a body, an object of several tones). Two chains
    of opposite polarities are not joined across a gap
    (:mod:`vidtrack.track.choose`)."""
    return np.where(dets["mixed"], 0, np.where(dets["contrast"] >= 0, 1, -1)).astype(np.int8)


def pixel_weights(d, b, sigma, level, obj, mixed=False, grow=None):
    """Each pixel's share of its object.

    Parameters
    ----------
    d, b, sigma : arrays
        The pixel's difference from the background, the background, its noise.
    level : array
        The object's contrast (the 90th percentile of its ``|d|``).
    obj : array
        The object's own grey level ``L`` (of its body, for an object of two
        polarities).
    mixed : bool or array of bool
        Whether the object is of two polarities (a highlight on a dark ball).
    grow : array, optional
        The difference (grey levels) beyond which a pixel is foreground; given, a pixel
        of a mixed object beyond it of the other polarity than its body is the object's
        whole (a highlight).

    Returns
    -------
    array
        ``(f - b) / (L - b)`` clipped to [0, 1] where the object's level stands 2 noises
        clear of the background there (its coverage, whatever the background's texture
        under it: a weight of ``|d|`` would lean towards the darker texture), 0 where
        the pixel is of the other polarity (a one-level object's shadow, compression's
        ringing) and 1 where it is of the other polarity beyond ``grow`` in a mixed
        object (a highlight lies on its object); elsewhere ``min(|d|, level) / level``,
        bounded.
    """
    a = np.abs(d)
    w = np.minimum(a, level) / np.maximum(level, 1e-9)
    span = obj - b
    with np.errstate(invalid="ignore"):
        pol = np.sign(span)
        solid = np.isfinite(span) & (np.abs(span) > CLEAR_SIGMAS * sigma) & (pol * d >= 0)
        other = np.isfinite(span) & (pol * d < 0)
    w = np.where(other, 0.0, w)
    w = np.where(solid, np.clip(d / np.where(solid, span, 1.0), 0.0, 1.0), w)
    if grow is not None:
        w = np.where(other & mixed & (a > grow), 1.0, w)
    return w


class Detector:
    """Detections of one view's frames against its background.

    Parameters
    ----------
    background : vidtrack.track.background.Background
        The static background and its per-pixel noise.
    settings : vidtrack.track.settings.TrackerSettings
        ``k_sigma``, ``k_grow``, ``min_area_px``, ``shadow_ratio_min``,
        ``shadow_texture_min``.
    """

    def __init__(self, background, settings):
        self.settings = settings
        self.bg = np.ascontiguousarray(background.image, dtype=np.float32)
        sigma = background.threshold(k=1.0).astype(np.float32)
        self.sigma = sigma
        self.seed_level = (sigma * np.float32(settings.k_sigma)).astype(np.float32)
        self.grow_level = (sigma * np.float32(settings.k_grow)).astype(np.float32)
        self.noise = float(background.noise_sigma)
        self.rows, self.cols = self.bg.shape
        self.shadow_test = ShadowTest(self.bg, self.noise, settings.shadow_ratio_min,
                                      settings.shadow_texture_min)

    def __call__(self, frame):
        """The detections of one grey frame (a :data:`DETECTION_DTYPE` array)."""
        s = self.settings
        f = frame.astype(np.float32, copy=False)
        diff = cv2.subtract(f, self.bg)
        absd = np.abs(diff)
        grow = cv2.compare(absd, self.grow_level, cv2.CMP_GT)
        # (a shadow's pixels, where the background's texture tells them, are no one's)
        shade, light = self.shadow_test(f, (grow > 0) & (diff < 0))
        if light is not None:
            grow[shade] = 0
        n, lab, stats, _ = cv2.connectedComponentsWithStats(grow, connectivity=8,
                                                            ltype=cv2.CV_32S)
        if n <= 1:
            return np.zeros(0, DETECTION_DTYPE)
        seed = cv2.compare(absd, self.seed_level, cv2.CMP_GT)
        ys, xs = nonzero_2d(seed != 0)
        seeded = np.zeros(n, bool)
        seeded[lab[ys, xs]] = True
        seeded[0] = False
        seeded &= stats[:, cv2.CC_STAT_AREA] >= s.min_area_px
        keep = np.flatnonzero(seeded)
        if keep.size == 0:
            return np.zeros(0, DETECTION_DTYPE)
        if keep.size > 4 * MAX_DETECTIONS:
            keep = keep[np.argsort(stats[keep, cv2.CC_STAT_AREA])[::-1][:4 * MAX_DETECTIONS]]
        # the kept components, relabelled 1..m, grown by a pixel (a pixel between two
        # takes the larger label: rare, and only at their edges)
        # (over the kept components' bounding box grown by the pixel: nothing is kept
        # beyond it, and the dilation ignores the crop's edge as it does the frame's)
        r0 = max(int(stats[keep, cv2.CC_STAT_TOP].min()) - 1, 0)
        c0 = max(int(stats[keep, cv2.CC_STAT_LEFT].min()) - 1, 0)
        r1 = min(int((stats[keep, cv2.CC_STAT_TOP] + stats[keep, cv2.CC_STAT_HEIGHT]).max())
                 + 1, self.rows)
        c1 = min(int((stats[keep, cv2.CC_STAT_LEFT] + stats[keep, cv2.CC_STAT_WIDTH]).max())
                 + 1, self.cols)
        remap = np.zeros(n, np.float32)
        remap[keep] = np.arange(1, keep.size + 1, dtype=np.float32)
        own = remap[lab[r0:r1, c0:c1]]
        grown = cv2.dilate(own, _KERNEL3)
        ys, xs = nonzero_2d(grown != 0)
        li = grown[ys, xs].astype(np.int64) - 1
        # (the component's own pixels, not the grown ring: the photometric test's; and
        # those a pixel inside its edge)
        core = own[ys, xs] > 0
        inside = (cv2.erode(own, _KERNEL3) == own)[ys, xs] & core
        ys += r0
        xs += c0
        m = keep.size
        d = diff[ys, xs].astype(np.float64)
        bgv = self.bg[ys, xs].astype(np.float64)
        if light is not None:
            # (read against the background as the shadow dims it)
            bgv = bgv * light[ys, xs]
            d = f[ys, xs] - bgv
        a = np.abs(d)
        level = _percentile_by_label(a, li, m, 0.9)
        fv = f[ys, xs].astype(np.float64)
        sign = np.where(np.bincount(li, d, m) >= 0, 1.0, -1.0)
        # (an object of two polarities, a highlight on a dark ball, has no one level;
        # compression's ringing round a bright straw is a few grey levels of the other
        # polarity: a share of the contrast, not of the pixels; and a bright object's
        # shadow beside it, the background dimmed by a factor no smaller than
        # shadow_ratio_min, is not the object's other polarity: measured as one level,
        # the object's coverage gives the shadow no weight)
        ratio_all = fv / np.maximum(bgv, 1.0)
        dimmed = (d < 0) & (ratio_all >= s.shadow_ratio_min) & (sign[li] > 0)
        gl = self.grow_level[ys, xs]
        other = np.bincount(li, np.where((sign[li] * d < -gl) & ~dimmed, a, 0.0), m)
        one_level = other <= ONE_LEVEL_SHARE * np.bincount(li, a, m)
        # (an object of two polarities: its body is the polarity most of its pixels
        # beyond k_grow show, whatever the other's contrast; the other is a highlight)
        more_bright = np.bincount(li, d > gl, m) >= np.bincount(li, d < -gl, m)
        body = np.where(one_level, sign, np.where(more_bright, 1.0, -1.0))
        obj = body * _percentile_by_label(body[li] * fv, li, m, 0.9)
        # (an object of one grey level L over a wall with patches both lighter and
        # darker than it is of two polarities against the wall, yet where it stands
        # clear of the wall (a pixel inside its edge, where it covers the pixel whole)
        # its pixels are of one level whatever the wall under them:
        # their interquartile range within ONE_LEVEL_IQR of its contrast, and its pixels
        # that differ from the wall the other way than L does (a highlight on a dark
        # ball; a toy's tones) hold at most ONE_LEVEL_SHARE of its summed contrast)
        clear = inside & (a >= CLEAR_SHARE * level[li])
        q25 = _percentile_by_label(fv[clear], li[clear], m, 0.25)
        q50 = _percentile_by_label(fv[clear], li[clear], m, 0.5)
        q75 = _percentile_by_label(fv[clear], li[clear], m, 0.75)
        span = q50[li] - bgv
        against = (core & (np.sign(span) * d < -gl)
                   & (np.abs(span) > CLEAR_SIGMAS * self.sigma[ys, xs]))
        flat = (~one_level & (np.bincount(li[clear], minlength=m) >= FLAT_MIN_PIXELS)
                & (q75 - q25 <= ONE_LEVEL_IQR * level)
                & (np.bincount(li, np.where(against, a, 0.0), m)
                   <= ONE_LEVEL_SHARE * np.bincount(li, np.where(core, a, 0.0), m)))
        obj = np.where(flat, q50, obj)
        one_level |= flat
        mixed = ~one_level
        # (a body's level has one side of the background under nearly all of it, or the
        # other polarity is no highlight: a grey object over a light wall and a dark
        # floor is of several tones)
        above = np.bincount(li, obj[li] > bgv, m) / np.bincount(li, minlength=m)
        one_side = np.maximum(above, 1.0 - above) >= s.highlight_one_side
        body_level = np.where(mixed & one_side, obj, np.nan)
        # (the detection is weighed as one of several tones, by its bounded difference,
        # until its chain shows it a body with a highlight)
        obj = np.where(one_level, obj, np.nan)
        # (a mixed object may be a bright object beside its shadow: measured as such where
        # its chain shows it so, at the level of its bright pixels)
        beside = mixed & _beside_its_shadow(d, gl, ratio_all >= s.shadow_ratio_min, li, m,
                                            (ys - r0, xs - c0), grown,
                                            s.highlight_enclosed)
        lit_level = (_percentile_by_label(fv, li, m, 0.9) if beside.any()
                     else np.full(m, np.nan))
        w = pixel_weights(d, bgv, self.sigma[ys, xs], level[li], obj[li])
        if light is not None:
            # (the ring grown round a detection weighs no shadow's pixel)
            w = np.where(shade[ys, xs], 0.0, w)
        xf, yf = xs.astype(np.float64), ys.astype(np.float64)
        sw = np.bincount(li, w, m)
        good = sw > 0
        su = np.bincount(li, w * xf, m)
        sv = np.bincount(li, w * yf, m)
        u = np.divide(su, sw, out=np.full(m, np.nan), where=good)
        v = np.divide(sv, sw, out=np.full(m, np.nan), where=good)
        du, dv = xf - u[li], yf - v[li]
        muu = np.bincount(li, w * du * du, m) / np.maximum(sw, 1e-12)
        mvv = np.bincount(li, w * dv * dv, m) / np.maximum(sw, 1e-12)
        muv = np.bincount(li, w * du * dv, m) / np.maximum(sw, 1e-12)
        bright = np.bincount(li, w * (d > 0), m) / np.maximum(sw, 1e-12)
        # (a mixed object's contrast is its body's)
        wb = np.where(body[li] * d >= 0, w, 0.0)
        contrast = np.bincount(li, wb * d, m) / np.maximum(np.bincount(li, wb, m), 1e-12)
        # the photometric test, over the component's own pixels (core)
        ratio = fv / np.maximum(bgv, 1.0)
        ratio_p10 = _percentile_by_label(ratio[core], li[core], m, 0.1)
        dark_all = np.bincount(li, core & (d >= 0), m) == 0
        cnt = np.bincount(li, core, m)
        mb = np.bincount(li, core * bgv, m) / np.maximum(cnt, 1)
        mf = np.bincount(li, core * fv, m) / np.maximum(cnt, 1)
        cb = np.where(core, bgv - mb[li], 0.0)
        cf = np.where(core, fv - mf[li], 0.0)
        sbb = np.bincount(li, cb * cb, m)
        sff = np.bincount(li, cf * cf, m)
        sbf = np.bincount(li, cb * cf, m)
        texture_r = sbf / np.sqrt(np.maximum(sbb * sff, 1e-12))
        textured = np.sqrt(sbb / np.maximum(cnt, 1)) >= TEXTURE_SIGMAS * self.noise
        zc = np.where(core, a / self.sigma[ys, xs], 0.0)
        snr = np.bincount(li, zc, m) / np.sqrt(np.maximum(cnt, 1))
        good &= snr >= s.min_snr
        shadow = (dark_all & (ratio_p10 >= s.shadow_ratio_min)
                  & (~textured | (texture_r >= s.shadow_texture_min)))
        x0 = stats[keep, cv2.CC_STAT_LEFT]
        y0 = stats[keep, cv2.CC_STAT_TOP]
        x1 = x0 + stats[keep, cv2.CC_STAT_WIDTH]
        y1 = y0 + stats[keep, cv2.CC_STAT_HEIGHT]
        border = (x0 <= 0) | (y0 <= 0) | (x1 >= self.cols) | (y1 >= self.rows)
        out = np.zeros(m, DETECTION_DTYPE)
        out["u"], out["v"], out["weight"] = u, v, sw
        out["area"] = stats[keep, cv2.CC_STAT_AREA]
        out["muu"], out["mvv"], out["muv"] = muu, mvv, muv
        out["contrast"], out["bright_share"] = contrast, bright
        out["ratio_p10"], out["texture_r"] = ratio_p10, texture_r
        out["snr"], out["shadow"], out["border"] = snr, shadow, border
        out["textured"] = textured
        out["level"], out["obj_level"], out["mixed"] = level, obj, mixed
        out["body_level"] = body_level
        out["beside_shadow"], out["lit_level"] = beside, lit_level
        out = out[good]
        if out.size > MAX_DETECTIONS:
            out = out[np.argsort(out["snr"])[::-1][:MAX_DETECTIONS]]
        return out
