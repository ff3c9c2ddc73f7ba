"""The 11-parameter direct linear transformation (DLT) for a camera not square to the axes.

When a camera does not look square onto a world plane, the orthographic view mapping
does not hold. The DLT models any pinhole camera (distortion removed first) by

    u = (L1 X + L2 Y + L3 Z + L4) / (L9 X + L10 Y + L11 Z + 1)
    v = (L5 X + L6 Y + L7 Z + L8) / (L9 X + L10 Y + L11 Z + 1)

(Abdel-Aziz and Karara 1971), i.e. a 3x4 projection matrix with its last element 1.
:func:`estimate_dlt` finds L1..L11 from six or more known, non-coplanar 3-D points and
their pixels; :func:`triangulate` recovers 3-D points seen by two (or more) cameras;
:func:`reconstruct_with_known` recovers them from one camera when one world coordinate
is known (a straw in a known plane).
"""

from dataclasses import dataclass

import numpy as np

from calibration.errors import InputError
from calibration.scale import _point_array

__all__ = ["DLT", "estimate_dlt", "project", "triangulate", "reconstruct_with_known"]

_AXES = ("x", "y", "z")


@dataclass(frozen=True)
class DLT:
    """An 11-parameter DLT camera.

    Attributes
    ----------
    params : tuple of float
        L1..L11 (pixels per metre and 1/m in the denominator).
    rms_px : float or None
        RMS reprojection error over the points it was estimated from, pixels.
    n_points : int
        Number of points it was estimated from (0 when built from parameters).
    condition : float or None
        Ratio of the largest to the second-smallest singular value of the normalised
        design matrix: large values mean a poorly constrained estimate.
    """

    params: tuple
    rms_px: float | None = None
    n_points: int = 0
    condition: float | None = None

    def __post_init__(self):
        p = np.asarray(self.params, dtype=np.float64).ravel()
        if p.shape != (11,) or not np.all(np.isfinite(p)):
            raise InputError(f"a DLT needs 11 finite parameters, got {self.params!r}")
        object.__setattr__(self, "params", tuple(float(v) for v in p))

    @classmethod
    def from_matrix(cls, matrix, *, rms_px=None, n_points=0, condition=None):
        """Build from a 3x4 projection matrix (scaled so its last element is 1).

        Raises
        ------
        InputError
            Not 3x4, or its last element is 0 (the world origin lies in the camera's
            focal plane: no 11-parameter form exists).
        """
        P = np.asarray(matrix, dtype=np.float64)
        if P.shape != (3, 4):
            raise InputError(f"a projection matrix must be 3x4, got shape {P.shape}")
        scale = np.max(np.abs(P))
        if not scale > 0 or abs(P[2, 3]) <= 1e-12 * scale:
            raise InputError("the world origin lies in the camera's focal plane: the "
                             "11-parameter DLT cannot represent this camera (move the origin)")
        P = P / P[2, 3]
        return cls(params=tuple(np.concatenate([P[0], P[1], P[2, :3]])), rms_px=rms_px,
                   n_points=n_points, condition=condition)

    @property
    def matrix(self):
        """The 3x4 projection matrix with last element 1."""
        L = np.asarray(self.params)
        return np.array([L[0:4], L[4:8], [L[8], L[9], L[10], 1.0]])

    def project(self, xyz):
        """World points (m) -> pixels; see :func:`project`."""
        return project(self, xyz)

    def to_dict(self):
        """A plain dict (JSON and TOML can take it)."""
        out = {"params": list(self.params), "n_points": self.n_points}
        if self.rms_px is not None:
            out["rms_px"] = self.rms_px
        if self.condition is not None:
            out["condition"] = self.condition
        return out


def _normaliser(pts):
    """Similarity T (homogeneous) taking pts to centroid 0, mean distance sqrt(dim)."""
    dim = pts.shape[1]
    c = pts.mean(axis=0)
    d = np.sqrt(np.sum((pts - c) ** 2, axis=1)).mean()
    s = np.sqrt(dim) / d if d > 0 else 1.0
    T = np.eye(dim + 1)
    T[:dim, :dim] *= s
    T[:dim, dim] = -s * c
    return T


