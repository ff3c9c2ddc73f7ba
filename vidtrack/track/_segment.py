"""Segmentation of moving objects against the background, and the coverage measurement.

Internal to :mod:`vidtrack.track.tracker`. Two ways to look at a frame:

- :meth:`Segmenter.coarse`: the whole frame, cheaply (integer absolute difference,
  per-pixel threshold, block-reduced before the connected components), used only while
  the straw is not being followed;
- :meth:`Segmenter.segment`: a region of interest at full resolution (integer
  operations), with the per-pixel threshold and, once the straw's grey level is known,
  only changes *towards* that level (a shadow darkens a bright straw's background: not
  the straw). Floating-point work is then confined to the box around the blob that is
  measured (:meth:`Region.work`).

:func:`measure` turns the straw's blob into its centroid, area, orientation and length
from its **coverage** of each pixel: a pixel that the opaque straw covers by a fraction
c shows ``f = b + c (s - b)`` (b the background, s the straw's grey level), so
``c = (f - b) / (s - b)``, not clipped to [0, 1] (:data:`COVERAGE_RANGE`). Weighting
by c instead of by ``|f - b|`` keeps the centroid unbiased over a textured background,
where ``|s - b|`` changes from pixel to pixel. Where ``|s - b|`` is within the noise
the coverage cannot be read off the pixel; inside the straw's rod (its axis and width
from the readable part) such a pixel gets the rod's coverage (:func:`_band_fill`).
"""

import copy
import math
from dataclasses import dataclass

import cv2
import numpy as np

from vidtrack.track._thin import GAP_MAX_PX, THIN_PX, fit_line, local_centroid, strong_line

#: Kernels of the 1- and 2-pixel dilations and closings.
_K3 = np.ones((3, 3), np.uint8)
_K5 = np.ones((5, 5), np.uint8)

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
#: A rod of both polarities: its core is where its main polarity shows at least this
#: share of its level (a rider of half the contrast never does), and its band reaches
#: :data:`CORE_EDGE_PX` beyond the core's farthest pixel.
CORE = 0.75
CORE_EDGE_PX = 1.5

#: Pixels kept round a region's detections: the closing's and the dilation's reach, + 1.
_CROP_MARGIN = 3

#: Brightness changes (relative) below this are taken as no flicker.
_GAIN_TOL = 0.01

#: A speck (:meth:`Segmenter.specks`) has at least this many pixels: a smaller set is
#: never taken for an object (the tracker's ``min_area_px``, 4 by default).
SPECK_PX = 4


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
    off_axis: float = 0.0     # a rod's coverage share beyond its band (another across it)
    core: int = 0             # its fully covered pixels, read by one grey level
    # (width, length) of its strongest pixels (coverage at least half its 90th
    # percentile): a thin straw with a fainter rod or a shadow attached is still a line
    strong_shape: tuple = (np.nan, np.nan)
    fitted: bool = False      # a thin straw's centre from its own line fitted (_thin)
    separated: tuple = None   # (u, v, area, angle, length, width, off_axis) on its core's
    #                           band, of a rod of both polarities measured whole
    banded: bool = False      # a rod of both polarities measured on its core's band
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
            nb = cv2.filter2D(small, cv2.CV_16U, _K3, borderType=cv2.BORDER_CONSTANT)
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
        strict = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, _K3)
        m8 = strict
        if weak is not None:
            # Where the straw's level is within the threshold of the background the
            # straw cannot be seen; such pixels next to a detection keep its parts in
            # one component (their coverage is filled in by measure()).
            m8 = strict | (cv2.dilate(strict, _K5) & weak)
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


