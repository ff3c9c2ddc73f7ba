"""Exact pixel coverage of capsules, many at a time (see :mod:`vidtrack.synth._raster`).

:func:`capsule_coverages` gives, for each capsule of a list and its ROI, the array that
:func:`vidtrack.synth._raster.capsule_coverage` documents, to the bit: every pixel of
every ROI goes through one set of array operations, each element with its own capsule's
end points and radius, so that a frame's shapes (every exposure sample's) cost a few
dozen numpy calls instead of a few dozen each. Every element is computed by the same
floating-point operations, in the same order, as when a capsule is taken alone, and
each capsule keeps its own choices (the sub-row counting or the point-by-point test of
its sampled pixels, by their number), so no value depends on what it is computed with.
"""

import functools

import numpy as np

#: Half the diagonal of a pixel: a pixel whose centre is farther than this from an edge
#: lies wholly on one side of it.
_HALF_DIAGONAL = 0.5 * np.sqrt(2.0) + 1e-9

#: Relative margin beyond which ``hypot(qu, qv)`` and ``sqrt(qu^2 + qv^2)`` (a few ulps
#: apart) are on the same side of a threshold.
_ROUNDING = 1e-9

#: Fewer sampled pixels than this in a capsule: each grid point is tested; more, the grid
#: is counted a sub-row at a time, whose fixed cost in numpy calls then pays (on the calls
#: of ``vidtrack synth --person-at-side``, thresholds from 8 to 40 took the same time
#: within 5 %, one point by point throughout twice as long).
_COUNT_BY_LINES_FROM = 24

#: Pixels tested point by point at a time: their points' arrays stay in the processor's
#: cache.
_POINTS_AT_ONCE = 64

#: Below this, the smaller of a unit normal's two components counts as zero (an
#: axis-aligned edge) in :func:`_square_below`.
_AXIS_ALIGNED = 1e-12


class _Segments:
    """End points and radii of capsules, one element per point to test (arrays that
    broadcast with the points)."""

    def __init__(self, ax, ay, bx, by, r):
        self.ax, self.ay, self.bx, self.by, self.r = ax, ay, bx, by, r
        self.du, self.dv = bx - ax, by - ay
        self.length2 = self.du * self.du + self.dv * self.dv

    @classmethod
    def of(cls, capsules):
        """One element per capsule."""
        ends = np.array([(c.a_px[0], c.a_px[1], c.b_px[0], c.b_px[1], float(c.radius_px))
                         for c in capsules], dtype=np.float64).reshape(-1, 5)
        return cls(*ends.T)

    def take(self, index):
        """The capsules of elements ``index`` (an index array of any shape)."""
        return _Segments(self.ax[index], self.ay[index], self.bx[index], self.by[index],
                         self.r[index])


def _segment_offset(pu, pv, seg):
    """``(qu, qv)``: points (pu, pv) less their closest points on their segments."""
    qu, qv = pu - seg.ax, pv - seg.ay
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.minimum(np.maximum((qu * seg.du + qv * seg.dv) / seg.length2, 0.0), 1.0)
    s = np.where(seg.length2 > 0.0, s, 0.0)       # a disc: qu - 0 * 0 is qu
    return qu - s * seg.du, qv - s * seg.dv


def _segment_distance(pu, pv, seg, near=()):
    """Distance of points (pu, pv) to their segments (arrays broadcast), on the same side
    of each threshold in ``near`` (arrays like the points) as ``np.hypot`` puts it.

    ``np.hypot`` costs ten times a multiplication: the distance is ``sqrt(qu^2 + qv^2)``,
    and ``hypot``'s only where that lies within :data:`_ROUNDING` of a threshold, where the
    two may round to either side of it.
    """
    qu, qv = _segment_offset(pu, pv, seg)
    d = np.sqrt(qu * qu + qv * qv)
    unsure = None
    for t in near:
        hit = np.abs(d - t) <= _ROUNDING * (np.abs(t) + 1.0)
        unsure = hit if unsure is None else unsure | hit
    if unsure is not None and unsure.any():
        qu, qv = np.broadcast_arrays(qu, qv)
        d[unsure] = np.hypot(qu[unsure], qv[unsure])
    return d


def _inside(pu, pv, seg):
    """The points (pu, pv) within ``r`` of their segments: ``np.hypot``'s verdict."""
    return _segment_distance(pu, pv, seg, near=(seg.r,)) <= seg.r


@functools.lru_cache(maxsize=8)
def _grid(s):
    """Offsets (1, s*s) of an s x s grid of points centred in their cells of a pixel."""
    offs = (np.arange(s) + 0.5) / s - 0.5
    ou, ov = np.meshgrid(offs, offs)
    ou, ov = ou.ravel()[None, :], ov.ravel()[None, :]
    ou.flags.writeable = False
    ov.flags.writeable = False
    return ou, ov


