"""A calibrated perspective camera at any angle: world metres to observed pixels.

Labs calibrate their cameras with a wand or a frame (easyWand, DLTdv, Argus) or a
checkerboard (OpenCV) and get, per camera, either the 11 DLT coefficients or a 3x4
projection matrix P = K [R | t] with the lens's intrinsics K and distortion. Both are the
same model, a projective map of homogeneous world points to homogeneous pixels:

    (u, v, 1)^T ~ P (X, Y, Z, 1)^T

:class:`ProjectiveCamera` holds P, the lens (observed pixels are distorted: they are
undistorted through the lens before P is used; projected pixels are distorted after), and
the pixel convention of its coordinates: ``"top-left"`` (OpenCV's and vidtrack's: v grows
down from the top row) or ``"bottom-left"`` (DLTdv's and easyWand's: v grows up from the
bottom edge, v_bottom = height - v_top).
"""

from dataclasses import dataclass, field

import numpy as np

from calibration.errors import InputError

__all__ = ["ProjectiveCamera", "PIXEL_ORIGINS"]

#: Pixel conventions a camera's coordinates may use.
PIXEL_ORIGINS = ("top-left", "bottom-left")


def _finite_array(value, shape, what):
    a = np.asarray(value, dtype=np.float64)
    if a.shape != shape:
        raise InputError(f"{what} must have shape {shape}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{what} must be finite numbers")
    return a


def _affine(A, uv):
    """Pixels through a 3x3 matrix whose last row is (0, 0, 1)."""
    return uv @ A[:2, :2].T + A[:2, 2]