def estimate_dlt(xyz, uv):
    """Estimate the 11 DLT parameters from known 3-D points and their pixels.

    Parameters
    ----------
    xyz : array_like, shape (N, 3)
        World positions in m, N >= 6, not all in one plane.
    uv : array_like, shape (N, 2)
        Their pixel positions (undistorted when the lens distorts).

    Returns
    -------
    DLT
        With the RMS reprojection error over the N points.

    Raises
    ------
    InputError
        Fewer than 6 points, shapes that differ, non-finite values, points that are
        coplanar (or collinear) so that the 3-D DLT is not determined.

    Notes
    -----
    Hartley's normalised linear method: both point sets are moved to centroid 0 and
    scaled to mean distance sqrt(3) (3-D) and sqrt(2) (2-D); the homogeneous system
    A p = 0 (two rows per point) is solved by SVD (the right singular vector of the
    smallest singular value), then denormalised.
    """
    X, _ = _point_array(xyz, 3, "xyz")
    x, _ = _point_array(uv, 2, "uv")
    if len(X) != len(x):
        raise InputError(f"xyz has {len(X)} points but uv has {len(x)}")
    if len(X) < 6:
        raise InputError(f"the 11-parameter DLT needs at least 6 points, got {len(X)}")
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(x))):
        raise InputError("xyz and uv must be finite (no NaN)")
    T3 = _normaliser(X)
    T2 = _normaliser(x)
    Xn = (T3 @ np.column_stack([X, np.ones(len(X))]).T).T
    xn = (T2 @ np.column_stack([x, np.ones(len(x))]).T).T
    sv3 = np.linalg.svd(Xn[:, :3], compute_uv=False)
    if sv3[-1] <= 1e-9 * sv3[0]:
        raise InputError("the 3-D points are coplanar (or collinear): a 3-D DLT needs "
                         "points spread in depth (use points on two planes)")
    n = len(X)
    A = np.zeros((2 * n, 12))
    A[0::2, 0:4] = Xn
    A[0::2, 8:12] = -xn[:, [0]] * Xn
    A[1::2, 4:8] = Xn
    A[1::2, 8:12] = -xn[:, [1]] * Xn
    _, s, vt = np.linalg.svd(A)
    Pn = vt[-1].reshape(3, 4)
    cond = float(s[0] / s[-2]) if s[-2] > 0 else float("inf")
    P = np.linalg.solve(T2, Pn @ T3)
    dlt = DLT.from_matrix(P)
    res = project(dlt, X) - x
    rms = float(np.sqrt(np.mean(np.sum(res ** 2, axis=1))))
    return DLT(params=dlt.params, rms_px=rms, n_points=n, condition=cond)