def _top_third_median(vals):
    """Median of the largest third of ``vals`` (a 1-D array, not empty): an object's
    level from its most changed pixels, which are the fully covered ones."""
    k = max(1, vals.size // 3)
    return float(np.median(np.partition(vals, vals.size - k)[vals.size - k:]))


def other_touching(work, *, width, min_area):
    """Something of the other polarity touches the straw: solid (it survives a 3 x 3
    opening) and reaching beyond the 2-pixel seam where compression rings round the
    straw's edges (a halo is not an object)."""
    sel = work.sel
    opp = ((work.d * work.den < 0) & (np.abs(work.d) > work.t)).view(np.uint8)
    hug = cv2.dilate(sel, _K5)
    if np.count_nonzero(hug & opp) < min_area:
        return False
    k = 2 * int(math.ceil(max(width or 1.0, 1.0))) + 3
    kernel = np.ones((k + 4, k + 4), np.uint8)
    solid = cv2.morphologyEx(opp, cv2.MORPH_OPEN, _K3)
    return np.count_nonzero(cv2.dilate(sel, kernel) & ~hug & solid) >= min_area


def other_behind(work, level, *, width, min_area):
    """Take a moving object of the other polarity touching the straw as its background.

    A bright straw riding a dark blade (or crossing a dark object) does not cover the
    static background but the object: its coverage must be read against the object's
    level. The object's pixels near the straw (changed *away* from the straw's level)
    are closed over the straw's width, and inside that region the background becomes the
    object's median level (in place, in ``work``).

    Returns
    -------
    bool
        True when such an object touches the straw (the frame is then flagged).
    """
    if not other_touching(work, width=width, min_area=min_area):
        return False
    sel = work.sel
    opp = ((work.d * work.den < 0) & (np.abs(work.d) > work.t)).view(np.uint8)
    k = 2 * int(math.ceil(max(width or 1.0, 1.0))) + 3
    kernel = np.ones((k, k), np.uint8)
    near = cv2.dilate(sel, kernel).view(bool)
    obj = opp.view(bool) & near
    if not obj.any():
        return True
    obj_level = np.float32(np.median(work.f[obj]))
    behind = cv2.morphologyEx(opp, cv2.MORPH_CLOSE, kernel).view(bool) & near
    b = work.b.copy()
    b[behind] = obj_level
    work.b = b
    work.d = work.f - b
    work.den = np.float32(level) - b
    return True


def trim_to_rod(work, *, width, length, core=0.75):
    """Keep the straw's own band of the detections (in place, in ``work``).

    The straw is a rod of a known width and length at one grey level: its fully
    covered core (coverage at least ``core``; a dimmer rod never reaches it) gives its
    axis, and only the detections within ``width / 2 + 1`` px of that axis and
    ``length / 2 + 1`` px along it from the core's centre are the straw's; the rest (a
    thinner, dimmer rod riding along it or across it) become other pixels, which
    :func:`measure` leaves out; the band's pixels beside them (not fully covered) are
    made unreadable, for :func:`measure` to complete from the rod model. Returns the
    number of detections dropped, or None when
    the core is too small or too round to give an axis (nothing changed).
    """
    sel = work.sel.view(bool)
    readable = np.abs(work.den) > np.float32(READABLE) * work.t
    c = np.zeros_like(work.d)
    np.divide(work.d, work.den, out=c, where=readable)
    full = sel & readable & (c >= core)
    if np.count_nonzero(full) < 3:
        return None
    m = cv2.moments(full.view(np.uint8), True)
    a, bb, cc = m["mu20"] / m["m00"], m["mu11"] / m["m00"], m["mu02"] / m["m00"]
    rad = np.hypot(0.5 * (a - cc), bb)
    if not rad > 0.25 * (a + cc):       # a round core: no axis
        return None
    ang = 0.5 * np.arctan2(2.0 * bb, a - cc)
    cu, cv_ = m["m10"] / m["m00"], m["m01"] / m["m00"]
    yy, xx = np.indices(sel.shape, dtype=np.float32)
    along = (xx - cu) * np.cos(ang) + (yy - cv_) * np.sin(ang)
    perp = -(xx - cu) * np.sin(ang) + (yy - cv_) * np.cos(ang)
    # (a thin straw's width is the pixel grid's: its band is the thin limit's)
    half = 0.5 * max(width, THIN_PX) + 1.0
    band = (np.abs(perp) <= half) & (np.abs(along) <= 0.5 * length + 1.0)
    drop = sel & ~band
    n = int(np.count_nonzero(drop))
    if n:
        work.sel = (sel & band).view(np.uint8)
        work.others = work.others | drop
        # the band's edge pixels beside what was cut away show both: not readable,
        # completed from the rod model
        beside = cv2.dilate(drop.view(np.uint8), _K3).view(bool) & band & ~full
        if beside.any():
            den = work.den.copy()
            den[beside] = 0.0
            work.den = den
    return n


def shade_background(work):
    """Take a shadow beside the straw into its background (in place, in ``work``).

    A shadow darkens the static background by a factor that varies smoothly (its
    penumbra), also under the straw's edge on that side, where the straw's coverage is
    read. The factor ``f / b`` is read off the shadow's pixels beside the straw (changed
    away from the straw's level) and carried 2 px further by normalised 3 x 3
    averages, under the straw's edge; there the background becomes ``b`` times it.
    Returns the number of pixels whose background changed.
    """
    opp = (work.d * work.den < 0) & (np.abs(work.d) > work.t)
    near = cv2.dilate(work.sel, np.ones((9, 9), np.uint8)).view(bool)
    shade = opp & near
    if not shade.any():
        return 0
    b = work.b
    ratio = np.ones_like(b)
    np.divide(work.f, b, out=ratio, where=shade & (b > 0))
    w = shade.astype(np.float32)
    rw = ratio * w
    known = shade.copy()
    for _ in range(2):
        num = cv2.blur(rw, (3, 3), borderType=cv2.BORDER_CONSTANT)
        cnt = cv2.blur(w, (3, 3), borderType=cv2.BORDER_CONSTANT)
        got = ~known & (cnt > 0)
        ratio[got] = num[got] / cnt[got]
        w[got] = 1.0
        known |= got
        rw = ratio * w
    b2 = b.copy()
    b2[known] = b[known] * ratio[known]
    work.b = b2
    work.d = work.f - b2
    level = work.den + b          # the straw's level (den = level - b)
    work.den = level - b2
    return int(np.count_nonzero(known))


def _axis(c):
    """Centroid, unit axis and the two second moments of a coverage image."""
    m = cv2.moments(c, False)
    m00 = m["m00"]
    if not m00 > 0:
        return None
    a, bb, cc = m["mu20"] / m00, m["mu11"] / m00, m["mu02"] / m00
    ang = 0.5 * np.arctan2(2.0 * bb, a - cc)
    half = 0.5 * (a + cc)
    rad = np.hypot(0.5 * (a - cc), bb)
    return (m["m10"] / m00, m["m01"] / m00, np.cos(ang), np.sin(ang), half + rad,
            max(half - rad, 0.0))


def _band_fill(c, sup, unread, readable, *, width, length):
    """Coverage of unreadable pixels from a rod model along the readable part's axis.

    The rod has the readable part's axis and the reference ``width``; along the axis it
    spans the readable part's covered pixels, extended towards an end that runs into
    unreadable pixels until it has the reference ``length``. Returns the pixels filled
    (to be added to the support).
    """
    ax = _axis(np.where(sup, c, np.float32(0.0)))
    if ax is None:
        return None
    cx, cy, ca, sa, lam1, lam2 = ax
    if not (width and np.isfinite(width) and width > 0):
        width = float(np.sqrt(12.0 * lam2)) if lam2 > 0 else 1.0
    rows, cols = c.shape
    yy, xx = np.mgrid[0:rows, 0:cols]
    along = (xx - cx) * ca + (yy - cy) * sa
    across = np.abs(-(xx - cx) * sa + (yy - cy) * ca)
    inband = across <= 0.5 * width
    seen = readable & sup & (c > 0.5)
    if not seen.any():
        return None
    lo, hi = float(along[seen].min()), float(along[seen].max())
    # readable covered pixels on the axis beyond the detections (below the detection
    # threshold but readable) extend the rod while they continue it without a gap
    more = np.sort(along[readable & inband & (c > 0.5) & ~sup])
    if more.size:
        above = more[more > hi]
        for a in above:
            if a - hi > 1.5:
                break
            hi = float(a)
        below = more[more < lo][::-1]
        for a in below:
            if lo - a > 1.5:
                break
            lo = float(a)
    if length and np.isfinite(length) and hi - lo < length - 1.0:
        lo_hidden = (~readable & inband & (along < lo) & (along > lo - 2.5)).any()
        hi_hidden = (~readable & inband & (along > hi) & (along < hi + 2.5)).any()
        short = length - 1.0 - (hi - lo)
        if lo_hidden and hi_hidden:
            lo, hi = lo - short / 2, hi + short / 2
        elif lo_hidden:
            lo -= short
        elif hi_hidden:
            hi += short
    prof = np.clip(0.5 * width + 0.5 - across, 0.0, 1.0)
    prof *= np.clip(np.minimum(along - lo, hi - along) + 0.5, 0.0, 1.0)
    band = prof > 0
    hidden = band & ~readable
    c[hidden] = prof[hidden]
    return band


def measure(work, blob, level, *, width=None, length=None, thin=None, separate=True):
    """Coverage-weighted centroid, area, orientation and length of the straw (in place).

    Parameters
    ----------
    work : Work
        The box around the straw's components (:meth:`Region.work`).
    blob : Blob
        The straw's main component; its fields are filled in.
    level : float
        The straw's grey level.
    width, length : float, optional
        The straw's reference width and length (px), for the pixels where the straw
        cannot be seen (its level within the noise of the background's).
    thin : bool or None
        Its clean frames were a thin straw (:data:`~vidtrack.track._thin.THIN_PX`):
        its line is fitted when this frame's strongest pixels are a thin line too;
        False: they were not (not fitted); None: not known (fitted when this frame's
        are).
    separate : bool
        A rod of both polarities is measured on its core's band (:func:`measure_mixed`;
        False: whole, the band's measurement in ``blob.separated``).

    Returns
    -------
    Blob
        ``blob``, with ``u, v`` the coverage centroid (px), ``area`` the coverage sum
        (px^2), ``angle`` the orientation of the major axis in (-pi/2, pi/2] from +u
        towards +v, ``length`` and ``width`` ``sqrt(12 lambda)`` of the coverage's
        second moments (exact for a uniform rectangle).

    Notes
    -----
    The support is the detected pixels grown by one pixel, without other components.
    Unreadable pixels (``|level - background|`` below :data:`READABLE` times the
    threshold) inside a rod along the readable part's axis get the rod's coverage;
    other unreadable pixels of the support get the normalised average of their
    readable neighbours. A rod whose eroded detections hold pixels of the other
    polarity (at least 3 and 5 % of them: a highlight along a dark straw) is measured by
    :func:`measure_mixed` instead, its ``off_axis`` then read off its detections about
    the body's axis.
    """
    others = work.others
    support = cv2.dilate(work.sel, _K3)
    support[others] = 0
    d, t, den = work.d, work.t, work.den
    readable = np.abs(den) > np.float32(READABLE) * t
    c = np.zeros_like(d)
    np.divide(d, den, out=c, where=readable)
    np.clip(c, *COVERAGE_RANGE, out=c)
    sup = support.view(bool)
    # a highlight along the straw (brighter than the background where the straw is
    # darker), which the closing took into the detections, would be read as negative
    # coverage: a rod of both polarities, measured by its body
    # (not a straw known to be thin whose strongest pixels are still a thin line: what
    # the closing joined to it there, a shadow between it and a rider beside it, is not
    # inside it; its own line is fitted below)
    lit = cv2.erode(work.sel, _K3).view(bool) & (d * den < 0) & (np.abs(d) > t)
    if np.count_nonzero(lit) >= max(3, 0.05 * np.count_nonzero(work.sel)) and \
            not (thin and _thin_line(c, sup, readable)):
        measure_mixed(work, blob, rod=True, separate=separate)
        blob.level = level
        return blob
    unread = sup & ~readable
    if unread.any():
        c_read = c.copy()
        band = _band_fill(c, sup, unread, readable, width=width, length=length)
        if band is not None:
            # once more with the axis of the completed rod (a partly hidden rod's
            # visible part tilts the first axis)
            sup1 = (sup & readable) | (band & ~others)
            c2 = c_read.copy()
            band2 = _band_fill(c2, sup1, sup1 & ~readable, readable, width=width,
                               length=length)
            if band2 is not None:
                band, c = band2, c2
            band &= ~others
            sup = (sup & readable) | band
            unread[:] = False
    if unread.any():
        # normalised 3 x 3 averages of the readable coverage, twice (2 px deep)
        w = (sup & ~unread).astype(np.float32)
        cw = c * w
        for _ in range(2):
            num = cv2.blur(cw, (3, 3), borderType=cv2.BORDER_CONSTANT)
            cnt = cv2.blur(w, (3, 3), borderType=cv2.BORDER_CONSTANT)
            got = unread & (cnt > 0)
            c[got] = num[got] / cnt[got]
            w[got] = 1.0
            cw = c * w
            unread &= ~got
            if not unread.any():
                break
    c_all = c.copy()
    c[~sup] = 0.0
    m = cv2.moments(c, False)
    m00 = m["m00"]
    if m00 < 0.5 * float(c[c > 0].sum()):
        # the negative coverage outweighs half the positive: a faint blob in noise,
        # whose moments are not a rod's; measured on the positive coverage alone
        np.clip(c, 0.0, None, out=c)
        m = cv2.moments(c, False)
        m00 = m["m00"]
    x0, y0 = work.origin
    if not m00 > 0:
        blob.area = 0.0
        return blob
    blob.u = x0 + m["m10"] / m00
    blob.v = y0 + m["m01"] / m00
    blob.area = float(m00)
    a, bb, cc = m["mu20"] / m00, m["mu11"] / m00, m["mu02"] / m00
    half = 0.5 * (a + cc)
    rad = np.hypot(0.5 * (a - cc), bb)
    lam1, lam2 = max(half + rad, 0.0), max(half - rad, 0.0)
    blob.length = float(np.sqrt(12.0 * lam1))
    blob.width = float(np.sqrt(12.0 * lam2))
    ang = 0.5 * np.arctan2(2.0 * bb, a - cc)
    if ang <= -np.pi / 2:
        ang += np.pi
    blob.angle = float(ang)
    blob.level = level
    blob.off_axis = _off_axis(c, m, ang)
    line = strong_line(c)
    if line is not None:
        blob.strong_shape = line[:2]
        if line[0] < THIN_PX and thin is not False:
            # a thin straw: the moments' axis runs between it and a fainter rod beside
            # it, and their band holds both; its strongest pixels' axis is its own, and
            # its centre that of its own line fitted to the pixels (_thin)
            if line[1] >= 2.0 * THIN_PX:
                blob.off_axis = max(blob.off_axis, _off_axis(
                    c, None, line[4], centre=line[2:4], band=0.5 * line[0] + 1.5))
            domain = cv2.dilate(sup.view(np.uint8), _K3).view(bool) & ~others
            domain &= sup | readable
            got = fit_line(c_all, domain, line, m00 / max(line[1], 1.0))
            blob.fitted = got is not None
            if got is None and line[5] <= GAP_MAX_PX:
                # too short for a line (seen nearly end on), or the fit failed: the
                # coverage within 2 px of its strongest pixels (a fainter rod farther
                # off is not of it; a rod whose middle a highlight cancels keeps its
                # moments)
                got = local_centroid(c, line)
            if got is not None:
                blob.u, blob.v = x0 + got[0], y0 + got[1]
    return blob


def _thin_line(c, sup, readable):
    """The strongest pixels of the positive coverage over the support are a thin line."""
    line = strong_line(np.where(sup & readable, np.maximum(c, np.float32(0.0)),
                                np.float32(0.0)))
    return line is not None and line[0] < THIN_PX and line[1] >= 2.0 * THIN_PX


def _detections_off_axis(work, blob, ad, top, *, sel=None):
    """:func:`_off_axis` of a rod measured by its body (:func:`measure_mixed`): of its
    detections, each weighted by its change ``ad`` (up to ``top``, the 90th percentile of
    them), about the body's axis. What is attached across or beside the rod, and was
    closed into its body, shows there. ``sel``: the detections that are the rod's
    (default: all)."""
    if sel is None:
        sel = work.sel.view(bool)
    if not sel.any() or not blob.area > 0:
        return 0.0
    det = np.where(sel, np.minimum(ad / max(top, np.float32(1e-6)), np.float32(1.0)),
                   np.float32(0.0)).astype(np.float32)
    m = cv2.moments(det, False)
    if not m["m00"] > 0:
        return 0.0
    return _off_axis(det, m, blob.angle)


def _off_axis(c, m, ang, *, centre=None, band=None):
    """Share of a rod's coverage beyond its band (twice the median distance from the
    axis plus 1.5 px, or ``band``) from the axis (through the centroid of moments ``m``,
    or ``centre``), away from its ends: 0 for one rod, blurred or not; a rod attached
    across it (riding along, crossing) puts its arms there."""
    pos = c > 0.15
    if np.count_nonzero(pos) < 6:
        return 0.0
    yy, xx = np.nonzero(pos)
    w = c[pos].astype(np.float64)
    cx, cy = centre if centre is not None else (m["m10"] / m["m00"], m["m01"] / m["m00"])
    ca, sa = np.cos(ang), np.sin(ang)
    along = (xx - cx) * ca + (yy - cy) * sa
    across = np.abs(-(xx - cx) * sa + (yy - cy) * ca)
    if band is None:
        order = np.argsort(across)
        cum = np.cumsum(w[order])
        half = float(across[order][np.searchsorted(cum, 0.5 * cum[-1])])
        band = 2.0 * half + 1.5
    k = along.size
    lo, hi = np.partition(along, (k // 10, k - 1 - k // 10))[[k // 10, k - 1 - k // 10]]
    mid = (along > lo) & (along < hi)
    total = float(w[mid].sum())
    if total <= 0:
        return 0.0
    return float(w[mid & (across > band)].sum() / total)


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
    ring = cv2.dilate(sel.view(np.uint8), _K3).view(bool)
    side = np.float32(np.sign(np.median(work.d[sel])) or 1.0)
    other = ((work.d * side) < -work.t).view(np.uint8) if np.ndim(work.t) else \
        ((work.d * side) < -np.float32(work.t)).view(np.uint8)
    if alone and other.any():
        ring &= ~cv2.dilate(other, _K5).view(bool)
        if not ring.any():
            return contrast, np.nan
    g = float(np.percentile(cv2.magnitude(gx, gy)[ring], 90))
    return contrast, contrast / max(g, 1e-6)


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


def trim_attached(work, *, reach_px, along=(0.0, 0.0)):
    """Drop detections not within ``reach_px`` of the object's fully covered core (None:
    only measure the core).

    For an object of one grey level (``work.den`` from its level): its pixels show its
    level whatever the background, so their coverage ``c = d / den`` is 1, partial only
    in a ring at its edge (and a smear along the motion: ``along``, the motion's vector
    in px per exposure at most; the smear is read off the core, shorter along the
    motion than across it by the blur's length). What is detected farther out is
    attached to it, not of it: a shadow of the same polarity (c about 0.5: a lighter
    darkening, blurred), a reflection. Those pixels are taken out of ``work.sel`` (into
    ``work.trimmed``: the surroundings the edge is read against).

    Returns
    -------
    (int, int, float)
        The core's pixel count (c >= 0.8), the pixels dropped, and the core's share of
        the region it closes (holes filled; 1 for an object of one grey level, less for a
        textured object, which the caller does not trim; 0 when the core's grey levels
        spread over more than 15 % of its contrast plus twice the noise: shading,
        texture).
    """
    sel = work.sel.view(bool)
    readable = np.abs(work.den) > np.float32(READABLE) * work.t
    c = np.zeros_like(work.d)
    np.divide(work.d, work.den, out=c, where=readable)
    filled = fill_holes(work.sel)
    core = (sel & (c >= 0.8)).view(np.uint8)
    n_core = int(np.count_nonzero(core))
    if n_core == 0:
        return 0, 0, 0.0
    # how solid the core is: its share of the region it closes (a ball of one grey
    # level: all of it; a textured object's scattered bright patches: little)
    closed = cv2.morphologyEx(core, cv2.MORPH_CLOSE, _K5).view(bool)
    closed = fill_holes(closed.view(np.uint8)) & filled
    region = int(np.count_nonzero(closed))
    uniform = float(np.count_nonzero(core.view(bool) & closed)) / region if region else 0.0
    # and of one grey level: the core's pixels agree (their spread a small part of the
    # contrast; a white cup's shading or a toy's fur do not)
    vals = work.f[core.view(bool)]
    contrast = float(np.median(np.abs(work.d[core.view(bool)])))
    if vals.size >= 5 and contrast > 0:
        q25, q75 = np.percentile(vals, [25, 75])
        if (q75 - q25) > 0.15 * contrast + 2.0 * float(np.median(work.t)) / 5.0:
            uniform = 0.0
    if reach_px is None:
        return n_core, 0, uniform
    r = max(1, int(math.ceil(reach_px)))
    disk = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    foot = cv2.dilate(core, disk)
    au, av = along
    length = float(np.hypot(au, av))
    if length >= 1.0:
        # the smear along the motion, as the core shows it: motion blur shortens the
        # fully covered core along the motion by its length, and spreads half of it
        # beyond each end (a round object's core is as long as it is wide unblurred)
        m = cv2.moments(core, True)
        if m["m00"] > 0:
            ux, uy = au / length, av / length
            mu20, mu02, mu11 = m["mu20"] / m["m00"], m["mu02"] / m["m00"], m["mu11"] / m["m00"]
            var_along = ux * ux * mu20 + 2 * ux * uy * mu11 + uy * uy * mu02
            var_perp = uy * uy * mu20 - 2 * ux * uy * mu11 + ux * ux * mu02
            blur = max(0.0, np.sqrt(12.0 * max(var_perp, 0.0))
                       - np.sqrt(12.0 * max(var_along, 0.0)))
            blur = min(blur, length, 10.0)
            au, av, length = 0.5 * blur * ux, 0.5 * blur * uy, 0.5 * blur
    if length >= 1.0:
        k = int(math.ceil(length))
        line = np.zeros((2 * k + 1, 2 * k + 1), np.uint8)
        cv2.line(line, (k - int(round(au)), k - int(round(av))),
                 (k + int(round(au)), k + int(round(av))), 1, 1)
        foot = cv2.dilate(foot, line)
    drop = filled & ~foot.view(bool)
    n_drop = int(np.count_nonzero(drop & sel))
    if n_drop:
        work.sel = (sel & ~drop).view(np.uint8)
        work.trimmed = drop
    return n_core, n_drop, uniform


def measure_solid(work, blob):
    """Centroid etc. of an object of one grey level, its edge read against its
    surroundings (in place; ``work.den`` from its level).

    Its fully covered core (c >= 0.8) and enclosed holes cover fully. A pixel of the
    ring round the core (2 px) is partly covered, ``c = (f - b') / (s - b')``, clipped to
    [0, 1], where ``b'`` is the pixel's static background plus how much the surroundings
    (2 to 5 px beyond the core) differ from theirs: a shadow falling beside the object
    darkens what shows between its edge and the shadow, which read against the static
    background would look like more of the object.
    """
    sel = work.sel.view(bool)
    readable = np.abs(work.den) > np.float32(READABLE) * work.t
    c = np.zeros_like(work.d)
    np.divide(work.d, work.den, out=c, where=readable)
    core = (sel & (c >= 0.8)).view(np.uint8)
    if not core.any():
        return measure_silhouette(work, blob)
    ring_k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5))
    far_k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (11, 11))
    offset = np.zeros_like(work.d)
    for _ in range(2):
        # the core, then the surroundings' offset, then the core read against them
        core_b = fill_holes(core) & ~work.others
        near = cv2.dilate(core_b.view(np.uint8), ring_k).view(bool)
        far = cv2.dilate(core_b.view(np.uint8), far_k).view(bool)
        band = (far & ~near & ~work.others).astype(np.float32)
        num = cv2.blur(work.d * band, (9, 9), borderType=cv2.BORDER_REPLICATE)
        cnt = cv2.blur(band, (9, 9), borderType=cv2.BORDER_REPLICATE)
        offset = np.where(cnt > 0.05, num / np.maximum(cnt, 1e-6), np.float32(0.0))
        d2 = work.d - offset
        den2 = work.den - offset
        c2 = np.zeros_like(work.d)
        np.divide(d2, den2, out=c2, where=np.abs(den2) > np.float32(READABLE) * work.t)
        core2 = (sel & (c2 >= 0.8)).view(np.uint8)
        if not core2.any():
            break
        core = core2
    core_b = fill_holes(core) & ~work.others
    near = cv2.dilate(core_b.view(np.uint8), ring_k).view(bool)
    ring = near & ~core_b & ~work.others & (sel | cv2.dilate(work.sel, _K3).view(bool))
    d2 = work.d - offset
    den2 = work.den - offset
    ok = ring & (np.abs(den2) > np.float32(READABLE) * work.t)
    cov = np.zeros_like(work.d)
    cov[ok] = np.clip(d2[ok] / den2[ok], 0.0, 1.0)
    cov[core_b] = 1.0
    return _from_moments(blob, cov, work.origin)


