"""The rasteriser of ``vidtrack synth``: exact pixel coverage of simple shapes, textures,
compositing and sensor noise.

Pixel convention (the one every vidtrack track uses): ``u`` is the column, ``v`` the
row, and the centre of pixel ``(row r, column c)`` is at ``(u, v) = (c, r)``; that pixel
covers ``[c - 0.5, c + 0.5] x [r - 0.5, r + 0.5]``. The image spans
``[-0.5, W - 0.5] x [-0.5, H - 0.5]``.

Shapes are *capsules* (the set of points within ``radius`` of a segment: a rod with
rounded ends, a disk when the segment has zero length) and axis-aligned boxes. A box's
coverage is exact (products of interval overlaps). A capsule's coverage is exact for
pixels entirely inside or outside it and for pixels crossed only by its straight sides
(the area of the pixel inside a strip, in closed form); for pixels near its rounded
ends it is the fraction of an ``s x s`` grid of sub-pixel points (centred in their
cells) that lie inside (16 x 16 by default: steps of 1/256, an error of at most a few
hundredths of a pixel's area, with no bias in position because the grid is symmetric
about the pixel centre).

Intensities are floats in [0, 1] (fraction of full scale) until :func:`quantize`.
"""

import functools
from dataclasses import dataclass

import numpy as np

__all__ = ["Capsule", "Box", "Roi", "capsule_coverage", "box_coverage", "shape_roi",
           "smooth_texture", "composite_box", "add_sensor_noise", "quantize"]

#: Half the diagonal of a pixel: a pixel whose centre is farther than this from an edge
#: lies wholly on one side of it.
_HALF_DIAGONAL = 0.5 * np.sqrt(2.0) + 1e-9


@dataclass(frozen=True)
class Roi:
    """A rectangle of pixels: rows ``r0 .. r1 - 1``, columns ``c0 .. c1 - 1``."""

    r0: int
    r1: int
    c0: int
    c1: int

    @property
    def empty(self):
        return self.r1 <= self.r0 or self.c1 <= self.c0

    @property
    def shape(self):
        return (max(self.r1 - self.r0, 0), max(self.c1 - self.c0, 0))

    def clip(self, shape):
        """This ROI cut to an image of ``shape`` (rows, cols)."""
        return Roi(max(self.r0, 0), min(self.r1, shape[0]), max(self.c0, 0),
                   min(self.c1, shape[1]))

    def union(self, other):
        return Roi(min(self.r0, other.r0), max(self.r1, other.r1), min(self.c0, other.c0),
                   max(self.c1, other.c1))

    def intersects(self, other):
        return (self.r0 < other.r1 and other.r0 < self.r1 and self.c0 < other.c1
                and other.c0 < self.c1)

    def slice_in(self, outer):
        """Index slices of this ROI inside the array of ``outer`` (which contains it)."""
        return (slice(self.r0 - outer.r0, self.r1 - outer.r0),
                slice(self.c0 - outer.c0, self.c1 - outer.c0))

    @property
    def slices(self):
        return (slice(self.r0, self.r1), slice(self.c0, self.c1))


@dataclass(frozen=True)
class Capsule:
    """Points within ``radius_px`` of the segment ``a_px`` - ``b_px`` (pixels, (u, v))."""

    a_px: tuple
    b_px: tuple
    radius_px: float

    @property
    def centre_px(self):
        return (0.5 * (self.a_px[0] + self.b_px[0]), 0.5 * (self.a_px[1] + self.b_px[1]))

    @property
    def area_px(self):
        """Exact area in px^2: pi r^2 + 2 r |ab|."""
        seg = np.hypot(self.b_px[0] - self.a_px[0], self.b_px[1] - self.a_px[1])
        return float(np.pi * self.radius_px ** 2 + 2.0 * self.radius_px * seg)

    def extent_px(self):
        """``(u_min, u_max, v_min, v_max)`` of the shape."""
        r = self.radius_px
        us, vs = (self.a_px[0], self.b_px[0]), (self.a_px[1], self.b_px[1])
        return (min(us) - r, max(us) + r, min(vs) - r, max(vs) + r)


