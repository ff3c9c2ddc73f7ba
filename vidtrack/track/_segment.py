"""Segmentation of moving objects against the background.

Internal to the tracker. Two ways to look at a frame:

- :meth:`Segmenter.coarse`: the whole frame, cheaply (integer absolute difference,
  per-pixel threshold, block-reduced before the connected components), used only while
  the straw is not being followed;
- :meth:`Segmenter.segment`: a region of interest at full resolution (integer
  operations), with the per-pixel threshold and, once the straw's grey level is known,
  only changes *towards* that level (a shadow darkens a bright straw's background: not
  the straw). Floating-point work is then confined to the box around the blob that is
  measured (:meth:`Region.work`), by its kind: a rod by its coverage
  (:mod:`vidtrack.track._coverage`), an object of both polarities by its body
  (:mod:`vidtrack.track._mixed`), any other by its silhouette or its fully covered core
  (:mod:`vidtrack.track._silhouette`).
"""

import math
from dataclasses import dataclass

import cv2
import numpy as np

#: Kernels of the 1- and 2-pixel dilations and closings.
K3 = np.ones((3, 3), np.uint8)
K5 = np.ones((5, 5), np.uint8)

#: A pixel's coverage is read off it where ``|level - background|`` exceeds this fraction
#: of the detection threshold (3 sigma at k = 5): the coverage's noise is then at most a
#: third of the straw's full contrast.
READABLE = 0.6

#: Coverage read off a pixel is kept within this range. Not [0, 1]: noise and the
#: ringing of compression round the straw's edges are as often below the background as
#: above it, and cutting off the negative half biases the centroid towards wherever the
#: ringing is strong (measured on MJPG quality 40 footage of the sample run's settings:
#: 0.030 px RMS centroid error with [0, 1], 0.015 px without the cut; on lossless footage
#: both are below 0.01 px). The wide range only stops gross values.
COVERAGE_RANGE = (-1.0, 2.0)

#: Pixels kept round a region's detections: the closing's and the dilation's reach, + 1.
_CROP_MARGIN = 3

#: Brightness changes (relative) below this are taken as no flicker.
_GAIN_TOL = 0.01

#: A speck (:meth:`Segmenter.specks`) has at least this many pixels: a smaller set is
#: never taken for an object (the tracker's ``min_area_px``, 4 by default).
SPECK_PX = 4


def fill_holes(mask):
    """``mask`` (uint8 0/1 or 0/255) with the holes inside its components filled (bool)."""
    m = (mask > 0).astype(np.uint8)
    rows, cols = m.shape
    pad = np.zeros((rows + 2, cols + 2), np.uint8)
    pad[1:-1, 1:-1] = m
    flood = pad.copy()
    ff = np.zeros((rows + 4, cols + 4), np.uint8)
    cv2.floodFill(flood, ff, (0, 0), 1)
    return (pad[1:-1, 1:-1] > 0) | (flood[1:-1, 1:-1] == 0)


def convex_hull(mask):
    """The convex hull of ``mask``'s nonzero pixels, filled (bool, ``mask``'s shape)."""
    hull = np.zeros(mask.shape, np.uint8)
    cv2.fillConvexPoly(hull, cv2.convexHull(cv2.findNonZero(mask.view(np.uint8))), 1)
    return hull.view(bool)


def opposite(work, ignore=None):
    """The pixels of ``work`` changed beyond the threshold the other way than the
    object's level (bool), less ``ignore`` (bool) when given."""
    opp = (work.d * work.den < 0) & (np.abs(work.d) > work.t)
    if ignore is not None:
        opp &= ~ignore
    return opp