def _from_moments(blob, c, origin):
    """``blob`` (in place) with the centroid, area, length, width and angle of the
    coverage image ``c`` whose top-left pixel is ``origin``; area 0 when it is empty."""
    m = cv2.moments(c, False)
    m00 = m["m00"]
    if not m00 > 0:
        blob.area = 0.0
        return blob
    x0, y0 = origin
    blob.u = x0 + m["m10"] / m00
    blob.v = y0 + m["m01"] / m00
    blob.area = float(m00)
    a, bb, cc = m["mu20"] / m00, m["mu11"] / m00, m["mu02"] / m00
    half = 0.5 * (a + cc)
    rad = np.hypot(0.5 * (a - cc), bb)
    blob.length = float(np.sqrt(12.0 * max(half + rad, 0.0)))
    blob.width = float(np.sqrt(12.0 * max(half - rad, 0.0)))
    ang = 0.5 * np.arctan2(2.0 * bb, a - cc)
    if ang <= -np.pi / 2:
        ang += np.pi
    blob.angle = float(ang)
    return blob


def measure_silhouette(work, blob):
    """Centroid, area, orientation and size of an object of any grey levels (in place).

    For an object that is brighter than the background in some parts and darker in
    others (a dark ball with a highlight, a white cup with a dark opening), or that is
    textured, no single grey level gives the coverage. Its silhouette does: the detected
    pixels (either polarity) with their holes filled (where the object's own grey level
    happens to equal the background's) cover fully; round the edge, a pixel's coverage
    is its ``|f - b|`` against the largest ``|f - b|`` of the object's interior within
    2 px (an edge pixel half covered by the object shows half of the nearby interior's
    contrast), clipped to [0, 1]. Then moments as in :func:`measure`.
    """
    sel = work.sel
    if not sel.any():
        blob.area = 0.0
        return blob
    filled = fill_holes(sel)
    fu8 = filled.view(np.uint8)
    inner = cv2.erode(fu8, _K3).view(bool)
    ad = np.abs(work.d)
    ref = cv2.dilate(np.where(inner, ad, np.float32(0.0)), _K5)
    ref = np.maximum(ref, work.t)
    edge = (cv2.dilate(fu8, _K3).view(bool) & ~inner) & ~work.others
    if work.trimmed is not None:
        edge &= ~work.trimmed
    c = np.zeros_like(ad)
    c[edge] = np.minimum(ad[edge] / ref[edge], 1.0)
    c[inner] = 1.0
    return _from_moments(blob, c, work.origin)