def _line_spans(v, seg, gap):
    """The ``u`` interval inside its capsule of each horizontal line ``v`` (an array, one
    capsule an element).

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
    ax, ay, bx, by, r = seg.ax, seg.ay, seg.bx, seg.by, seg.r
    du, dv, length2 = seg.du, seg.dv, seg.length2
    w = v - ay
    with np.errstate(invalid="ignore", divide="ignore"):
        h2 = np.stack([r * r - w * w, r * r - (v - by) * (v - by)])
        h2[h2 < 0.0] = np.nan                       # a NaN end is an empty piece
        h = np.sqrt(h2)
        lo = np.fmin(ax - h[0], bx - h[1])          # fmin and fmax skip NaN
        hi = np.fmax(ax + h[0], bx + h[1])
        # the strip, x = u - ax: 0 <= x du + w dv <= |ab|^2 (the projection) and
        # -r |ab| <= x dv - w du <= r |ab| (the distance from the axis)
        reach = r * np.sqrt(length2)
        lo_1 = w * (-dv / du) + ax
        hi_1 = lo_1 + length2 / du
        lo_1, hi_1 = np.where(du < 0.0, hi_1, lo_1), np.where(du < 0.0, lo_1, hi_1)
        # a vertical segment: all u, or none
        vertical = np.where((w * dv >= 0.0) & (w * dv <= length2), -np.inf, np.nan)
        lo_1 = np.where(du != 0.0, lo_1, vertical)
        hi_1 = np.where(du != 0.0, hi_1, -vertical)
        mid = w * (du / dv) + ax
        lo_2, hi_2 = mid - reach / np.abs(dv), mid + reach / np.abs(dv)
        # a horizontal segment: all u, or none
        horizontal = np.where(np.abs(w * du) <= reach, -np.inf, np.nan)
        lo_2 = np.where(dv != 0.0, lo_2, horizontal)
        hi_2 = np.where(dv != 0.0, hi_2, -horizontal)
        lo_s, hi_s = np.maximum(lo_1, lo_2), np.minimum(hi_1, hi_2)    # NaN: no u
        ok = (lo_s <= hi_s) & (length2 > 0.0)       # a disc has no strip
    np.fmin(lo, lo_s, out=lo, where=ok)
    np.fmax(hi, hi_s, out=hi, where=ok)
    empty = np.isnan(lo)
    if empty.any():             # above or below the segment: the nearer end is the closer
        first, second = np.where(ay <= by, ax, bx), np.where(ay <= by, bx, ax)
        near = np.where(v < 0.5 * (ay + by), first, second)
        np.copyto(lo, near, where=empty)
        np.copyto(hi, near - gap, where=empty)
    return lo, hi


def _points_coverage(pr, pc, seg, s):
    """Share of the ``s x s`` grid points of each pixel (row ``pr``, column ``pc``) inside
    its capsule (``seg``, an element a pixel), tested one by one.

    :func:`_inside` on every point, a few pixels at a time (:data:`_POINTS_AT_ONCE`) and
    with what depends on a point's row or column alone computed once a row or column
    (the same values: each element by the same operations).
    """
    offs = _grid(s)[0][0, :s]                       # the s sub-pixel offsets, in order
    cov = np.empty(pr.size)
    for first in range(0, pr.size, _POINTS_AT_ONCE):
        part = slice(first, first + _POINTS_AT_ONCE)
        inside = _grid_inside(pr[part], pc[part], seg.take(part), offs)
        cov[part] = np.count_nonzero(inside.reshape(inside.shape[0], -1), axis=1) / (s * s)
    return cov


def _grid_inside(pr, pc, seg, offs):
    """:func:`_inside` on the grid points ``(pc + offs[j], pr + offs[i])`` of each pixel:
    an array (pixel, i, j)."""
    qu = ((pc[:, None] + offs) - seg.ax[:, None])[:, None, :]     # points' u less ax
    qv = ((pr[:, None] + offs) - seg.ay[:, None])[:, :, None]
    du, dv, length2, r = (x[:, None, None] for x in (seg.du, seg.dv, seg.length2, seg.r))
    disc = length2 == 0.0
    if not disc.all():                              # the closest points on the segments
        with np.errstate(invalid="ignore", divide="ignore"):
            t = qu * du + qv * dv
            t /= length2
        np.minimum(np.maximum(t, 0.0, out=t), 1.0, out=t)
        if disc.any():
            t[np.broadcast_to(disc, t.shape)] = 0.0  # a disc: qu - 0 * 0 is qu
        qu = qu - t * du
        t *= dv
        qv = np.subtract(qv, t, out=t)
    d = qu * qu + qv * qv
    np.sqrt(d, out=d)
    unsure = np.abs(d - r) <= _ROUNDING * (np.abs(r) + 1.0)
    if unsure.any():
        qu, qv = np.broadcast_arrays(qu, qv)
        d[unsure] = np.hypot(qu[unsure], qv[unsure])
    return d <= r


def _lines_coverage(pr, pc, own, c0, n_cols, seg, s):
    """Coverage of the pixels (rows ``pr``, columns ``pc``, sorted by their capsule's
    number ``own`` then row; ``c0`` and ``n_cols`` their ROI's first column and width,
    ``seg`` their capsule: an element a pixel) on the ``s x s`` grid of :func:`_grid`,
    counted a sub-row at a time.

    Returns
    -------
    cov : numpy.ndarray
        The coverage of each pixel.
    redo : numpy.ndarray of bool
        The pixels on a line where the distance test disagrees with the count (a point
        within rounding of an end): to be tested point by point.
    """
    # the lines of pixels (a capsule's pixels in one row), each pixel's among them (line)
    new_line = np.empty(pr.size, dtype=bool)
    new_line[0] = True
    np.not_equal(pr[1:], pr[:-1], out=new_line[1:])
    new_line[1:] |= own[1:] != own[:-1]
    line = np.cumsum(new_line) - 1
    offs = _grid(s)[0][0, :s]                       # the s sub-pixel offsets, in order
    # sub-line k of line i is element i * s + k: exactly the v of the grid points on it
    starts = np.flatnonzero(new_line)
    each = np.repeat(starts, s)
    line_v = (pr[starts][:, None] + offs).ravel()
    n_lines = starts.size
    lseg = seg.take(each)
    lo, hi = _line_spans(line_v, lseg, 0.5 / s)
    # the grid points (column + offs[j]) along a line, numbered g = column * s + j from
    # the roi's first column, are at u = u0 + g / s (exactly: s is a power of two)
    u0 = c0[each] - 0.5 + 0.5 / s
    first = np.ceil((lo - u0) * s)
    last = np.floor((hi - u0) * s)
    n_grid = n_cols[each] * s
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
    wrong = _inside(probe / s + u0, line_v, lseg) != expect
    # grid points of pixel column c on a line: g in [c s, c s + s - 1]
    start = ((pc - c0) * s)[:, None]
    counts = (np.minimum(last.reshape(n_lines, s)[line] + 1.0 - start, s)
              - np.maximum(first.reshape(n_lines, s)[line] - start, 0.0))
    cov = np.maximum(counts, 0.0).sum(axis=1) / (s * s)
    redo = wrong.any(axis=0).reshape(n_lines, s).any(axis=1)[line]
    return cov, redo


def _square_below(delta, a, b):
    """Exact area of the unit pixel on the side ``n . q <= delta`` of a line.

    ``q`` is measured from the pixel centre, ``n = (cos t, sin t)`` a unit normal with
    ``a = max(|cos t|, |sin t|)`` and ``b = min(...)`` (arrays like ``delta``). The
    distribution of ``n . q`` over the pixel is the convolution of two uniform laws of
    widths ``a`` and ``b`` (a trapezoid); this is its cumulative distribution function.
    """
    u = np.clip(delta + 0.5 * (a + b), 0.0, a + b)
    with np.errstate(invalid="ignore", divide="ignore"):
        low = u * u / (2.0 * a * b)
        mid = (u - 0.5 * b) / a
        high = 1.0 - (a + b - u) ** 2 / (2.0 * a * b)
    area = np.where(u <= b, low, np.where(u <= a, mid, high))
    return np.where(b <= _AXIS_ALIGNED, np.clip(u / a, 0.0, 1.0), area)


def _roi_pixels(rois):
    """Every pixel of every ROI, ROI after ROI, row-major: (owner, row, column)."""
    h = np.array([roi.shape[0] for roi in rois], dtype=np.int64)
    w = np.array([roi.shape[1] for roi in rois], dtype=np.int64)
    sizes = h * w
    owner = np.repeat(np.arange(len(rois)), sizes)
    index = np.arange(owner.size) - np.repeat(np.cumsum(sizes) - sizes, sizes)
    width = w[owner]
    r0 = np.array([roi.r0 for roi in rois], dtype=np.int64)[owner]
    c0 = np.array([roi.c0 for roi in rois], dtype=np.int64)[owner]
    return owner, index // width + r0, index % width + c0, sizes


def capsule_coverages(capsules, rois, *, supersample=16):
    """Fraction of each pixel of ``rois[k]`` covered by ``capsules[k]``, for every k.

    Parameters
    ----------
    capsules : sequence of Capsule
    rois : sequence of Roi
        The pixels to evaluate for each capsule.
    supersample : int, keyword-only
        Sub-pixel grid ``s x s`` used where a rounded end crosses a pixel.

    Returns
    -------
    list of numpy.ndarray, shape ``rois[k].shape``, float64
        What :func:`vidtrack.synth._raster.capsule_coverage` gives for each, to the bit.
    """
    s = int(supersample)
    outs = [np.zeros(roi.shape, dtype=np.float64) for roi in rois]
    live = [k for k, roi in enumerate(rois) if not roi.empty]
    if not live:
        return outs
    segs = _Segments.of([capsules[k] for k in live])
    owner, row, col, sizes = _roi_pixels([rois[k] for k in live])
    flat = np.zeros(owner.size, dtype=np.float64)
    seg = segs.take(owner)
    r = seg.r
    d = _segment_distance(col.astype(np.float64), row.astype(np.float64), seg,
                          near=(r - _HALF_DIAGONAL, r + _HALF_DIAGONAL))
    flat[d <= r - _HALF_DIAGONAL] = 1.0
    edge = np.flatnonzero(np.abs(d - r) < _HALF_DIAGONAL)
    if edge.size:
        flat[edge] = _edge_coverage(edge, owner, row, col, seg.take(edge), s,
                                    [rois[k] for k in live])
    ends = np.cumsum(sizes)
    for k, piece, roi_k in zip(live, np.split(flat, ends[:-1]), (rois[k] for k in live)):
        outs[k] = piece.reshape(roi_k.shape)
    return outs


def _edge_coverage(edge, owner, row, col, seg, s, rois):
    """Coverage of the pixels ``edge`` (indices into ``owner``, ``row``, ``col``), those
    within half a pixel's diagonal of their capsule's boundary: exact beside the straight
    sides, sampled elsewhere (:func:`vidtrack.synth._raster.capsule_coverage`, Notes)."""
    cov = np.empty(edge.size)
    pu, pv = col[edge] - seg.ax, row[edge] - seg.ay
    length = np.hypot(seg.du, seg.dv)
    with np.errstate(invalid="ignore", divide="ignore"):
        tu, tv = seg.du / length, seg.dv / length
        along = pu * tu + pv * tv
        half = 0.5 * (np.abs(tu) + np.abs(tv))  # the pixel's half-extent along the axis
        side = (along >= half) & (along <= length - half) & (length > 0.0)
    if np.any(side):
        tu, tv, r = tu[side], tv[side], seg.r[side]
        across = pu[side] * (-tv) + pv[side] * tu
        a, b = np.maximum(np.abs(tu), np.abs(tv)), np.minimum(np.abs(tu), np.abs(tv))
        area = (_square_below(r - across, a, b) + _square_below(r + across, a, b) - 1.0)
        cov[side] = np.clip(area, 0.0, 1.0)
    sampled = np.flatnonzero(~side)
    if sampled.size:
        pixels = edge[sampled]
        cov[sampled] = _sampled_coverage(row[pixels], col[pixels], owner[pixels],
                                         seg.take(sampled), s, rois)
    return cov


def _sampled_coverage(row, col, own, seg, s, rois):
    """Coverage of the pixels (``row``, ``col``) of capsules number ``own`` (sorted by
    capsule, then row-major; ``seg`` their capsules and ``rois`` the capsules' ROIs) on
    the ``s x s`` grid of :func:`_grid`.

    The same value as the share of a pixel's grid points whose :func:`_segment_distance`
    is ``<= r``: tested point by point for a capsule with few such pixels or an ``s`` that
    is not a power of two, counted one sub-row at a time otherwise (see the Notes of
    :func:`vidtrack.synth._raster.capsule_coverage`).
    """
    pr, pc = row.astype(np.float64), col
    counts = np.bincount(own, minlength=len(rois))
    by_lines = (counts[own] >= _COUNT_BY_LINES_FROM) & (not s & (s - 1))
    cov = np.empty(row.size)
    pointwise = ~by_lines
    if by_lines.any():
        c0 = np.array([roi.c0 for roi in rois], dtype=np.int64)[own[by_lines]]
        n_cols = np.array([roi.shape[1] for roi in rois], dtype=np.int64)[own[by_lines]]
        cov[by_lines], redo = _lines_coverage(pr[by_lines], pc[by_lines], own[by_lines],
                                              c0, n_cols, seg.take(by_lines), s)
        pointwise[np.flatnonzero(by_lines)[redo]] = True
    if pointwise.any():
        cov[pointwise] = _points_coverage(pr[pointwise], pc[pointwise],
                                          seg.take(pointwise), s)
    return cov
