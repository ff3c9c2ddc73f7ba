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

from dataclasses import dataclass

import numpy as np

from vidtrack.synth._capsules import capsule_coverages

__all__ = ["Capsule", "Box", "Roi", "capsule_coverage", "capsule_coverages", "box_coverage",
           "coverages", "shape_roi", "smooth_texture", "composite_boxes", "add_sensor_noise",
           "quantize"]

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
    pixel below a line (``_square_below`` of :mod:`vidtrack.synth._capsules`, where the
    functions named here are) and ``d`` the signed distance of its centre from the axis.
    Pixels near the rounded ends are sampled on an ``s x s`` grid centred in its cells
    (resolution 1/s^2, symmetric about the pixel centre): the share of its points whose
    distance to the segment (``_segment_distance``) is ``<= r``.

    That share is counted one sub-row of points at a time rather than point by point
    (``_sampled_coverage``): the capsule is convex, so a horizontal line meets it in one
    interval ``[lo, hi]``, the union of its sections by the two end discs and by the
    strip between them (``_line_spans``), and the points ``column + offset`` of the line
    in it follow from ``ceil`` and ``floor``: ``s`` evaluations a pixel instead of
    ``s^2``. So that the count is the point-by-point one to the bit, and not only
    mathematically, the distance test itself is made on the two points either side of
    each end of every line; a line where it disagrees (a point within rounding of the
    boundary) has its pixels tested point by point, as are the pixels of a capsule with
    few of them (``_COUNT_BY_LINES_FROM``) or an ``s`` that is not a power of two.
    """
    return capsule_coverages([capsule], [roi], supersample=supersample)[0]


def _interval_overlap(lo, hi, centres):
    return np.clip(np.minimum(hi, centres + 0.5) - np.maximum(lo, centres - 0.5), 0.0, 1.0)


def box_coverage(box, roi):
    """Exact fraction of each pixel of ``roi`` covered by the axis-aligned ``box``."""
    u0, u1, v0, v1 = box.extent_px()
    rows = np.arange(roi.r0, roi.r1, dtype=np.float64)
    cols = np.arange(roi.c0, roi.c1, dtype=np.float64)
    return np.outer(_interval_overlap(v0, v1, rows), _interval_overlap(u0, u1, cols))


#: Coverage arrays a cache of :func:`coverages` holds before it is emptied.
_CACHE_SIZE = 256


def coverages(items, *, supersample=16, cache=None):
    """Coverage of each ``(shape, roi)`` of ``items`` (a :class:`Capsule` or a
    :class:`Box` over a :class:`Roi`), the capsules computed together
    (:func:`~vidtrack.synth._capsules.capsule_coverages`).

    ``cache``, a dict, holds the arrays of earlier calls by ``(shape, roi)``: a shape that
    does not move is computed once (emptied when it would hold more than
    :data:`_CACHE_SIZE`).
    """
    cache = {} if cache is None else cache
    todo = [item for item in dict.fromkeys(items) if item not in cache]
    if len(cache) + len(todo) > _CACHE_SIZE:
        cache.clear()
        todo = list(dict.fromkeys(items))
    capsules = [item for item in todo if not isinstance(item[0], Box)]
    found = capsule_coverages([shape for shape, _ in capsules], [roi for _, roi in capsules],
                              supersample=supersample)
    cache.update(zip(capsules, found))
    cache.update((item, box_coverage(*item)) for item in todo if isinstance(item[0], Box))
    return [cache[item] for item in items]


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


def composite_boxes(bases, layer_lists, roi, *, supersample=16, cache=None):
    """Paint opaque ``layer_lists[k]`` over ``bases[k]`` (the pixels of ``roi``), in order,
    for every k (the exposure samples of a frame): the coverages of all of them computed
    together (:func:`coverages`).

    Parameters
    ----------
    bases : sequence of numpy.ndarray
        The pixels of ``roi`` before painting (not modified).
    layer_lists : sequence of sequences of (key, shape, grey)
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
    list of (image, covers)
        For each base: the painted pixels, and key -> (sub-ROI, coverage array) for
        every layer painted on it.
    """
    placed = [[(key, shape, grey, _within(shape, roi)) for key, shape, grey in layers
               if shape is not None] for layers in layer_lists]
    placed = [[layer for layer in layers if not layer[3].empty] for layers in placed]
    found = iter(coverages([(shape, sub) for layers in placed for _, shape, _, sub in layers],
                           supersample=supersample, cache=cache))
    out = []
    for base, layers in zip(bases, placed):
        image = base.copy()
        covers = {}
        for (key, _, grey, sub), cov in zip(layers, found):
            sl = sub.slice_in(roi)
            if callable(grey):                 # a textured fill: its grey levels over sub
                grey = grey(sub)
            image[sl] += (grey - image[sl]) * cov
            covers[key] = (sub, cov)
        out.append((image, covers))
    return out


def _within(shape, roi):
    """The pixels of ``roi`` that ``shape`` can touch."""
    s = shape_roi(shape.extent_px())
    return Roi(max(s.r0, roi.r0), min(s.r1, roi.r1), max(s.c0, roi.c0), min(s.c1, roi.c1))


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
    dn = np.clip(np.asarray(image, dtype=np.float64), 0.0, 1.0)
    dn *= top
    return np.rint(dn, out=dn).astype(np.uint8 if bit_depth <= 8 else np.uint16)