def measure_mixed(work, blob, *, rod=None, separate=True):
    """Centroid etc. of an object of both polarities (in place): a rod (a dark straw
    with a highlight along it) by its body, anything else by :func:`measure_silhouette`.
    ``rod``: whether it is one (as its clean frames were: a straw seen end on still is);
    None: when this frame's body is 3 times as long as wide. A rod's body is taken
    within its core's band (:func:`_core_band`): a fainter rod riding along it or
    across it, closed into its body, is left out. ``separate`` False: the rod is
    measured whole, its band's measurement kept in ``blob.separated`` (the blobs a
    straw is chosen among are measured whole: cutting what its blade holds in some
    frames and not in others would break its path).

    The body is what differs from the background by at least 0.15 of the object's
    contrast (the 90th percentile of ``|f - b|``; what the closing adds and
    compression's ringing round a sharp edge stay below), closed, holes filled, and its
    convex hull taken (a highlight reaching the edge leaves a notch). The body's
    interior covers fully. An edge pixel (the body's outer pixel and the one beyond)
    that shows at least a quarter of the contrast is read against the level of its own
    polarity within 2 px (a shaded rod is not of one level end to end); a fainter one
    is read signed against the polarity round it, so that noise and ringing average
    out instead of adding up. Where the highlight's blur
    cancels part of the edge the coverage reads low: the centre along the axis is then
    taken halfway between the ends (:func:`_rod_ends_centre`). A rod's ``off_axis`` is
    that of its detections about the body's axis (:func:`_detections_off_axis`).
    """
    sel = work.sel.view(bool)
    if not sel.any():
        blob.area = 0.0
        return blob
    d = work.d
    ad = np.abs(d)
    top = np.float32(np.percentile(ad[sel], 90))
    strong = sel & (ad >= 0.25 * top)
    faint = (sel & (ad > 0.3 * top)).view(np.uint8)
    body = fill_holes(cv2.morphologyEx(faint, cv2.MORPH_CLOSE, _K3))
    body &= ~work.others
    if not body.any():
        return measure_silhouette(work, blob)
    band = _core_band(d, sel, strong) if rod is not False else None
    if rod is None:
        # (a rod with a fainter rod across it, closed into its body, is a rod: its body
        # within its core's band is judged)
        probe = _from_moments(copy.copy(blob), (body if band is None else body & band)
                              .astype(np.float32), (0, 0))
        rod = probe.area > 0 and probe.length >= 3.0 * max(probe.width, 1.0)
    if not rod:
        return measure_silhouette(work, blob)
    if band is not None and not separate:
        sep = _rod_body(work, copy.copy(blob), d, ad, top, sel, strong, body, band)
        if sep.area > 0:
            blob.separated = (sep.u, sep.v, sep.area, sep.angle, sep.length, sep.width,
                              sep.off_axis)
        band = None
    return _rod_body(work, blob, d, ad, top, sel, strong, body, band)


