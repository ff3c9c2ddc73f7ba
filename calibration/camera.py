"""The camera model: pinhole intrinsics and lens distortion, and (un)distorting points.

:class:`CameraCalibration` holds one camera's intrinsics and Brown-Conrady distortion
(OpenCV's model). :func:`undistort_points` takes observed (distorted) pixel positions to
where an ideal pinhole camera with the same camera matrix would have seen them;
:func:`distort_points` is its inverse.

A camera is calibrated from checkerboard images by ``calibration.checkerboard`` and
written to and read from calibration files by ``calibration.calibration_file``.
"""

from dataclasses import dataclass

import numpy as np

from calibration.scale import _point_array

__all__ = ["CameraCalibration", "undistort_points", "distort_points"]


@dataclass(frozen=True)
class CameraCalibration:
    """Pinhole intrinsics and lens distortion of one camera (OpenCV's model).

    Attributes
    ----------
    fx, fy : float
        Focal lengths in pixels (> 0).
    cx, cy : float
        Principal point in pixels (column, row).
    dist_coeffs : tuple of float
        ``(k1, k2, p1, p2[, k3[, k4, k5, k6[, s1..s4[, tau_x, tau_y]]]])``, OpenCV order.
    image_size : tuple of int
        ``(width, height)`` in pixels of the images calibrated.
    rms_px : float or None
        Root-mean-square reprojection error over every corner of every image, in
        pixels (None when unknown, e.g. a hand-written file).
    per_image_rms_px : tuple of float
        The same per image, in the order of ``images``.
    images : tuple of str
        Names of the images used.
    rejected : tuple of str
        Names of the images in which the board was not found (not used).
    pattern : tuple of int or None
        Inner corners ``(per row, per column)`` of the board, e.g. ``(9, 6)``.
    square_m : float or None
        Side of one board square in m.
    """

    fx: float
    fy: float
    cx: float
    cy: float
    dist_coeffs: tuple = (0.0, 0.0, 0.0, 0.0, 0.0)
    image_size: tuple | None = None
    rms_px: float | None = None
    per_image_rms_px: tuple = ()
    images: tuple = ()
    rejected: tuple = ()
    pattern: tuple | None = None
    square_m: float | None = None

    @property
    def camera_matrix(self):
        """The 3x3 camera matrix K (float64)."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def dist_array(self):
        """The distortion coefficients as a float64 array."""
        return np.asarray(self.dist_coeffs, dtype=np.float64)

    def undistort_points(self, uv):
        """Observed pixels -> ideal (distortion-free) pixels; see :func:`undistort_points`."""
        return undistort_points(uv, self)

    def distort_points(self, uv):
        """Ideal pixels -> observed pixels; see :func:`distort_points`."""
        return distort_points(uv, self)

    def to_dict(self):
        """A plain dict (JSON and TOML can take it): the ``[camera]`` table of a file."""
        out = {
            "fx": self.fx, "fy": self.fy, "cx": self.cx, "cy": self.cy,
            "dist_coeffs": list(self.dist_coeffs),
        }
        if self.image_size is not None:
            out["image_size"] = list(self.image_size)
        if self.rms_px is not None:
            out["rms_px"] = self.rms_px
        if self.images:
            out["images"] = list(self.images)
            out["per_image_rms_px"] = list(self.per_image_rms_px)
        if self.rejected:
            out["rejected"] = list(self.rejected)
        if self.pattern is not None:
            out["pattern"] = list(self.pattern)
        if self.square_m is not None:
            out["square_m"] = self.square_m
        return out


# --------------------------------------------------------------------------- points


def _criteria():
    import cv2

    return (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)


def undistort_points(uv, camera):
    """Observed (distorted) pixel positions to ideal pinhole pixel positions.

    Parameters
    ----------
    uv : array_like, shape (N, 2) or (2,)
        Pixel positions (u = column, v = row) as seen in the image. Rows with NaN stay
        NaN.
    camera : CameraCalibration

    Returns
    -------
    numpy.ndarray
        Same shape, float64: where a distortion-free camera with the same camera
        matrix K would have imaged the same rays (``cv2.undistortPoints`` with P = K,
        iterated to convergence).

    Raises
    ------
    InputError
        ``uv`` not (N, 2).
    """
    import cv2

    pts, single = _point_array(uv, 2, "uv")
    out = np.full_like(pts, np.nan)
    ok = np.all(np.isfinite(pts), axis=1)
    if ok.any():
        src = np.ascontiguousarray(pts[ok].reshape(-1, 1, 2))
        K = camera.camera_matrix
        D = camera.dist_array
        if hasattr(cv2, "undistortPointsIter"):  # OpenCV 4.x
            dst = cv2.undistortPointsIter(src, K, D, None, K, _criteria())
        else:  # OpenCV 5: criteria are an argument of undistortPoints
            dst = cv2.undistortPoints(src, K, D, None, K, criteria=_criteria())
        out[ok] = dst.reshape(-1, 2)
    return out[0] if single else out


def distort_points(uv, camera):
    """Ideal pinhole pixel positions to observed (distorted) pixel positions.

    The inverse of :func:`undistort_points`: the ideal position is turned into its
    normalised ray ((u - cx) / fx, (v - cy) / fy, 1) and projected through the lens
    model with ``cv2.projectPoints`` (no rotation, no translation).

    Parameters
    ----------
    uv : array_like, shape (N, 2) or (2,)
        Ideal pixel positions; NaN rows stay NaN.
    camera : CameraCalibration

    Returns
    -------
    numpy.ndarray
        Same shape, float64.
    """
    import cv2

    pts, single = _point_array(uv, 2, "uv")
    out = np.full_like(pts, np.nan)
    ok = np.all(np.isfinite(pts), axis=1)
    if ok.any():
        rays = np.ones((int(ok.sum()), 3))
        rays[:, 0] = (pts[ok, 0] - camera.cx) / camera.fx
        rays[:, 1] = (pts[ok, 1] - camera.cy) / camera.fy
        img, _ = cv2.projectPoints(rays.reshape(-1, 1, 3), np.zeros(3), np.zeros(3),
                                   camera.camera_matrix, camera.dist_array)
        out[ok] = img.reshape(-1, 2)
    return out[0] if single else out