@dataclass(frozen=True, eq=False)
class ProjectiveCamera:
    """A pinhole camera with an optional lens distortion.

    Attributes
    ----------
    matrix : numpy.ndarray, shape (3, 4)
        The projection P, scaled so that its third row's first three elements have unit
        length (then the third element of P (X, 1) is the point's distance from the
        camera's focal plane, in m, up to its sign: see :meth:`depth`).
    lens : calibration.camera.CameraCalibration or None
        Intrinsics K and distortion of the lens (OpenCV's model) when the pixels P gives are
        ideal (undistorted) ones; None when P maps straight to observed pixels (a DLT).
        P's own intrinsics may differ from K (OpenCV's ``getOptimalNewCameraMatrix``
        gives P = K' [R | t]): observed pixels are undistorted to normalised rays with K
        and the distortion, then mapped with P's intrinsics K' (from the RQ
        decomposition of P's left 3x3 block); projection runs the same way back.
    pixel_origin : {"top-left", "bottom-left"}
        The convention of the pixel coordinates this camera takes and gives.
    name : str
        The view's name, for messages.
    """

    matrix: np.ndarray
    lens: object = None
    pixel_origin: str = "top-left"
    name: str = "camera"
    _centre: np.ndarray = field(init=False, repr=False)
    _lens_to_ideal: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        P = _finite_array(self.matrix, (3, 4), f"{self.name}: the projection matrix")
        norm = np.linalg.norm(P[2, :3])
        M = P[:, :3]
        if norm == 0 or abs(np.linalg.det(M)) <= 1e-12 * np.linalg.norm(M) ** 3:
            raise InputError(f"{self.name}: the projection matrix is singular (its left 3x3 "
                             "block has no inverse): not a camera")
        P = P / norm
        if self.pixel_origin not in PIXEL_ORIGINS:
            raise InputError(f"{self.name}: pixel_origin must be one of "
                             f"{', '.join(PIXEL_ORIGINS)}, got {self.pixel_origin!r}")
        if self.lens is not None and self.pixel_origin != "top-left":
            raise InputError(f"{self.name}: a lens distortion model (OpenCV's) needs "
                             "pixel_origin = \"top-left\"")
        P.setflags(write=False)
        object.__setattr__(self, "matrix", P)
        centre = -np.linalg.solve(P[:, :3], P[:, 3])
        centre.setflags(write=False)
        object.__setattr__(self, "_centre", centre)
        if self.lens is not None:
            from scipy.linalg import rq

            k_p, _ = rq(P[:, :3])
            k_p = k_p @ np.diag(np.sign(np.diag(k_p)))
            k_p /= k_p[2, 2]
            # lens pixels (K) -> P's ideal pixels (K'): K' K^-1, an affine map
            object.__setattr__(self, "_lens_to_ideal",
                               k_p @ np.linalg.inv(self.lens.camera_matrix))

    def __repr__(self):
        c = ", ".join(f"{v:.3g}" for v in self.centre)
        lens = "" if self.lens is None else ", lens"
        return (f"ProjectiveCamera(name={self.name!r}, centre_m=({c}), "
                f"pixel_origin={self.pixel_origin!r}{lens})")

    # ----------------------------------------------------------------- constructors
    @classmethod
    def from_dlt(cls, params, *, pixel_origin="top-left", name="camera"):
        """The camera of 11 DLT coefficients L1..L11 (DLTdv/easyWand order).

        u = (L1 X + L2 Y + L3 Z + L4) / (L9 X + L10 Y + L11 Z + 1), v likewise with
        L5..L8: P = [[L1 L2 L3 L4], [L5 L6 L7 L8], [L9 L10 L11 1]].
        """
        L = _finite_array(params, (11,), f"{name}: dlt (11 coefficients)")
        P = np.array([L[0:4], L[4:8], [L[8], L[9], L[10], 1.0]])
        return cls(P, pixel_origin=pixel_origin, name=name)

    @classmethod
    def from_projection(cls, matrix, *, intrinsics=None, distortion=None, name="camera"):
        """The camera of a 3x4 projection P = K [R | t] (OpenCV's convention, top-left).

        ``intrinsics`` (3x3 K) and ``distortion`` (OpenCV's 4, 5, 8, 12 or 14
        coefficients) describe the lens: observed pixels are undistorted with them before
        P is applied. Distortion needs the intrinsics.
        """
        lens = None
        if distortion is not None and intrinsics is None:
            raise InputError(f"{name}: distortion needs intrinsics (the 3x3 K it goes with)")
        if intrinsics is not None:
            from calibration.camera import CameraCalibration

            K = _finite_array(intrinsics, (3, 3), f"{name}: intrinsics")
            if (K[0, 0] <= 0 or K[1, 1] <= 0 or K[2, 2] != 1 or K[0, 1] or K[1, 0]
                    or K[2, 0] or K[2, 1]):
                raise InputError(f"{name}: intrinsics must be [[fx, 0, cx], [0, fy, cy], "
                                 "[0, 0, 1]] with fx, fy > 0")
            d = np.zeros(5) if distortion is None else np.asarray(distortion, np.float64)
            d = d.ravel()
            if d.size not in (4, 5, 8, 12, 14) or not np.all(np.isfinite(d)):
                raise InputError(f"{name}: distortion must be 4, 5, 8, 12 or 14 finite "
                                 f"numbers (OpenCV's order), got {d.size}")
            lens = CameraCalibration(fx=float(K[0, 0]), fy=float(K[1, 1]), cx=float(K[0, 2]),
                                     cy=float(K[1, 2]), dist_coeffs=tuple(map(float, d)))
        return cls(np.asarray(matrix, dtype=np.float64), lens=lens, name=name)

    # ----------------------------------------------------------------- geometry
    @property
    def centre(self):
        """The camera's centre in world coordinates (m)."""
        return self._centre

    def depth(self, xyz):
        """Depth of world points along the optical axis (m; > 0 in front of the camera).

        The sign follows from the handedness of the pixel axes: with pixels top-left (v
        down) a camera's left 3x3 block has a positive determinant when the third row
        points forward; bottom-left pixels (v up) flip it.
        """
        X = np.asarray(xyz, dtype=np.float64)
        sign = np.sign(np.linalg.det(self.matrix[:, :3]))
        if self.pixel_origin == "bottom-left":
            sign = -sign
        return sign * (X @ self.matrix[2, :3] + self.matrix[2, 3])

    def project_ideal(self, xyz):
        """World points (N, 3) -> ideal pixels (N, 2) through P (NaN in the focal plane)."""
        X = np.asarray(xyz, dtype=np.float64)
        h = X @ self.matrix[:, :3].T + self.matrix[:, 3]
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = h[..., :2] / h[..., 2:3]
        uv[h[..., 2] == 0] = np.nan
        return uv

    def project(self, xyz):
        """World points (N, 3) -> observed pixels (N, 2): the lens applied after P."""
        uv = self.project_ideal(xyz)
        if self.lens is None:
            return uv
        out = np.full_like(uv, np.nan)
        ok = np.all(np.isfinite(uv), axis=-1)
        if ok.any():
            out[ok] = self.lens.distort_points(_affine(np.linalg.inv(self._lens_to_ideal),
                                                       uv[ok]))
        return out

    def ideal(self, uv):
        """Observed pixels (N, 2) -> ideal pixels of P (the lens removed; NaN stays NaN)."""
        uv = np.asarray(uv, dtype=np.float64)
        if self.lens is None:
            return uv.copy()
        out = np.full_like(uv, np.nan)
        ok = np.all(np.isfinite(uv), axis=-1)
        if ok.any():
            out[ok] = _affine(self._lens_to_ideal, self.lens.undistort_points(uv[ok]))
        return out

    def from_image_pixels(self, uv, image_height):
        """Pixels in vidtrack's image convention (top-left) -> this camera's convention."""
        uv = np.array(uv, dtype=np.float64)
        if self.pixel_origin == "bottom-left":
            uv[..., 1] = image_height - uv[..., 1]
        return uv

    def to_dict(self):
        """A JSON-ready description."""
        out = {"name": self.name, "projection": self.matrix.tolist(),
               "pixel_origin": self.pixel_origin, "centre_m": self.centre.tolist()}
        if self.lens is not None:
            out["intrinsics"] = self.lens.camera_matrix.tolist()
            out["distortion"] = list(self.lens.dist_coeffs)
        return out