def _rod_body(work, blob, d, ad, top, sel, strong, body, band):
    """:func:`measure_mixed` of a rod (in place), from its detections ``sel``, their
    changes ``d`` and ``ad = |d|`` (``top``: its 90th percentile), the strong ones and
    the closed body; within ``band`` when given (:func:`_core_band`)."""
    zero = np.float32(0.0)
    blob.banded = band is not None
    if band is not None:
        # a fainter rod riding along it or across it, closed into its body: the rod is
        # its core's band
        body = body & band
        sel = sel & band
        strong = strong & band
    # (its largest piece: a speck of compression's ringing beside it would stretch the
    # hull over the background)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(body.view(np.uint8), connectivity=8)
    if n > 2:
        body = labels == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    pts = cv2.findNonZero(body.view(np.uint8))
    hull = np.zeros(body.shape, np.uint8)
    cv2.fillConvexPoly(hull, cv2.convexHull(pts), 1)
    body = hull.view(bool) & ~work.others
    bu8 = body.view(np.uint8)
    inner = cv2.erode(bu8, _K3).view(bool)
    edge = cv2.dilate(bu8, _K3).view(bool) & ~inner & ~work.others
    if work.trimmed is not None:
        edge &= ~work.trimmed
    if band is not None:
        edge &= band
    # the polarity round each pixel (of the body's strong pixels within 2 px)
    sgn = np.where(strong & body, np.sign(d), zero).astype(np.float32)
    near = cv2.blur(sgn, (5, 5), borderType=cv2.BORDER_CONSTANT)
    side = np.where(strong, np.sign(d), np.sign(near)).astype(np.float32)
    side[side == 0] = np.sign(d[side == 0])
    ref = np.zeros_like(d)
    for pol in (1.0, -1.0):
        mine = strong & body & (d * pol > 0)
        if not mine.any():
            continue
        level = _top_third_median((d * pol)[mine])
        loc = cv2.dilate(np.where(mine, d * pol, zero), _K5)
        loc = np.where(loc >= 0.5 * level, loc, np.float32(level))
        ref = np.where(side == pol, loc, ref)
    ref = np.where(ref > 0, ref, top)
    c = np.zeros_like(d)
    c[edge] = np.clip(side[edge] * d[edge] / ref[edge], -1.0, 1.0)
    c[inner] = 1.0
    _from_moments(blob, c, work.origin)
    if blob.area > 0:
        _rod_ends_centre(blob, c, work.origin)
        blob.off_axis = _detections_off_axis(work, blob, ad, top, sel=sel)
    return blob