@dataclass(frozen=True)
class Box:
    """The axis-aligned rectangle ``[u0, u1] x [v0, v1]`` in pixels."""

    u0: float
    u1: float
    v0: float
    v1: float

    def extent_px(self):
        return (min(self.u0, self.u1), max(self.u0, self.u1), min(self.v0, self.v1),
                max(self.v0, self.v1))


def shape_roi(extent):
    """The pixels a shape with extent ``(u_min, u_max, v_min, v_max)`` can touch."""
    u_min, u_max, v_min, v_max = extent
    return Roi(int(np.floor(v_min + 0.5)), int(np.floor(v_max + 0.5)) + 1,
               int(np.floor(u_min + 0.5)), int(np.floor(u_max + 0.5)) + 1)


def _segment_offset(pu, pv, a, b):
    """``(qu, qv)``: points (pu, pv) less their closest points on the segment a-b."""
    du, dv = b[0] - a[0], b[1] - a[1]
    length2 = du * du + dv * dv
    qu, qv = pu - a[0], pv - a[1]
    if length2 > 0.0:
        s = np.minimum(np.maximum((qu * du + qv * dv) / length2, 0.0), 1.0)
        qu = qu - s * du
        qv = qv - s * dv
    return qu, qv


#: Relative margin beyond which ``hypot(qu, qv)`` and ``sqrt(qu^2 + qv^2)`` (a few ulps
#: apart) are on the same side of a threshold.
_ROUNDING = 1e-9


def _segment_distance(pu, pv, a, b, near=()):
    """Distance of points (pu, pv) to the segment a-b (arrays broadcast), on the same side
    of each threshold in ``near`` as ``np.hypot`` puts it.

    ``np.hypot`` costs ten times a multiplication: the distance is ``sqrt(qu^2 + qv^2)``,
    and ``hypot``'s only where that lies within :data:`_ROUNDING` of a threshold, where the
    two may round to either side of it.
    """
    qu, qv = _segment_offset(pu, pv, a, b)
    d = np.sqrt(qu * qu + qv * qv)
    unsure = None
    for t in near:
        hit = np.abs(d - t) <= _ROUNDING * (abs(t) + 1.0)
        unsure = hit if unsure is None else unsure | hit
    if unsure is not None and unsure.any():
        qu, qv = np.broadcast_arrays(qu, qv)
        d[unsure] = np.hypot(qu[unsure], qv[unsure])
    return d


def _inside(pu, pv, a, b, r):
    """The points (pu, pv) within ``r`` of the segment a-b: ``np.hypot``'s verdict."""
    return _segment_distance(pu, pv, a, b, near=(r,)) <= r


@functools.lru_cache(maxsize=8)
def _grid(s):
    """Offsets (1, s*s) of an s x s grid of points centred in their cells of a pixel."""
    offs = (np.arange(s) + 0.5) / s - 0.5
    ou, ov = np.meshgrid(offs, offs)
    ou, ov = ou.ravel()[None, :], ov.ravel()[None, :]
    ou.flags.writeable = False
    ov.flags.writeable = False
    return ou, ov


