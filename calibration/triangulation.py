"""3-D points from their pixels in two or more calibrated cameras.

:func:`triangulate` finds, for each point, the world position whose projections are
closest to where the cameras saw it: it minimises the sum of squared reprojection
distances in OBSERVED pixels (the lens's distortion included), over the views that saw
the point. It starts from the linear solution (each view's two equations
(u p3 - p1) . X = 0, (v p3 - p2) . X = 0 on undistorted pixels, rows scaled to unit
length, solved by least squares) and refines it by Levenberg-Marquardt, all points at
once (each point is its own 3-parameter problem). The linear solution minimises an
algebraic error, not the reprojection error; on a calibration that does not quite agree
with the points the two differ by centimetres (``Triangulation.linear_xyz`` keeps it, for
comparison).
"""

from dataclasses import dataclass

import numpy as np

from calibration.errors import InputError

__all__ = ["Triangulation", "triangulate"]


@dataclass(frozen=True, eq=False)
class Triangulation:
    """Triangulated points and how well they agree with the views.

    Attributes
    ----------
    xyz : numpy.ndarray, shape (N, 3)
        World positions (m); NaN where fewer than two views saw the point or the rays
        were parallel.
    residual_px : numpy.ndarray, shape (N, M)
        Reprojection distance in each of the M views (observed pixels); NaN where the view
        did not see the point.
    views : numpy.ndarray of int, shape (N,)
        Number of views that saw each point.
    linear_xyz : numpy.ndarray, shape (N, 3)
        The linear (algebraic) solution the refinement started from.
    iterations : int
        Levenberg-Marquardt iterations taken.
    """

    xyz: np.ndarray
    residual_px: np.ndarray
    views: np.ndarray
    linear_xyz: np.ndarray
    iterations: int

    def __repr__(self):
        ok = np.isfinite(self.xyz[:, 0])
        vals = self.residual_px[np.isfinite(self.residual_px)]
        med = float(np.median(vals)) if vals.size else float("nan")
        return (f"Triangulation(points={len(self.xyz)}, triangulated={int(ok.sum())}, "
                f"median_residual_px={med:.3g})")

    @property
    def rms_px(self):
        """RMS reprojection distance per point over the views that saw it (px)."""
        with np.errstate(invalid="ignore"):
            return np.sqrt(np.nanmean(self.residual_px ** 2, axis=1))


def _observations(cameras, uvs):
    cameras = list(cameras)
    if len(cameras) < 2:
        raise InputError(f"triangulation needs at least two cameras, got {len(cameras)}")
    if len(uvs) != len(cameras):
        raise InputError(f"{len(cameras)} cameras but {len(uvs)} point sets")
    obs = []
    for cam, uv in zip(cameras, uvs):
        a = np.asarray(uv, dtype=np.float64)
        if a.ndim != 2 or a.shape[1] != 2:
            raise InputError(f"{cam.name}: pixels must have shape (N, 2), got {a.shape}")
        obs.append(a)
    n = len(obs[0])
    if any(len(a) != n for a in obs):
        raise InputError(f"every camera needs the same number of points, got "
                         f"{[len(a) for a in obs]}")
    return cameras, np.stack(obs, axis=1)                    # (N, M, 2)


def _linear(cameras, ideal, seen):
    """Least squares of the stacked linear equations, rows of unit length."""
    n, m = seen.shape
    A = np.zeros((n, 2 * m, 3))
    b = np.zeros((n, 2 * m))
    for j, cam in enumerate(cameras):
        P = cam.matrix
        for k in range(2):
            row = ideal[:, j, k, None] * P[2] - P[k]         # (N, 4): row . (X, 1) = 0
            norm = np.linalg.norm(row[:, :3], axis=1)
            good = seen[:, j] & (norm > 0)
            scale = np.where(good, 1.0 / np.where(norm > 0, norm, 1.0), 0.0)
            A[:, 2 * j + k] = np.where(good[:, None], row[:, :3] * scale[:, None], 0.0)
            b[:, 2 * j + k] = np.where(good, -row[:, 3] * scale, 0.0)
    AtA = np.einsum("nki,nkj->nij", A, A)
    Atb = np.einsum("nki,nk->ni", A, b)
    out = np.full((n, 3), np.nan)
    ev = np.linalg.eigvalsh(AtA)
    ok = (seen.sum(axis=1) >= 2) & (ev[:, 0] > 1e-10 * np.maximum(ev[:, -1], 1e-300))
    if ok.any():
        out[ok] = np.linalg.solve(AtA[ok], Atb[ok][:, :, None])[:, :, 0]
    return out