def _core_band(d, sel, strong):
    """The band of a rod of both polarities round its core, or None when nothing of its
    detections lies beyond it.

    The core is where the rod's main polarity (of more of its strong pixels) shows at
    least :data:`CORE` of its level (the median of the strongest third): a dark straw's
    edges either side of its highlight reach it end to end, a fainter rod riding along
    it or across it does not. The band runs along the core's axis, from the core's
    farthest pixel on one side to its farthest on the other, plus :data:`CORE_EDGE_PX`
    (the blurred edge beyond the fully covered pixels) each side. None also when the
    core is under 6 pixels or not 3 times as long as wide (seen end on: no axis).
    """
    counts = [np.count_nonzero(strong & (d * pol > 0)) for pol in (1.0, -1.0)]
    pol = 1.0 if counts[0] >= counts[1] else -1.0
    vals = (d * pol)[strong & (d * pol > 0)]
    if vals.size < 6:
        return None
    core = sel & (d * pol >= CORE * _top_third_median(vals))
    if np.count_nonzero(core) < 6:
        return None
    cu, cv_, ca, sa, lam1, lam2 = _axis(core.astype(np.float32))
    if lam1 < 9.0 * max(lam2, 1.0 / 12.0):
        return None
    yy, xx = np.indices(sel.shape, dtype=np.float32)
    perp = -(xx - cu) * sa + (yy - cv_) * ca
    band = (perp >= float(perp[core].min()) - CORE_EDGE_PX) & \
        (perp <= float(perp[core].max()) + CORE_EDGE_PX)
    if np.count_nonzero(sel & ~band) < 3:
        return None
    return band