def _line_spans(v, a, b, r, gap):
    """The ``u`` interval inside the capsule on each horizontal line ``v`` (an array).

    The capsule is convex, so its section by a line is one interval: the union of the
    line's sections by the disc at ``a``, the disc at ``b`` and, for a segment of non-zero
    length, the strip ``0 <= t <= 1`` (``t`` the projection on the segment), ``|d| <= r``
    (``d`` the distance from the axis), two linear inequalities in ``u``.

    Returns
    -------
    lo, hi : numpy.ndarray
        The ends of each line's interval. A line that misses the capsule has ``hi < lo``
        with ``lo`` the ``u`` where it comes closest to the capsule (that of the end,
        ``a`` or ``b``, nearest to it in ``v``) and ``hi = lo - gap``.
    """
    ax, ay = a
    bx, by = b
    if ax == bx and ay == by:                       # a disc
        w = v - ay
        h2 = r * r - w * w
        h2[h2 < 0.0] = np.nan
        h = np.sqrt(h2)
        lo, hi = ax - h, ax + h
        empty = np.isnan(lo)
        if empty.any():
            np.copyto(lo, ax, where=empty)
            np.copyto(hi, ax - gap, where=empty)
        return lo, hi
    w = v - np.array([[ay], [by]])
    h2 = r * r - w * w
    h2[h2 < 0.0] = np.nan                           # a NaN end is an empty piece
    h = np.sqrt(h2)
    lo = np.fmin(ax - h[0], bx - h[1])              # fmin and fmax skip NaN
    hi = np.fmax(ax + h[0], bx + h[1])
    # the strip, x = u - ax, w = v - ay: 0 <= x du + w dv <= |ab|^2 (the projection) and
    # -r |ab| <= x dv - w du <= r |ab| (the distance from the axis)
    du, dv = bx - ax, by - ay
    length2 = du * du + dv * dv
    reach = r * np.sqrt(length2)
    w = w[0]
    if du != 0.0:
        lo_1 = w * (-dv / du) + ax
        hi_1 = lo_1 + length2 / du
        if du < 0.0:
            lo_1, hi_1 = hi_1, lo_1
    else:                                           # a vertical segment: all u, or none
        lo_1 = np.where((w * dv >= 0.0) & (w * dv <= length2), -np.inf, np.nan)
        hi_1 = -lo_1
    if dv != 0.0:
        mid = w * (du / dv) + ax
        lo_2, hi_2 = mid - reach / abs(dv), mid + reach / abs(dv)
    else:                                           # a horizontal segment: all u, or none
        lo_2 = np.where(np.abs(w * du) <= reach, -np.inf, np.nan)
        hi_2 = -lo_2
    lo_s, hi_s = np.maximum(lo_1, lo_2), np.minimum(hi_1, hi_2)    # NaN: no u
    ok = lo_s <= hi_s
    np.fmin(lo, lo_s, out=lo, where=ok)
    np.fmax(hi, hi_s, out=hi, where=ok)
    empty = np.isnan(lo)
    if empty.any():             # above or below the segment: the nearer end is the closer
        near = np.where(v < 0.5 * (ay + by), ax if ay <= by else bx, bx if ay <= by else ax)
        np.copyto(lo, near, where=empty)
        np.copyto(hi, near - gap, where=empty)
    return lo, hi


#: Fewer sampled pixels than this: each grid point is tested; more, the grid is counted
#: a sub-row at a time, whose fixed cost in numpy calls then pays (on the calls of
#: ``vidtrack synth --person-at-side``, thresholds from 8 to 40 took the same time
#: within 5 %, one point by point throughout twice as long).
_COUNT_BY_LINES_FROM = 24


