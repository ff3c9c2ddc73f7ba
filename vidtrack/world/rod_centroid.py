"""Where a calibrated camera sees the centroid of a rod's silhouette, and the rod's 3-D axis.

A straw is a rod: a capsule of length ``L`` (between its end caps' centres) and radius
``r``, the set of points within ``r`` of its axis segment, i.e. the union of the balls of
radius ``r`` centred on the segment. In a pinhole camera each ball images (to (r /
depth)^2) as a disc of radius ``f r / depth`` centred on the projection of its centre,
the projected axis is a straight segment and 1 / depth varies linearly along it: the
silhouette is the union of discs whose centres run along the projected segment and whose
radii vary linearly between the ends -- the convex hull of the two end discs (a "tapered
capsule"). Its area centroid lies on the projected axis but not at the projection of the
rod's centre: the near half images longer (and wider) than the far half, so the centroid
sits towards the near end, by up to about f L^2 / (6 depth^2) px (f L^2 / (8 depth^2)
from the lengths, a third more from the widths).

``taper`` chooses the end discs' radii:

- ``"perspective"`` (a real rod): ``f r / depth`` of each end;
- ``"uniform"``: both ``f r / depth`` of the centre -- how ``vidtrack synth`` draws the
  straw (its silhouette's centroid is then the midpoint of the projected ends).

:func:`hull_centroid` is the exact centroid of the convex hull of two discs;
:func:`silhouette_centroid` places a rod in a camera and returns the centroid in the
camera's observed pixels (the lens, if any, applied to the centroid);
:func:`axis_from_lines` finds the rod's 3-D direction from each view's image line (the
centroid and the image angle): each line back-projects to a plane through its camera's
centre that holds the axis; the planes' common direction is the axis.
"""

import numpy as np

__all__ = ["TAPERS", "MIN_PLANE_ANGLE_DEG", "hull_centroid", "silhouette_centroid",
           "silhouette_bias", "centre_from_ends", "axis_from_lines", "axis_from_planes",
           "capsule_from_moments", "pixels_per_m"]

#: Two views' planes must be at least this far from parallel (degrees) for their
#: intersection to give the axis.
MIN_PLANE_ANGLE_DEG = 10.0

#: How the silhouette's width varies along a rod (see the module).
TAPERS = ("perspective", "uniform")


def hull_centroid(a_px, b_px, ra_px, rb_px):
    """Area centroid of the convex hull of two discs (the union of the discs whose centre
    and radius vary linearly from disc a to disc b).

    Parameters
    ----------
    a_px, b_px : array_like, shape (N, 2)
        The discs' centres.
    ra_px, rb_px : array_like, shape (N,)
        Their radii (> 0).

    Returns
    -------
    numpy.ndarray, shape (N, 2)
        The centroid; it lies on the line a-b.
    """
    a = np.atleast_2d(np.asarray(a_px, dtype=np.float64))
    b = np.atleast_2d(np.asarray(b_px, dtype=np.float64))
    r1 = np.broadcast_to(np.asarray(ra_px, dtype=np.float64), a.shape[:1])
    r2 = np.broadcast_to(np.asarray(rb_px, dtype=np.float64), a.shape[:1])
    d = b - a
    ell = np.linalg.norm(d, axis=1)
    out = np.where((r1 >= r2)[:, None], a, b)          # one disc holds the other
    hull = ell > np.abs(r1 - r2)
    if hull.any():
        l_, p, q = ell[hull], r1[hull], r2[hull]
        cos_t = np.clip((p - q) / l_, -1.0, 1.0)
        theta = np.arccos(cos_t)                         # tangent points' angle at a
        sin_t = np.sin(theta)
        # x along a -> b, from a: the sector of disc a behind its tangent points ...
        beta = np.pi - theta
        area_a = beta * p * p
        x_a = -2.0 * p * sin_t / (3.0 * beta)
        # ... the sector of disc b ahead of them (theta > 0: ell > |r1 - r2|) ...
        area_b = theta * q * q
        x_b = l_ + 2.0 * q * sin_t / (3.0 * theta)
        # ... and twice the quadrilateral a, b, T_b, T_a between them
        xs = np.stack([np.zeros_like(l_), l_, l_ + q * cos_t, p * cos_t], axis=1)
        ys = np.stack([np.zeros_like(l_), np.zeros_like(l_), q * sin_t, p * sin_t], axis=1)
        xn, yn = np.roll(xs, -1, axis=1), np.roll(ys, -1, axis=1)
        cross = xs * yn - xn * ys
        area_q = 0.5 * cross.sum(axis=1)
        x_q = ((xs + xn) * cross).sum(axis=1) / (6.0 * area_q)
        total = area_a + area_b + 2.0 * area_q
        x = (area_a * x_a + area_b * x_b + 2.0 * area_q * x_q) / total
        out = out.copy()
        out[hull] = a[hull] + d[hull] * (x / l_)[:, None]
    return out