def project(dlt, xyz):
    """Project world points to pixels through a DLT.

    Parameters
    ----------
    dlt : DLT
    xyz : array_like, shape (N, 3) or (3,)
        World positions in m.

    Returns
    -------
    numpy.ndarray, shape (N, 2) or (2,)
        Pixels (u, v); NaN for points in the camera's focal plane (denominator 0) and
        for NaN input.
    """
    X, single = _point_array(xyz, 3, "xyz")
    P = dlt.matrix
    h = X @ P[:, :3].T + P[:, 3]
    w = h[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where((w != 0)[:, None], h[:, :2] / w[:, None], np.nan)
    return out[0] if single else out


def _rows(dlt, uv):
    """For each point, the two linear equations a . (X, Y, Z) = b of one camera."""
    L = np.asarray(dlt.params)
    u, v = uv[:, 0], uv[:, 1]
    a = np.empty((len(uv), 2, 3))
    b = np.empty((len(uv), 2))
    a[:, 0, :] = L[0:3] - u[:, None] * L[8:11]
    b[:, 0] = u - L[3]
    a[:, 1, :] = L[4:7] - v[:, None] * L[8:11]
    b[:, 1] = v - L[7]
    return a, b


def triangulate(dlts, uvs):
    """3-D points from their pixels in two or more DLT cameras (linear least squares).

    Parameters
    ----------
    dlts : sequence of DLT
        Two or more cameras.
    uvs : sequence of array_like, each shape (N, 2)
        The same N points' pixels in each camera, in the order of ``dlts``. A NaN in
        any camera gives NaN for that point.

    Returns
    -------
    numpy.ndarray, shape (N, 3)
        World positions in m. NaN where the rays are (nearly) parallel.

    Raises
    ------
    InputError
        Fewer than two cameras, counts that differ.

    Notes
    -----
    Each camera gives two equations linear in (X, Y, Z) (the DLT equations multiplied
    out); the stacked 2m x 3 system is solved per point through its SVD.
    """
    dlts = list(dlts)
    uvs = [_point_array(a, 2, "uv")[0] for a in uvs]
    if len(dlts) < 2:
        raise InputError(f"triangulation needs at least two cameras, got {len(dlts)}")
    if len(uvs) != len(dlts):
        raise InputError(f"{len(dlts)} cameras but {len(uvs)} point sets")
    n = len(uvs[0])
    if any(len(a) != n for a in uvs):
        raise InputError("every camera needs the same number of points "
                         f"(got {[len(a) for a in uvs]})")
    parts = [_rows(d, a) for d, a in zip(dlts, uvs)]
    A = np.concatenate([p[0] for p in parts], axis=1)
    b = np.concatenate([p[1] for p in parts], axis=1)
    out = np.full((n, 3), np.nan)
    ok = np.all(np.isfinite(A).reshape(n, -1), axis=1) & np.all(np.isfinite(b), axis=1)
    if ok.any():
        U, s, Vt = np.linalg.svd(A[ok], full_matrices=False)
        good = s[:, -1] > 1e-12 * s[:, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            coef = np.einsum("nij,ni->nj", U, b[ok]) / s
        sol = np.einsum("nji,nj->ni", Vt, coef)
        sol[~good] = np.nan
        out[ok] = sol
    return out


def reconstruct_with_known(dlt, uv, axis, value):
    """3-D points from one DLT camera when one world coordinate is known.

    Parameters
    ----------
    dlt : DLT
    uv : array_like, shape (N, 2)
        Pixels of the points.
    axis : {"x", "y", "z"}
        The world coordinate that is known.
    value : float or array_like, shape (N,)
        Its value in m (one for all points, or one per point).

    Returns
    -------
    numpy.ndarray, shape (N, 3)
        World positions in m; NaN where the camera ray is parallel to the plane
        ``axis = value`` (and for NaN input).

    Raises
    ------
    InputError
        Unknown axis, value of the wrong length.
    """
    if axis not in _AXES:
        raise InputError(f"axis must be one of x, y, z, got {axis!r}")
    pts, single = _point_array(uv, 2, "uv")
    n = len(pts)
    vals = np.broadcast_to(np.asarray(value, dtype=np.float64), (n,)) \
        if np.ndim(value) == 0 else np.asarray(value, dtype=np.float64)
    if vals.shape != (n,):
        raise InputError(f"value must be one number or {n} numbers, got shape {np.shape(value)}")
    k = _AXES.index(axis)
    free = [i for i in range(3) if i != k]
    a, b = _rows(dlt, pts)
    M = a[:, :, free]
    rhs = b - a[:, :, k] * vals[:, None]
    det = M[:, 0, 0] * M[:, 1, 1] - M[:, 0, 1] * M[:, 1, 0]
    scale = np.max(np.abs(M).reshape(n, -1), axis=1) ** 2
    good = np.isfinite(det) & np.isfinite(rhs).all(axis=1) & (np.abs(det) > 1e-12 * scale)
    out = np.full((n, 3), np.nan)
    if good.any():
        sol = np.linalg.solve(M[good], rhs[good][:, :, None])[:, :, 0]
        out[np.ix_(good, free)] = sol
        out[good, k] = vals[good]
    return out[0] if single else out