def _sampled_coverage(capsule, roi, sr, sc, s):
    """Coverage of the pixels ``(sr, sc)`` (indices in ``roi``, row-major order) on the
    ``s x s`` grid of :func:`_grid`.

    The same value as the share of a pixel's grid points whose :func:`_segment_distance`
    is ``<= r``: tested point by point for a few pixels or an ``s`` that is not a power of
    two, counted one sub-row at a time otherwise (see the Notes of
    :func:`capsule_coverage`).
    """
    r = float(capsule.radius_px)
    a, b = capsule.a_px, capsule.b_px
    if sr.size < _COUNT_BY_LINES_FROM or s & (s - 1):
        return _points_coverage(capsule, roi, sr, sc, s)
    # the rows holding sampled pixels (sr is sorted), each pixel's among them (row)
    new_row = np.empty(sr.size, dtype=bool)
    new_row[0] = True
    np.not_equal(sr[1:], sr[:-1], out=new_row[1:])
    row = np.cumsum(new_row) - 1
    offs = _grid(s)[0][0, :s]                       # the s sub-pixel offsets, in order
    # line k of row i is line_v[i * s + k]: exactly the v of the grid points on it
    line_v = ((sr[new_row] + roi.r0)[:, None] + offs).ravel()
    n_rows = line_v.size // s
    lo, hi = _line_spans(line_v, a, b, r, 0.5 / s)
    # the grid points (column + offs[j]) along a line, numbered g = column * s + j from
    # the roi's first column, are at u = u0 + g / s (exactly: s is a power of two)
    u0 = roi.c0 - 0.5 + 0.5 / s
    first = np.ceil((lo - u0) * s)
    last = np.floor((hi - u0) * s)
    n_grid = (roi.c1 - roi.c0) * s
    np.minimum(np.maximum(first, 0.0, out=first), n_grid, out=first)
    np.minimum(np.maximum(last, -1.0, out=last), n_grid - 1.0, out=last)
    # the float test itself on the points either side of each end: with the points of a
    # line inside the capsule contiguous, agreeing there is agreeing everywhere
    probe = np.empty((4, first.size))
    np.subtract(first, 1.0, out=probe[0])
    probe[1] = first
    probe[2] = last
    np.add(last, 1.0, out=probe[3])
    np.minimum(np.maximum(probe, 0.0, out=probe), n_grid - 1.0, out=probe)
    expect = (probe >= first) & (probe <= last)
    wrong = _inside(probe / s + u0, line_v, a, b, r) != expect
    # grid points of pixel column c on a line: g in [c s, c s + s - 1]
    start = (sc * s)[:, None]
    counts = (np.minimum(last.reshape(n_rows, s)[row] + 1.0 - start, s)
              - np.maximum(first.reshape(n_rows, s)[row] - start, 0.0))
    cov = np.maximum(counts, 0.0).sum(axis=1) / (s * s)
    if wrong.any():                                 # a point within rounding of an end
        redo = wrong.any(axis=0).reshape(n_rows, s).any(axis=1)[row]
        cov[redo] = _points_coverage(capsule, roi, sr[redo], sc[redo], s)
    return cov


def _points_coverage(capsule, roi, sr, sc, s):
    """Share of the ``s x s`` grid points of each pixel ``(sr, sc)`` inside the capsule,
    tested one by one."""
    ou, ov = _grid(s)
    qu = (sc + roi.c0)[:, None] + ou
    qv = (sr + roi.r0)[:, None] + ov
    return _inside(qu, qv, capsule.a_px, capsule.b_px, float(capsule.radius_px)).mean(axis=1)


def _square_below(delta, a, b):
    """Exact area of the unit pixel on the side ``n . q <= delta`` of a line.

    ``q`` is measured from the pixel centre, ``n = (cos t, sin t)`` a unit normal with
    ``a = max(|cos t|, |sin t|)`` and ``b = min(...)``. The distribution of ``n . q``
    over the pixel is the convolution of two uniform laws of widths ``a`` and ``b``
    (a trapezoid); this is its cumulative distribution function.
    """
    u = np.clip(delta + 0.5 * (a + b), 0.0, a + b)
    if b <= 1e-12:
        return np.clip(u / a, 0.0, 1.0)
    low = u * u / (2.0 * a * b)
    mid = (u - 0.5 * b) / a
    high = 1.0 - (a + b - u) ** 2 / (2.0 * a * b)
    return np.where(u <= b, low, np.where(u <= a, mid, high))


