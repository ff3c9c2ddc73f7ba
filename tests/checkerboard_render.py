"""Render checkerboard images through a known camera: ground truth for calibration tests.

The renderer is independent of the code under test: each output pixel is supersampled
(n x n sub-pixel samples), every sample's observed position is turned into its ray with
OpenCV's iterative undistortion (tight criteria), the ray is intersected with the board
plane of the given pose, and the board's colour there (black/white squares, a white
quiet zone one square wide, grey beyond) is averaged. The true corner pixels are then
``cv2.projectPoints`` of the board corners (see :func:`true_corners`).
"""

import numpy as np

_RAYS = {}


def _rays(K, D, size, ss):
    import cv2

    key = (K.tobytes(), D.tobytes(), tuple(size), ss)
    if key not in _RAYS:
        w, h = size
        off = (np.arange(ss) + 0.5) / ss - 0.5
        v, u = np.mgrid[0:h, 0:w].astype(np.float64)
        uu = (u[None, None] + off[:, None, None, None]).repeat(ss, axis=1)
        vv = (v[None, None] + off[None, :, None, None]).repeat(ss, axis=0)
        pts = np.stack([uu, vv], axis=-1).reshape(-1, 1, 2)
        crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-12)
        if hasattr(cv2, "undistortPointsIter"):
            n = cv2.undistortPointsIter(pts, K, D, None, None, crit)
        else:
            n = cv2.undistortPoints(pts, K, D, None, None, criteria=crit)
        n = n.reshape(-1, 2)
        _RAYS[key] = np.vstack([n.T, np.ones(len(n))])
    return _RAYS[key]


def render_board(K, D, rvec, tvec, size, pattern, square_m, *, ss=3):
    """An 8-bit grey image of a checkerboard seen through camera (K, D) from a pose.

    Parameters
    ----------
    K : (3, 3) array; D : distortion coefficients (OpenCV order)
    rvec, tvec : board pose (Rodrigues vector, translation in m); board points are
        (i * square, j * square, 0) for inner corner (i, j).
    size : (width, height) in pixels
    pattern : (cols, rows) inner corners
    square_m : side of a square in m
    ss : supersampling per axis
    """
    import cv2

    K = np.asarray(K, dtype=np.float64)
    D = np.asarray(D, dtype=np.float64)
    w, h = size
    rays = _rays(K, D, size, ss)
    R, _ = cv2.Rodrigues(np.asarray(rvec, dtype=np.float64))
    H_inv = np.linalg.inv(np.column_stack([R[:, 0], R[:, 1], np.ravel(tvec)]))
    q = H_inv @ rays
    with np.errstate(divide="ignore", invalid="ignore"):
        X, Y = q[0] / q[2], q[1] / q[2]
    cols, rows = pattern
    i = np.floor(X / square_m)
    j = np.floor(Y / square_m)
    board = (i >= -1) & (i < cols) & (j >= -1) & (j < rows)
    quiet = (i >= -2) & (i < cols + 1) & (j >= -2) & (j < rows + 1)
    val = np.where(board, np.where((i + j) % 2 == 0, 30.0, 225.0), np.where(quiet, 225.0, 110.0))
    val = np.where(q[2] > 0, val, 110.0)  # behind the camera's view of the plane
    img = val.reshape(ss * ss, h, w).mean(axis=0)
    return np.clip(np.round(img), 0, 255).astype(np.uint8)


def true_corners(K, D, rvec, tvec, pattern, square_m):
    """The exact pixel positions of the inner corners (OpenCV order), shape (N, 2)."""
    import cv2

    cols, rows = pattern
    j, i = np.mgrid[0:rows, 0:cols]
    obj = np.column_stack([i.ravel() * square_m, j.ravel() * square_m, np.zeros(i.size)])
    img, _ = cv2.projectPoints(obj, np.asarray(rvec, float), np.asarray(tvec, float),
                               np.asarray(K, float), np.asarray(D, float))
    return img.reshape(-1, 2)


#: A camera like a lab's high-speed camera with a wide lens (square pixels).
TRUE_K = np.array([[800.0, 0.0, 322.0], [0.0, 800.0, 236.0], [0.0, 0.0, 1.0]])
TRUE_D = np.array([-0.22, 0.06, 0.0008, -0.0006, 0.0])
SIZE = (640, 480)
PATTERN = (9, 6)
SQUARE_M = 0.025

#: Board poses (Rodrigues vector, translation in m): tilted every way, rotated in-plane
#: (edges not along pixel rows, which a box filter would quantise), covering the frame.
POSES = [
    ((0.0, 0.0, 0.30), (-0.09, -0.08, 0.45)),
    ((0.35, 0.0, 0.20), (-0.10, -0.06, 0.45)),
    ((-0.35, 0.10, -0.20), (-0.10, -0.07, 0.42)),
    ((0.0, 0.40, 0.10), (-0.12, -0.06, 0.50)),
    ((0.10, -0.40, -0.10), (-0.09, -0.07, 0.45)),
    ((0.25, 0.25, 0.30), (-0.10, -0.10, 0.50)),
    ((-0.30, -0.25, -0.20), (-0.08, -0.05, 0.48)),
    ((0.20, -0.30, 0.50), (-0.10, -0.10, 0.40)),
]

#: The board lying in the throw plane, parallel to the image plane (in-plane rotated).
PLANE_POSE = ((0.0, 0.0, 0.25), (-0.10, -0.06, 0.60))