def _rod_ends_centre(blob, c, origin):
    """Move a rod's centroid along its axis to halfway between its ends (in place).

    A rod is uniform along its length: its coverage per unit length there is its width.
    Where a highlight's blur cancels part of its edge the coverage there reads low and
    pulls the moments' centroid towards the other end. Along the axis the coverage is
    binned (1 px); bins more than 1.5 widths from both ends are given the median of
    those bins, the ends keep what they read.
    """
    x0, y0 = origin
    cx, cy = blob.u - x0, blob.v - y0
    ca, sa = np.cos(blob.angle), np.sin(blob.angle)
    ys, xs = np.nonzero(c)
    w = c[ys, xs].astype(np.float64)
    s = (xs - cx) * ca + (ys - cy) * sa
    lit = w > 0.05
    if np.count_nonzero(lit) < 6:
        return
    lo, hi = float(s[lit].min()), float(s[lit].max())
    k = np.floor(s - lo + 0.5).astype(int)
    keep = (k >= 0) & (k <= int(round(hi - lo)))
    prof = np.bincount(k[keep], weights=w[keep], minlength=int(round(hi - lo)) + 1)
    centres = lo + np.arange(prof.size)
    margin = 1.5 * max(blob.width, 1.0)
    mid = (centres > lo + margin) & (centres < hi - margin)
    if np.count_nonzero(mid) < 3:
        return
    prof = prof.copy()
    prof[mid] = float(np.median(prof[mid]))
    tot = float(prof.sum())
    if not tot > 0:
        return
    shift = float((prof * centres).sum() / tot)
    blob.u += shift * ca
    blob.v += shift * sa


def work_margin(width, length, bbox):
    """Margin (px) around the straw's components that the measurement may need."""
    w = width if width and np.isfinite(width) else 1.0
    extra = 0.0
    if length and np.isfinite(length):
        extra = max(0.0, length - max(bbox[2] - bbox[0], bbox[3] - bbox[1]))
    return max(3.0 + extra, 2 * math.ceil(max(w, 1.0)) + 4)