@dataclass
class Blob:
    """One connected component of a region of interest, measured.

    Coordinates are full-frame pixels, OpenCV convention: pixel (col, row) has its
    centre at (u, v) = (col, row).
    """

    label: int
    u: float
    v: float
    mask_area: int
    bbox: tuple          # (x0, y0, x1, y1) half-open, full frame
    area: float = np.nan  # coverage sum, px^2
    angle: float = np.nan
    length: float = np.nan
    width: float = np.nan
    level: float = np.nan  # the straw's grey level read off this blob
    touches_border: bool = False
    touches_roi: bool = False
    index: int = -1      # source index of the frame it was seen in
    polarity: int = 0    # +1 brighter than the background, -1 darker, 0 both (one object)
    merged: bool = False  # touches a moving object of the other polarity
    contrast: float = np.nan  # typical |f - b| of its pixels (90th percentile)
    edge_w: float = np.nan    # contrast / steepest gradient of f - b at its edge (px)
    edge_w_alone: float = np.nan  # the same without the edges of what touches it in the
    # other polarity (a shadow's own penumbra, not the straw's edge beside it)
    silhouette: tuple = None  # (u, v, area, angle, length, width) by its silhouette
    hidden: float = 0.0       # how far part of it unseen could put its centre (px)
    off_axis: float = 0.0     # a rod's coverage share beyond its band (another across it)
    core: int = 0             # its fully covered pixels, read by one grey level
    # (width, length) of its strongest pixels (coverage at least half its 90th
    # percentile): a thin straw with a fainter rod or a shadow attached is still a line
    strong_shape: tuple = (np.nan, np.nan)
    fitted: bool = False      # a thin straw's centre from its own line fitted (_thin)
    separated: tuple = None   # (u, v, area, angle, length, width, off_axis) on its core's
    #                           band, of a rod of both polarities measured whole
    banded: bool = False      # a rod of both polarities measured on its core's band
    shadowless: tuple = None  # (u, v, area, angle, length, width) without the shadow
    #                           attached to it, of an object measured whole
    uniform: float = 0.0      # the core's share of the region it closes (1: one level)