def capsule_coverage(capsule, roi, *, supersample=16):
    """Fraction of each pixel of ``roi`` covered by ``capsule``.

    Parameters
    ----------
    capsule : Capsule
        The shape, in pixel coordinates.
    roi : Roi
        The pixels to evaluate.
    supersample : int, keyword-only
        Sub-pixel grid ``s x s`` used where a rounded end crosses a pixel.

    Returns
    -------
    numpy.ndarray, shape ``roi.shape``, float64
        Coverage in [0, 1].

    Notes
    -----
    Pixels wholly inside or outside are 1 or 0. A pixel crossed only by the straight
    sides (all of it projects onto the segment) is the exact area of the pixel inside
    the strip of half-width r: ``A(r - d) + A(r + d) - 1`` with ``A`` the area of the
    pixel below a line (:func:`_square_below`) and ``d`` the signed distance of its
    centre from the axis. Pixels near the rounded ends are sampled on an ``s x s``
    grid centred in its cells (resolution 1/s^2, symmetric about the pixel centre): the
    share of its points whose distance to the segment (:func:`_segment_distance`) is
    ``<= r``.

    That share is counted one sub-row of points at a time rather than point by point
    (:func:`_sampled_coverage`): the capsule is convex, so a horizontal line meets it
    in one interval ``[lo, hi]``, the union of its sections by the two end discs and by
    the strip between them (:func:`_line_spans`), and the points ``column + offset`` of
    the line in it follow from ``ceil`` and ``floor``: ``s`` evaluations a pixel instead
    of ``s^2``. So that the count is the point-by-point one to the bit, and not only
    mathematically, the distance test itself is made on the two points either side of
    each end of every line; a line where it disagrees (a point within rounding of the
    boundary) has its pixels tested point by point, as are the pixels of a capsule with
    few of them (:data:`_COUNT_BY_LINES_FROM`) or an ``s`` that is not a power of two.
    """
    out = np.zeros(roi.shape, dtype=np.float64)
    if roi.empty:
        return out
    rows = np.arange(roi.r0, roi.r1, dtype=np.float64)[:, None]
    cols = np.arange(roi.c0, roi.c1, dtype=np.float64)[None, :]
    r = float(capsule.radius_px)
    ax, ay = capsule.a_px
    d = _segment_distance(cols, rows, capsule.a_px, capsule.b_px,
                          near=(r - _HALF_DIAGONAL, r + _HALF_DIAGONAL))
    out[d <= r - _HALF_DIAGONAL] = 1.0
    edge = np.abs(d - r) < _HALF_DIAGONAL
    if not np.any(edge):
        return out
    er, ec = np.nonzero(edge)
    pu, pv = ec + roi.c0 - ax, er + roi.r0 - ay
    du, dv = capsule.b_px[0] - ax, capsule.b_px[1] - ay
    length = float(np.hypot(du, dv))
    sampled = np.ones(er.size, dtype=bool)
    if length > 0.0:
        tu, tv = du / length, dv / length
        along = pu * tu + pv * tv
        half = 0.5 * (abs(tu) + abs(tv))          # the pixel's half-extent along the axis
        side = (along >= half) & (along <= length - half)
        if np.any(side):
            across = pu[side] * (-tv) + pv[side] * tu
            a, b = max(abs(tu), abs(tv)), min(abs(tu), abs(tv))
            cov = (_square_below(r - across, a, b) + _square_below(r + across, a, b) - 1.0)
            out[er[side], ec[side]] = np.clip(cov, 0.0, 1.0)
            sampled = ~side
    if np.any(sampled):
        sr, sc = er[sampled], ec[sampled]
        out[sr, sc] = _sampled_coverage(capsule, roi, sr, sc, int(supersample))
    return out


def _interval_overlap(lo, hi, centres):
    return np.clip(np.minimum(hi, centres + 0.5) - np.maximum(lo, centres - 0.5), 0.0, 1.0)


def box_coverage(box, roi):
    """Exact fraction of each pixel of ``roi`` covered by the axis-aligned ``box``."""
    u0, u1, v0, v1 = box.extent_px()
    rows = np.arange(roi.r0, roi.r1, dtype=np.float64)
    cols = np.arange(roi.c0, roi.c1, dtype=np.float64)
    return np.outer(_interval_overlap(v0, v1, rows), _interval_overlap(u0, u1, cols))


def coverage(shape, roi, *, supersample=16):
    """Coverage of a :class:`Capsule` or :class:`Box` over ``roi``."""
    if isinstance(shape, Box):
        return box_coverage(shape, roi)
    return capsule_coverage(shape, roi, supersample=supersample)