def _residuals(cameras, xyz, obs, seen):
    """(N, M, 2) observed-pixel residuals, 0 where a view did not see the point."""
    r = np.zeros(obs.shape)
    for j, cam in enumerate(cameras):
        proj = cam.project(xyz)
        r[:, j] = np.where(seen[:, j, None], proj - obs[:, j], 0.0)
    return r


def triangulate(cameras, uvs, *, max_iter=50, tol=1e-10):
    """Triangulate points seen by two or more cameras, minimising the reprojection error.

    Parameters
    ----------
    cameras : sequence of calibration.projective.ProjectiveCamera
        M >= 2 cameras.
    uvs : sequence of array_like, each shape (N, 2)
        Each camera's observed pixels of the same N points, in that camera's pixel
        convention; a NaN row means the camera did not see the point.
    max_iter : int
        Levenberg-Marquardt iterations at most.
    tol : float
        Stop when no point's cost drops by more than this fraction.

    Returns
    -------
    Triangulation

    Raises
    ------
    InputError
        Fewer than two cameras, shapes that differ.
    """
    cameras, obs = _observations(cameras, uvs)
    n, m = obs.shape[:2]
    seen = np.all(np.isfinite(obs), axis=2)
    ideal = np.stack([cam.ideal(obs[:, j]) for j, cam in enumerate(cameras)], axis=1)
    seen &= np.all(np.isfinite(ideal), axis=2)
    linear = _linear(cameras, ideal, seen)
    x = linear.copy()
    active = np.all(np.isfinite(x), axis=1)
    if not active.any():
        return Triangulation(x, np.full((n, m), np.nan), seen.sum(axis=1), linear, 0)
    obs_a, seen_a, xa = obs[active], seen[active], x[active]
    lam = np.full(len(xa), 1e-3)
    r = _residuals(cameras, xa, obs_a, seen_a)
    cost = np.sum(r ** 2, axis=(1, 2))
    it = 0
    for it in range(1, max_iter + 1):  # noqa: B007 (the count is reported)
        h = 1e-6 * np.maximum(1.0, np.abs(xa))
        J = np.empty((len(xa), m, 2, 3))
        for k in range(3):
            step = np.zeros_like(xa)
            step[:, k] = h[:, k]
            rp = _residuals(cameras, xa + step, obs_a, seen_a)
            rm = _residuals(cameras, xa - step, obs_a, seen_a)
            J[..., k] = (rp - rm) / (2 * h[:, k, None, None])
        J = J.reshape(len(xa), 2 * m, 3)
        J[~np.isfinite(J)] = 0.0
        g = np.einsum("nki,nk->ni", J, r.reshape(len(xa), -1))
        H = np.einsum("nki,nkj->nij", J, J)
        D = np.einsum("nii->ni", H)
        H_lm = H + (lam[:, None] * np.maximum(D, 1e-12))[:, :, None] * np.eye(3)
        try:
            delta = -np.linalg.solve(H_lm, g[:, :, None])[:, :, 0]
        except np.linalg.LinAlgError:
            break
        trial = xa + delta
        r_new = _residuals(cameras, trial, obs_a, seen_a)
        cost_new = np.sum(r_new ** 2, axis=(1, 2))
        better = np.isfinite(cost_new) & (cost_new < cost)
        gain = np.where(better, (cost - cost_new) / np.maximum(cost, 1e-300), 0.0)
        xa = np.where(better[:, None], trial, xa)
        r = np.where(better[:, None, None], r_new, r)
        cost = np.where(better, cost_new, cost)
        lam = np.where(better, lam / 3, lam * 4)
        if np.all(gain <= tol) and np.all(better | (lam > 1e8)):
            break
    x[active] = xa
    res = np.full((n, m), np.nan)
    dist = np.sqrt(np.sum(r ** 2, axis=2))
    res[active] = np.where(seen_a, dist, np.nan)
    return Triangulation(x, res, seen.sum(axis=1), linear, it)