class Segmenter:
    """Thresholds and background of one view, ready for per-frame work.

    Parameters
    ----------
    background : vidtrack.track.background.Background
    k_sigma : float
        Threshold in multiples of the noise.
    """

    def __init__(self, background, *, k_sigma):
        self.bg = np.ascontiguousarray(background.image, dtype=np.float32)
        self.thr = background.threshold(k=k_sigma)
        self.shape = self.bg.shape
        dtype = np.dtype(background.dtype)
        self.top = float(np.iinfo(dtype).max) if dtype.kind in "ui" else 65535.0
        self.dtype = dtype
        self.bg_int = np.clip(np.rint(self.bg), 0, self.top).astype(dtype)
        self.scale = 1.0
        self._set_thr_int()
        rows, cols = self.shape
        self.decimate = max(1, int(np.ceil(max(rows, cols) / 320.0)))
        d = self.decimate
        self.small_size = (max(1, cols // d), max(1, rows // d))
        # Pixels for the global gain (flicker): a sparse grid away from dark areas.
        step = max(1, int(np.sqrt(rows * cols / 600.0)))
        grid = np.zeros(self.shape, bool)
        grid[step // 2::step, step // 2::step] = True
        grid &= self.bg > max(8.0, 0.05 * float(self.bg.max()))
        self.gain_index = np.flatnonzero(grid)
        self.gain_ref = self.bg.reshape(-1)[self.gain_index]

    def _set_thr_int(self):
        # in whole grey levels a pixel counts when it differs from the rounded background
        # by more than the threshold rounded up: 1 to 2 levels above k sigma, a margin for
        # the background's rounding and for the blocks compression re-encodes round a
        # moving object, which the static scene's noise does not show. Measured with the
        # threshold rounded down instead (the margin 0 to 1 level): the ball toss keeps 15
        # of its 18 usable frames (block halos join the ball: 0.62 px RMS from the
        # reference, against 0.49), though a bear at 0.4 times the contrast is then found
        # whole (48 of 59 usable, against 1)
        self.thr_int = np.clip(np.ceil(self.thr), 1, self.top).astype(self.dtype)
        self.thr2_int = np.clip(np.ceil(2.0 * self.thr), 1, self.top).astype(self.dtype)

    # ---------------------------------------------------------------- compression specks
    def specks(self, frame, gain=1.0, *, at_least=0):
        """How many specks ``frame`` holds: sets of at least :data:`SPECK_PX` connected
        pixels beyond the threshold none of which changed by twice the threshold.

        Footage compressed hard re-encodes blocks of the static scene by a few grey levels
        now and then (at a key frame, when the bit rate runs short): noise far out in the
        tail of what the frame differences measured, thousands of specks per frame, among
        which a small object is one of many and to which it merges. An object is not a
        speck: some of its pixels change by far more (a faint object's fragments can be).
        Returns 0 without labelling the frame when fewer than ``at_least`` specks could
        fit in the weak pixels (beyond the threshold, not beyond twice it).
        """
        rows, cols = self.shape
        ad = cv2.absdiff(frame, self._bg_int(0, rows, 0, cols, gain))
        mask = cv2.compare(ad, self.thr_int, cv2.CMP_GT)
        strong = cv2.compare(ad, self.thr2_int, cv2.CMP_GT)
        if cv2.countNonZero(mask) - cv2.countNonZero(strong) < SPECK_PX * max(at_least, 1):
            return 0
        n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        hit = np.zeros(n, bool)
        hit[labels[strong > 0]] = True
        return int(np.count_nonzero((stats[1:, 4] >= SPECK_PX) & ~hit[1:]))

    def raise_threshold(self, factor):
        """Multiply the threshold by ``factor`` from now on (:attr:`scale`: the product)."""
        self.scale *= float(factor)
        self.thr = (self.thr * np.float32(factor)).astype(np.float32)
        self._set_thr_int()

    # ---------------------------------------------------------------- global gain
    def gain(self, frame):
        """Ratio of this frame's brightness to the background's (median over a grid).

        Lighting on mains power flickers at twice its frequency; the tracker scales the
        background by this factor. Returns exactly 1.0 when the change is below 1 % or
        there are too few pixels to tell.
        """
        if self.gain_index.size < 100:
            return 1.0
        ratio = frame.reshape(-1)[self.gain_index] / self.gain_ref
        mid = ratio.size // 2
        g = float(np.partition(ratio, mid)[mid])
        if not np.isfinite(g) or g <= 0 or abs(g - 1.0) < _GAIN_TOL:
            return 1.0
        return g

    def _bg_int(self, y0, y1, x0, x1, gain):
        if gain == 1.0:
            return self.bg_int[y0:y1, x0:x1]
        return np.clip(np.rint(self.bg[y0:y1, x0:x1] * gain), 0, self.top).astype(self.dtype)

    # ---------------------------------------------------------------- whole frame
    def coarse(self, frame, gain=1.0):
        """Boxes of moving objects in the whole frame (cheap).

        Returns
        -------
        list of (x0, y0, x1, y1, count)
            Half-open full-frame boxes and the number of foreground pixels in each,
            largest first.
        """
        rows, cols = self.shape
        ad = cv2.absdiff(frame, self._bg_int(0, rows, 0, cols, gain))
        mask = cv2.compare(ad, self.thr_int, cv2.CMP_GT)
        if cv2.countNonZero(mask) == 0:
            return []
        d = self.decimate
        sw, sh = self.small_size
        # foreground pixels counted per d x d block (a block counts with 2 or more);
        # only the bands of rows that have any are looked at (most frames: a few)
        rowany = mask.any(axis=1)
        band_any = np.zeros(sh, bool)
        np.logical_or.at(band_any, np.minimum(np.flatnonzero(rowany) // d, sh - 1), True)
        bands = np.flatnonzero(band_any)
        rows_idx = (bands[:, None] * d + np.arange(d)[None, :]).reshape(-1)
        rows_idx = rows_idx[rows_idx < rows]
        flat = np.flatnonzero(mask[rows_idx])
        py, px = rows_idx[flat // cols], flat % cols
        cell = np.minimum(py // d, sh - 1) * sw + np.minimum(px // d, sw - 1)
        counts = np.bincount(cell, minlength=sw * sh)
        need = 2 if d > 1 else 1
        hit = np.flatnonzero(counts >= need)
        if not hit.size:
            return []
        hy, hx = hit // sw, hit % sw
        y0c, y1c, x0c, x1c = int(hy.min()), int(hy.max()) + 1, int(hx.min()), int(hx.max()) + 1
        small = np.zeros((y1c - y0c, x1c - x0c), np.uint8)
        small[hy - y0c, hx - x0c] = 255
        if d == 1:
            # single isolated pixels are noise: keep pixels with a neighbour
            nb = cv2.filter2D(small, cv2.CV_16U, K3, borderType=cv2.BORDER_CONSTANT)
            small[nb <= 255] = 0
        n, _, stats, _ = cv2.connectedComponentsWithStats(small, connectivity=8)
        out = []
        for k in range(1, n):
            x, y, w, h, a = (int(q) for q in stats[k])
            x += x0c
            y += y0c
            out.append((min(cols, x * d), min(rows, y * d), min(cols, (x + w) * d),
                        min(rows, (y + h) * d), a * d * d))
        out.sort(key=lambda b: -b[4])
        return out

    # ---------------------------------------------------------------- region of interest
    def segment(self, frame, roi, *, gain=1.0, level=None, polarity=0):
        """Components of the moving objects inside ``roi``.

        Parameters
        ----------
        frame : numpy.ndarray
            The full frame.
        roi : (x0, y0, x1, y1)
            Half-open box, clipped to the frame by the caller.
        gain : float
            Brightness of this frame relative to the background.
        level : float or None
            The straw's grey level; when known only changes towards it count.
        polarity : int
            Without a level: +1 only brightening, -1 only darkening, 0 both (a bright
            straw on a dark blade are then two components, not one).

        Returns
        -------
        Region
        """
        x0, y0, x1, y1 = roi
        fi = frame[y0:y1, x0:x1]
        bi = self._bg_int(y0, y1, x0, x1, gain)
        ti = self.thr_int[y0:y1, x0:x1]
        # Over the whole region only what changed beyond the threshold (two passes); the
        # rest only round the changes (with the reach of the closing and the 2-pixel
        # dilation below, + 1): the components are the same as over the whole region, at
        # a fraction of the cost (a region is mostly background). Every mask below is
        # part of ``changed``.
        changed = cv2.compare(cv2.absdiff(fi, bi), ti, cv2.CMP_GT)
        bx, by, bw, bh = cv2.boundingRect(changed)
        if bw == 0 or bh == 0:                    # nothing changed: no components
            empty = np.zeros((0, 0), np.uint8)
            return Region(roi=(x0, y0, x0, y0), bounds=roi, frame=frame, seg=self,
                          gain=gain, labels=empty, stats=np.zeros((1, 5), np.int32),
                          centroids=np.zeros((1, 2)), n=1, strict=empty)
        m = _CROP_MARGIN
        cx0, cy0 = max(0, bx - m), max(0, by - m)
        cx1, cy1 = min(x1 - x0, bx + bw + m), min(y1 - y0, by + bh + m)
        fi, bi, ti = (a[cy0:cy1, cx0:cx1] for a in (fi, bi, ti))
        weak = None
        if level is not None and np.isfinite(level):
            pos = cv2.compare(cv2.subtract(fi, bi), ti, cv2.CMP_GT)
            neg = cv2.compare(cv2.subtract(bi, fi), ti, cv2.CMP_GT)
            up = cv2.compare(bi, float(level), cv2.CMP_LT)
            lev = np.full_like(bi, int(np.clip(round(level), 0, self.top)))
            weak = cv2.compare(cv2.absdiff(bi, lev), ti, cv2.CMP_LE)
            mask = (pos & up) | (neg & ~up)
        elif polarity > 0:
            mask = cv2.compare(cv2.subtract(fi, bi), ti, cv2.CMP_GT)
        elif polarity < 0:
            mask = cv2.compare(cv2.subtract(bi, fi), ti, cv2.CMP_GT)
        else:
            mask = changed[cy0:cy1, cx0:cx1]
        strict = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, K3)
        m8 = strict
        if weak is not None:
            # Where the straw's level is within the threshold of the background the
            # straw cannot be seen; such pixels next to a detection keep its parts in
            # one component (their coverage is filled in by measure()).
            m8 = strict | (cv2.dilate(strict, K5) & weak)
        n, labels, stats, cents = cv2.connectedComponentsWithStats(m8, connectivity=8)
        return Region(roi=(x0 + cx0, y0 + cy0, x0 + cx1, y0 + cy1), bounds=roi, frame=frame,
                      seg=self, gain=gain, labels=labels, stats=stats, centroids=cents, n=n,
                      strict=strict)


@dataclass
class Region:
    """A segmented region of interest (integer masks; floats on demand).

    ``bounds`` is the region asked for; ``roi`` the part of it the masks cover (the
    detections' box with a margin), the origin of ``labels``, ``stats`` and
    ``centroids``.
    """

    roi: tuple
    bounds: tuple
    frame: np.ndarray
    seg: Segmenter
    gain: float
    labels: np.ndarray
    stats: np.ndarray
    centroids: np.ndarray
    n: int
    strict: np.ndarray   # the detections (uint8 0/255) before weak pixels joined them

    def components(self, min_area, frame_shape):
        """Blobs with at least ``min_area`` mask pixels (unmeasured: mask centroid)."""
        x0, y0 = self.roi[:2]
        r0, s0, r1, s1 = self.bounds
        rows, cols = frame_shape
        out = []
        for k in range(1, self.n):
            x, y, w, h, a = (int(s) for s in self.stats[k])
            if a < min_area:
                continue
            bx0, by0, bx1, by1 = x0 + x, y0 + y, x0 + x + w, y0 + y + h
            blob = Blob(label=k, u=x0 + float(self.centroids[k][0]),
                        v=y0 + float(self.centroids[k][1]), mask_area=a,
                        bbox=(bx0, by0, bx1, by1))
            blob.touches_border = bx0 <= 0 or by0 <= 0 or bx1 >= cols or by1 >= rows
            blob.touches_roi = ((bx0 <= r0 and r0 > 0) or (by0 <= s0 and s0 > 0)
                                or (bx1 >= r1 and r1 < cols) or (by1 >= s1 and s1 < rows))
            out.append(blob)
        return out

    def peak(self, group):
        """Largest change ``|f - b|`` over the pixels of the components ``group``."""
        st = self.stats[group]
        gx0, gy0 = int(st[:, 0].min()), int(st[:, 1].min())
        gx1, gy1 = int((st[:, 0] + st[:, 2]).max()), int((st[:, 1] + st[:, 3]).max())
        lab = self.labels[gy0:gy1, gx0:gx1]
        sel = np.isin(lab, group)
        ox, oy = self.roi[0] + gx0, self.roi[1] + gy0
        f = self.frame[oy:oy + lab.shape[0], ox:ox + lab.shape[1]].astype(np.float32)
        b = self.seg.bg[oy:oy + lab.shape[0], ox:ox + lab.shape[1]] * np.float32(self.gain)
        return float(np.abs(f - b)[sel].max()) if sel.any() else 0.0

    def work(self, group, level, *, margin):
        """Float arrays over the box of the components ``group``, grown by ``margin``.

        Returns
        -------
        Work
        """
        st = self.stats[group]
        gx0, gy0 = int(st[:, 0].min()), int(st[:, 1].min())
        gx1, gy1 = int((st[:, 0] + st[:, 2]).max()), int((st[:, 1] + st[:, 3]).max())
        m = int(math.ceil(margin))
        ox, oy = self.roi[0], self.roi[1]
        r0, s0, r1, s1 = self.bounds
        # the box in frame pixels, within the region asked for (it may reach beyond the
        # part the masks cover: nothing was detected there)
        fx0, fy0 = max(r0, ox + gx0 - m), max(s0, oy + gy0 - m)
        fx1, fy1 = min(r1, ox + gx1 + m), min(s1, oy + gy1 + m)
        seg = self.seg
        f = self.frame[fy0:fy1, fx0:fx1].astype(np.float32)
        b = seg.bg[fy0:fy1, fx0:fx1]
        if self.gain != 1.0:
            b = b * np.float32(self.gain)
        t = seg.thr[fy0:fy1, fx0:fx1]
        labels = self._in_box(self.labels, fx0, fy0, fx1, fy1)
        if len(group) == 1:
            sel = labels == group[0]
        else:
            lut = np.zeros(self.n, bool)
            lut[group] = True
            sel = lut[labels]
        others = (labels > 0) & ~sel
        sel &= self._in_box(self.strict, fx0, fy0, fx1, fy1) > 0
        d = f - b
        den = np.float32(level) - b
        return Work(origin=(fx0, fy0), f=f, b=b, t=t, d=d, den=den,
                    sel=sel.view(np.uint8), others=others)

    def _in_box(self, a, fx0, fy0, fx1, fy1):
        """``a`` (over ``roi``) over the frame box given, zero where it has no pixels."""
        ox, oy, ox1, oy1 = self.roi
        if ox <= fx0 and oy <= fy0 and fx1 <= ox1 and fy1 <= oy1:
            return a[fy0 - oy:fy1 - oy, fx0 - ox:fx1 - ox]
        out = np.zeros((fy1 - fy0, fx1 - fx0), a.dtype)
        ix0, iy0 = max(fx0, ox), max(fy0, oy)
        ix1, iy1 = min(fx1, ox1), min(fy1, oy1)
        if ix0 < ix1 and iy0 < iy1:
            out[iy0 - fy0:iy1 - fy0, ix0 - fx0:ix1 - fx0] = a[iy0 - oy:iy1 - oy,
                                                              ix0 - ox:ix1 - ox]
        return out


@dataclass
class Work:
    """Float32 arrays of a box around the straw (``origin``: its top-left pixel)."""

    origin: tuple
    f: np.ndarray
    b: np.ndarray
    t: np.ndarray
    d: np.ndarray
    den: np.ndarray
    sel: np.ndarray      # uint8 0/1: the straw's detected pixels
    others: np.ndarray   # bool: pixels of other components
    trimmed: np.ndarray = None   # bool: detections cut off as not the object's (a shadow)


def read_level(region, blob):
    """The straw's grey level seen in ``blob``: median of its most changed pixels.

    Fully covered pixels show the straw's own level whatever the background; among a
    blob's pixels they are those that differ most from the background (partly covered
    ones differ less for the same background). The median of the top third is taken.
    """
    x, y, w, h = (int(s) for s in region.stats[blob.label][:4])
    ox, oy = region.roi[0], region.roi[1]
    sel = region.labels[y:y + h, x:x + w] == blob.label
    f = region.frame[oy + y:oy + y + h, ox + x:ox + x + w][sel].astype(np.float32)
    b = region.seg.bg[oy + y:oy + y + h, ox + x:ox + x + w][sel]
    if region.gain != 1.0:
        b = b * np.float32(region.gain)
    if f.size == 0:
        return np.nan
    ad = np.abs(f - b)
    k = max(1, f.size // 3)
    top = np.argpartition(ad, f.size - k)[f.size - k:]
    return float(np.median(f[top]))


def edge_stats(work, mask=None, *, alone=False):
    """Contrast and edge width of the detected pixels of ``work`` (for shadows).

    With ``alone``, the edges of anything of the other polarity touching them are left
    out (a shadow's ring holds the sharp edge of the bright straw beside it).

    Returns
    -------
    (float, float)
        The 90th percentile of ``|f - b|`` over the detections, and that contrast divided
        by the 90th percentile of the gradient of ``f - b`` over the detections grown by
        a pixel: about 2 px for a sharp edge (the gradient's 3 x 3 stencil), more for a
        blurred one (a shadow's penumbra). NaN without detections.
    """
    sel = work.sel.view(bool) if mask is None else mask
    if not sel.any():
        return np.nan, np.nan
    ad = np.abs(work.d)
    contrast = float(np.percentile(ad[sel], 90))
    gx = cv2.Sobel(work.d, cv2.CV_32F, 1, 0, ksize=3, scale=0.125)
    gy = cv2.Sobel(work.d, cv2.CV_32F, 0, 1, ksize=3, scale=0.125)
    ring = cv2.dilate(sel.view(np.uint8), K3).view(bool)
    side = np.float32(np.sign(np.median(work.d[sel])) or 1.0)
    other = ((work.d * side) < -work.t).view(np.uint8) if np.ndim(work.t) else \
        ((work.d * side) < -np.float32(work.t)).view(np.uint8)
    if alone and other.any():
        ring &= ~cv2.dilate(other, K5).view(bool)
        if not ring.any():
            return contrast, np.nan
    g = float(np.percentile(cv2.magnitude(gx, gy)[ring], 90))
    return contrast, contrast / max(g, 1e-6)


def work_margin(width, length, bbox):
    """Margin (px) around the straw's components that the measurement may need."""
    w = width if width and np.isfinite(width) else 1.0
    extra = 0.0
    if length and np.isfinite(length):
        extra = max(0.0, length - max(bbox[2] - bbox[0], bbox[3] - bbox[1]))
    return max(3.0 + extra, 2 * math.ceil(max(w, 1.0)) + 4)