def smooth_texture(shape, rng, *, scales_px=(40.0, 9.0), weights=(1.0, 0.45)):
    """A smooth random texture with zero mean and unit standard deviation.

    Parameters
    ----------
    shape : (int, int)
        Rows and columns.
    rng : numpy.random.Generator
    scales_px : tuple of float, keyword-only
        Gaussian smoothing lengths (standard deviations, px) of the summed components.
    weights : tuple of float, keyword-only
        Relative amplitude of each component.

    Returns
    -------
    numpy.ndarray, float64
    """
    import cv2

    total = np.zeros(shape, dtype=np.float64)
    for scale, weight in zip(scales_px, weights):
        field = rng.standard_normal(shape)
        field = cv2.GaussianBlur(field, (0, 0), sigmaX=float(scale), sigmaY=float(scale),
                                 borderType=cv2.BORDER_REFLECT)
        sd = field.std()
        if sd > 0:
            total += weight * (field - field.mean()) / sd
    sd = total.std()
    return (total - total.mean()) / sd if sd > 0 else total


def composite_box(base, layers, roi, *, supersample=16, cache=None):
    """Paint opaque ``layers`` over ``base`` (the pixels of ``roi``), in order.

    Parameters
    ----------
    base : numpy.ndarray
        The pixels of ``roi`` before painting (not modified).
    layers : sequence of (key, shape, grey)
        ``shape`` a Capsule or Box in pixels, ``grey`` its intensity in [0, 1], or a
        function of the sub-ROI the shape covers returning its grey levels there (a
        textured fill). A ``shape`` of None is skipped.
    roi : Roi
    supersample : int, keyword-only
    cache : dict, keyword-only
        Coverage arrays of earlier calls by (shape, sub-ROI): a shape that does not
        move is computed once.

    Returns
    -------
    image : numpy.ndarray
        The painted pixels.
    covers : dict
        key -> (sub-ROI, coverage array) for every painted layer.
    """
    image = base.copy()
    covers = {}
    for key, shape, grey in layers:
        if shape is None:
            continue
        s = shape_roi(shape.extent_px())
        sub = Roi(max(s.r0, roi.r0), min(s.r1, roi.r1), max(s.c0, roi.c0), min(s.c1, roi.c1))
        if sub.empty:
            continue
        key_c = (shape, sub)
        cov = None if cache is None else cache.get(key_c)
        if cov is None:
            cov = coverage(shape, sub, supersample=supersample)
            if cache is not None:
                if len(cache) > 256:
                    cache.clear()
                cache[key_c] = cov
        sl = sub.slice_in(roi)
        if callable(grey):                 # a textured fill: its grey levels over sub
            grey = grey(sub)
        image[sl] += (grey - image[sl]) * cov
        covers[key] = (sub, cov)
    return image, covers


def add_sensor_noise(image, rng, *, read_noise, full_well_e=None):
    """Shot noise (Poisson, when ``full_well_e`` is given) and Gaussian read noise.

    Parameters
    ----------
    image : numpy.ndarray
        Intensities in [0, 1] (fraction of full scale).
    rng : numpy.random.Generator
    read_noise : float, keyword-only
        Standard deviation of the read noise, as a fraction of full scale.
    full_well_e : float or None, keyword-only
        Electrons at full scale; the signal ``I * full_well_e`` is drawn from a Poisson
        law. None: no shot noise.

    Returns
    -------
    numpy.ndarray, float64
    """
    out = np.asarray(image, dtype=np.float64)
    if full_well_e is not None:
        out = rng.poisson(np.clip(out, 0.0, None) * full_well_e) / float(full_well_e)
    if read_noise > 0:
        out = out + rng.normal(0.0, read_noise, size=out.shape)
    return out


def quantize(image, bit_depth):
    """Intensities in [0, 1] to unsigned integers of ``bit_depth`` bits (rounded, clipped).

    Returns ``uint8`` for 8 bits, ``uint16`` otherwise.
    """
    top = (1 << int(bit_depth)) - 1
    dn = np.rint(np.clip(image, 0.0, 1.0) * top)
    return dn.astype(np.uint8 if bit_depth <= 8 else np.uint16)