def pixels_per_m(camera, xyz):
    """Ideal pixels per metre across the line of sight at world points (N,): the image
    radius of a ball of 1 m there (f / depth for square pixels; the geometric mean of the
    two focal lengths otherwise)."""
    M = camera.matrix[:, :3]                 # third row of unit length (ProjectiveCamera)
    f = np.sqrt(abs(np.linalg.det(M)))
    return f / np.abs(np.asarray(xyz, dtype=np.float64) @ M[2] + camera.matrix[2, 3])


def _observed(camera, uv_ideal, xyz):
    """Ideal pixels of P -> the camera's observed pixels (its lens applied), through the
    world point on each pixel's ray at the depth of ``xyz``."""
    if camera.lens is None:
        return uv_ideal
    P = camera.matrix
    w = xyz @ P[2, :3] + P[2, 3]
    h = np.column_stack([uv_ideal * w[:, None], w]) - P[:, 3]
    world = np.linalg.solve(P[:, :3], h.T).T
    return camera.project(world)


def _through_lens(camera, a, b, r1, r2, centroid, xyz, *, nx=12, ny=4):
    """The centroid in observed pixels of the hull of discs (a, r1), (b, r2) (ideal
    pixels) whose ideal centroid is ``centroid``: the lens carries the centroid and bends
    and stretches the shape; the latter's part is integrated (Gauss-Legendre over the
    hull, each point weighted by the lens's area ratio there) as the difference between
    the weighted mean of the carried points and the carried mean."""
    out = _observed(camera, centroid, xyz)
    d = b - a
    ell = np.linalg.norm(d, axis=1)
    hull = (ell > np.abs(r1 - r2)) & np.all(np.isfinite(out), axis=1)
    if not hull.any():
        return out
    a, l_, p, q = a[hull], ell[hull], r1[hull], r2[hull]
    e = d[hull] / l_[:, None]
    n_ = np.column_stack([-e[:, 1], e[:, 0]])
    cos_t = np.clip((p - q) / l_, -1.0, 1.0)
    sin_t = np.sqrt(1.0 - cos_t ** 2)
    xi, wi = np.polynomial.legendre.leggauss(nx)
    eta, wj = np.polynomial.legendre.leggauss(ny)
    pieces = ((-p, p * cos_t), (p * cos_t, l_ + q * cos_t), (l_ + q * cos_t, l_ + q))
    xs, ws = [], []
    for x0, x1 in pieces:
        mid, half = 0.5 * (x0 + x1), 0.5 * (x1 - x0)
        xs.append(mid[:, None] + half[:, None] * xi)
        ws.append(half[:, None] * wi)
    x = np.concatenate(xs, axis=1)                       # (K, 3 nx)
    wx = np.concatenate(ws, axis=1)
    # the half-width: the disc a behind its tangent points, the disc b ahead of them,
    # straight between
    t0, t1 = (p * cos_t)[:, None], (l_ + q * cos_t)[:, None]
    frac = np.clip((x - t0) / (t1 - t0), 0.0, 1.0)
    h = np.where(x < t0, np.sqrt(np.clip(p[:, None] ** 2 - x ** 2, 0.0, None)),
                 np.where(x > t1,
                          np.sqrt(np.clip(q[:, None] ** 2 - (x - l_[:, None]) ** 2, 0.0, None)),
                          (p[:, None] + (q - p)[:, None] * frac) * sin_t[:, None]))
    y = h[:, :, None] * eta                               # (K, 3 nx, ny)
    w = (wx * h)[:, :, None] * wj
    pts = (a[:, None, None, :] + x[:, :, None, None] * e[:, None, None, :]
           + y[..., None] * n_[:, None, None, :])
    k = len(a)
    flat = pts.reshape(-1, 2)
    ref = np.repeat(xyz[hull], flat.shape[0] // k, axis=0)
    step = 0.5
    q0 = _observed(camera, flat, ref)
    qu = _observed(camera, flat + [step, 0.0], ref)
    qv = _observed(camera, flat + [0.0, step], ref)
    jac = np.abs((qu[:, 0] - q0[:, 0]) * (qv[:, 1] - q0[:, 1])
                 - (qu[:, 1] - q0[:, 1]) * (qv[:, 0] - q0[:, 0])) / step ** 2
    w = w.reshape(k, -1)
    wj_ = w * jac.reshape(k, -1)
    carried_mean = np.einsum("km,kmi->ki", wj_, q0.reshape(k, -1, 2)) / wj_.sum(axis=1)[:, None]
    mean_ideal = np.einsum("km,kmi->ki", w, flat.reshape(k, -1, 2)) / w.sum(axis=1)[:, None]
    out = out.copy()
    out[hull] += carried_mean - _observed(camera, mean_ideal, xyz[hull])
    return out


def silhouette_centroid(camera, centre_m, direction, length_m, radius_m, *,
                        taper="perspective"):
    """The area centroid of a rod's silhouette in a camera's observed pixels.

    Parameters
    ----------
    camera : calibration.projective.ProjectiveCamera
    centre_m : array_like, shape (N, 3)
        The rod's centre (world, m).
    direction : array_like, shape (N, 3)
        Its axis (any length, either sense).
    length_m, radius_m : float or array_like, shape (N,)
        The axis segment's length (between the caps' centres) and the radius.
    taper : {"perspective", "uniform"}

    Returns
    -------
    numpy.ndarray, shape (N, 2)
        The centroid, computed in the ideal image and carried through the lens as a point
        (the lens's change of the silhouette's shape is left out: a second-order effect).
    """
    if taper not in TAPERS:
        raise ValueError(f"taper must be one of {TAPERS}, got {taper!r}")
    c = np.atleast_2d(np.asarray(centre_m, dtype=np.float64))
    d = np.atleast_2d(np.asarray(direction, dtype=np.float64))
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    half = 0.5 * np.broadcast_to(np.asarray(length_m, dtype=np.float64), c.shape[:1])
    r = np.broadcast_to(np.asarray(radius_m, dtype=np.float64), c.shape[:1])
    ends = (c - half[:, None] * d, c + half[:, None] * d)
    pa, pb = (camera.project_ideal(e) for e in ends)
    if taper == "perspective":
        ra, rb = (r * pixels_per_m(camera, e) for e in ends)
    else:
        ra = rb = r * pixels_per_m(camera, c)
    ra = np.broadcast_to(ra, c.shape[:1]).astype(np.float64)
    rb = np.broadcast_to(rb, c.shape[:1]).astype(np.float64)
    centroid = hull_centroid(pa, pb, ra, rb)
    if camera.lens is None:
        return centroid
    return _through_lens(camera, pa, pb, ra, rb, centroid, c)


def silhouette_bias(camera, centre_m, direction, length_m, radius_m, *, taper="perspective"):
    """The silhouette's centroid minus the projection of the rod's centre (observed px,
    (N, 2)): what to subtract from a measured centroid to get the centre's pixel."""
    c = np.atleast_2d(np.asarray(centre_m, dtype=np.float64))
    return (silhouette_centroid(camera, c, direction, length_m, radius_m, taper=taper)
            - camera.project(c))


def _to_cap_centres(camera, a, b, c, d, length_m, taper):
    """Image ends (N, 2) moved in along their line to where the rod's caps' centres image
    (``c -+ length_m / 2 d``): by the image length they exceed the projected axis segment
    by, shared as the caps' image radii are (equal for the "uniform" taper, each end's
    ``f r / depth`` for "perspective"); each end goes to the nearer cap."""
    half = 0.5 * length_m * d
    ca, cb = c - half, c + half
    pa, pb = camera.project(ca), camera.project(cb)
    swap = (np.linalg.norm(a - pb, axis=1) + np.linalg.norm(b - pa, axis=1)
            < np.linalg.norm(a - pa, axis=1) + np.linalg.norm(b - pb, axis=1))
    near_a = np.where(swap[:, None], cb, ca)
    near_b = np.where(swap[:, None], ca, cb)
    span = b - a
    ell = np.linalg.norm(span, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        e = span / ell[:, None]
    excess = ell - np.linalg.norm(pb - pa, axis=1)
    if taper == "perspective":
        ra, rb = pixels_per_m(camera, near_a), pixels_per_m(camera, near_b)
    else:
        ra = rb = np.ones(len(a))
    return (a + (excess * ra / (ra + rb))[:, None] * e,
            b - (excess * rb / (ra + rb))[:, None] * e)


def centre_from_ends(camera, end_a_px, end_b_px, centre_m, direction, *, length_m=None,
                     taper="perspective"):
    """Where a camera images the rod's 3-D centre, from the two ends of its image.

    Parameters
    ----------
    camera : calibration.projective.ProjectiveCamera
    end_a_px, end_b_px : array_like, shape (N, 2)
        The ends of the rod's image in the camera's observed pixels (in either order).
    centre_m, direction : array_like, shape (N, 3)
        A point of the rod's 3-D axis (world, m) and its direction (any length).
    length_m : float, optional
        The rod's axis length between its caps' centres. Given, the ends are taken to lie
        beyond the caps' centres' images by amounts in proportion to the caps' image
        radii (``taper``), as a silhouette's tips or a fitted bar's ends do, and are first
        moved in to them; None: the ends are the images of two points of the axis.
    taper : {"perspective", "uniform"}
        How the caps' image radii compare (see the module).

    Returns
    -------
    numpy.ndarray, shape (N, 2)
        Observed pixels of the rod's centre (the midpoint of the two 3-D points of the
        axis the ends, moved in, image); NaN where a row has no ends.

    Notes
    -----
    Each end's ray meets the axis line (nearest in the image) at ``c + s d``, depth
    ``w``; the 3-D midpoint of the two projects to ``(w_a a + w_b b) / (w_a + w_b)``
    (ideal pixels): the nearer end weighs less, as it images longer. Unlike the
    silhouette's centroid (:func:`silhouette_bias`) this does not rest on the image's
    width along the rod.
    """
    if taper not in TAPERS:
        raise ValueError(f"taper must be one of {TAPERS}, got {taper!r}")
    c = np.atleast_2d(np.asarray(centre_m, dtype=np.float64))
    d = np.atleast_2d(np.asarray(direction, dtype=np.float64))
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    a = np.atleast_2d(np.asarray(end_a_px, dtype=np.float64))
    b = np.atleast_2d(np.asarray(end_b_px, dtype=np.float64))
    if length_m is not None:
        a, b = _to_cap_centres(camera, a, b, c, d, float(length_m), taper)
    P = camera.matrix
    pc = c @ P[:, :3].T + P[:, 3]                     # homogeneous images of c and of d
    pd = d @ P[:, :3].T
    ends, depths = [], []
    for end in (a, b):
        q = camera.ideal(end)
        q1 = np.column_stack([q, np.ones(len(q))])
        # q x (pc + s pd) = 0 in the least-squares sense
        u, v = np.cross(q1, pc), np.cross(q1, pd)
        with np.errstate(invalid="ignore", divide="ignore"):
            s = -np.einsum("ni,ni->n", u, v) / np.einsum("ni,ni->n", v, v)
        ends.append(q)
        depths.append(pc[:, 2] + s * pd[:, 2])
    wa, wb = depths
    with np.errstate(invalid="ignore", divide="ignore"):
        ideal = (wa[:, None] * ends[0] + wb[:, None] * ends[1]) / (wa + wb)[:, None]
    out = np.full(ideal.shape, np.nan)
    ok = np.all(np.isfinite(ideal), axis=1)
    if ok.any():
        out[ok] = _observed(camera, ideal[ok], c[ok])
    return out


def axis_from_lines(cameras, points_px, directions_px, *, min_angle_deg=10.0):
    """The rod's 3-D axis from each view's image line.

    Parameters
    ----------
    cameras : sequence of calibration.projective.ProjectiveCamera
        M views.
    points_px : array_like, shape (N, M, 2)
        A point of each view's line (the measured centroid), observed pixels in each
        camera's convention; NaN where the view gives no line.
    directions_px : array_like, shape (N, M, 2)
        The line's direction there (observed pixels; NaN: no line).
    min_angle_deg : float
        The planes must be at least this far from parallel (the smallest angle between
        the best pair of them): otherwise the axis is not determined.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        Unit directions (N, 3), NaN where not determined, and the angle (degrees) that
        decided it: the direction's conditioning (0 when fewer than two lines).
    """
    pts = np.asarray(points_px, dtype=np.float64)
    dirs = np.asarray(directions_px, dtype=np.float64)
    n, m = pts.shape[:2]
    normals = np.full((n, m, 3), np.nan)
    for j, cam in enumerate(cameras):
        step = dirs[:, j] / np.linalg.norm(dirs[:, j], axis=1, keepdims=True)
        q1 = cam.ideal(pts[:, j] - step)
        q2 = cam.ideal(pts[:, j] + step)
        line = np.cross(np.column_stack([q1, np.ones(n)]), np.column_stack([q2, np.ones(n)]))
        plane = line @ cam.matrix                        # P^T l, per row
        nrm = plane[:, :3]
        normals[:, j] = nrm / np.linalg.norm(nrm, axis=1, keepdims=True)
    return axis_from_planes(normals, min_angle_deg=min_angle_deg)


def capsule_from_moments(length_px, area_px):
    """A capsule's axis length and radius (px) from its area and ``sqrt(12 lambda_max)``
    of its second moments (the tracker's ``length_px``); NaN where no capsule fits.

    Area 2 rho l + pi rho^2; second moment along the axis rho l^3 / 6 + 4 rho^3 l / 3 +
    pi rho^2 l^2 / 4 + pi rho^4 / 4.
    """
    s2 = np.asarray(length_px, dtype=np.float64) ** 2 / 12.0
    A = np.asarray(area_px, dtype=np.float64)
    ok = np.isfinite(s2) & np.isfinite(A) & (A > 0) & (s2 > 0)
    lo = np.zeros_like(A)
    hi = np.sqrt(np.where(ok, A, 0.0) / np.pi)

    def excess(rho):
        with np.errstate(divide="ignore", invalid="ignore"):
            ell = (A - np.pi * rho * rho) / (2.0 * rho)
            moment = (rho * ell ** 3 / 6.0 + 4.0 * rho ** 3 * ell / 3.0
                      + np.pi * rho ** 2 * ell ** 2 / 4.0 + np.pi * rho ** 4 / 4.0)
            return moment / A - s2                       # falls as rho grows

    ok &= excess(hi) < 0                                 # a disc is rounder than this
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        up = excess(mid) > 0
        lo = np.where(up, mid, lo)
        hi = np.where(up, hi, mid)
    rho = 0.5 * (lo + hi)
    with np.errstate(divide="ignore", invalid="ignore"):
        ell = (A - np.pi * rho * rho) / (2.0 * rho)
    return np.where(ok, ell, np.nan), np.where(ok, rho, np.nan)


def axis_from_planes(normals, *, min_angle_deg=MIN_PLANE_ANGLE_DEG):
    """The line common to the views' planes through the origin.

    Parameters
    ----------
    normals : array_like, shape (N, M, 3)
        Each view's plane's unit normal per row (NaN: the view gives no plane).
    min_angle_deg : float
        The planes must be at least this far from parallel (the smallest angle between
        the best-separated pair of them).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        Unit directions (N, 3), NaN where not determined, and the angle (degrees) that
        decided it (0 where fewer than two views give a plane).

    Notes
    -----
    The direction least inclined to every plane: the eigenvector of the smallest
    eigenvalue of ``sum n n^T``. With two planes the eigenvalues are 0, 1 - |cos| and
    1 + |cos| (``cos`` of the angle between the normals): the middle one measures how
    far from parallel the planes are.
    """
    normals = np.asarray(normals, dtype=np.float64)
    n = normals.shape[0]
    have = np.all(np.isfinite(normals), axis=2)
    out = np.full((n, 3), np.nan)
    angle = np.zeros(n)
    rows = np.flatnonzero(have.sum(axis=1) >= 2)
    if rows.size:
        nn = np.where(have[rows, :, None], normals[rows], 0.0)
        w, v = np.linalg.eigh(np.einsum("nmi,nmj->nij", nn, nn))
        mid = np.clip(w[:, 1], 0.0, None)
        angle[rows] = np.degrees(np.arccos(np.clip(1.0 - mid, -1.0, 1.0)))
        good = angle[rows] >= min_angle_deg
        out[rows[good]] = v[good, :, 0]
    return out, angle
