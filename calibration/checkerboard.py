"""Checkerboard camera calibration through OpenCV, and the scale of the throw plane.

A lab films a printed checkerboard from several poses; :func:`calibrate_checkerboard`
finds its inner corners (``cv2.findChessboardCorners`` refined by ``cv2.cornerSubPix``)
and estimates the pinhole intrinsics and the Brown-Conrady distortion
(``cv2.calibrateCamera``), reporting the reprojection error overall and per image.
With one more image of the board lying in the throw plane, the metric scale of that
plane (m per pixel) follows (:func:`plane_scale`). :func:`checkerboard_calibration`
does both and gives a calibration file's content (``calibration.calibration_file``).
"""

import math
import re
from pathlib import Path

import numpy as np

from calibration.calibration_file import CalibrationFile
from calibration.camera import CameraCalibration, undistort_points
from calibration.errors import InputError
from calibration.scale import Scale, check_m_per_px

__all__ = [
    "calibrate_checkerboard", "checkerboard_calibration", "find_board", "board_points",
    "plane_scale", "read_calibration_images", "parse_pattern",
]

#: Image file extensions a calibration folder is searched for.
IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".pgm", ".ppm")


def parse_pattern(text):
    """Parse a board pattern ``"9x6"`` (inner corners per row x per column).

    Parameters
    ----------
    text : str or sequence of two ints

    Returns
    -------
    tuple of int
        ``(cols, rows)``, each >= 2.

    Raises
    ------
    InputError
        Not of the form ``NxM`` with N, M >= 2.
    """
    if isinstance(text, str):
        m = re.fullmatch(r"\s*(\d+)\s*[xX*,]\s*(\d+)\s*", text)
        if not m:
            raise InputError(f"pattern must be inner corners per row x per column, "
                             f"like '9x6', got {text!r}")
        cols, rows = int(m.group(1)), int(m.group(2))
    else:
        try:
            cols, rows = (int(v) for v in text)
        except (TypeError, ValueError):
            raise InputError(f"pattern must be two integers like (9, 6), got {text!r}") from None
    if cols < 2 or rows < 2:
        raise InputError(f"pattern needs at least 2x2 inner corners, got {cols}x{rows}")
    return (cols, rows)


def _natural_key(name):
    return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", name)]


def read_calibration_images(images):
    """Read calibration images from a folder or a list of files or arrays.

    Parameters
    ----------
    images : str, pathlib.Path, or sequence of (path or numpy.ndarray)
        A folder (every image file in it, natural sort: 2 before 10), one image file,
        or a list of image files and/or arrays.

    Returns
    -------
    list of (str, numpy.ndarray)
        Name and image (as read, any bit depth, grey or colour).

    Raises
    ------
    InputError
        A missing or unreadable file, an empty folder or list.
    """
    import cv2

    if isinstance(images, (str, Path)):
        path = Path(images)
        if path.is_dir():
            files = sorted((p for p in path.iterdir()
                            if p.is_file() and p.suffix.lower() in IMAGE_EXTENSIONS),
                           key=lambda p: _natural_key(p.name))
            if not files:
                raise InputError(f"{path}: no image files ({', '.join(IMAGE_EXTENSIONS)}) "
                                 "in this folder")
            items = files
        else:
            items = [path]
    else:
        items = list(images)
    if not items:
        raise InputError("no calibration images given")
    out = []
    for i, item in enumerate(items):
        if isinstance(item, np.ndarray):
            out.append((f"image {i}", item))
            continue
        p = Path(item)
        if not p.is_file():
            raise InputError(f"{p}: no such image file")
        img = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
        if img is None:
            raise InputError(f"{p}: not an image OpenCV can read")
        out.append((str(p), img))
    return out


def _gray8(image, name):
    import cv2

    img = np.asarray(image)
    if img.ndim == 3 and img.shape[2] in (3, 4):
        img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY if img.shape[2] == 3
                           else cv2.COLOR_BGRA2GRAY)
    elif img.ndim == 3 and img.shape[2] == 1:
        img = img[:, :, 0]
    if img.ndim != 2 or img.size == 0:
        raise InputError(f"{name}: expected a grey or colour image, got an array of shape "
                         f"{np.shape(image)}")
    if img.dtype == np.uint8:
        return np.ascontiguousarray(img)
    f = img.astype(np.float64)
    lo, hi = np.nanmin(f), np.nanmax(f)
    if not (np.isfinite(lo) and np.isfinite(hi)) or hi <= lo:
        return np.zeros(img.shape, np.uint8)
    return np.ascontiguousarray(np.round((f - lo) * (255.0 / (hi - lo))).astype(np.uint8))


def board_points(pattern, square_m):
    """Board corner positions on the board plane, in the order OpenCV finds them.

    Parameters
    ----------
    pattern : tuple of int
        ``(cols, rows)`` inner corners.
    square_m : float
        Side of a square in m.

    Returns
    -------
    numpy.ndarray, shape (cols * rows, 3)
        ``(i * square_m, j * square_m, 0)`` for row j, column i, row by row.
    """
    cols, rows = pattern
    j, i = np.mgrid[0:rows, 0:cols]
    pts = np.zeros((rows * cols, 3))
    pts[:, 0] = i.ravel() * square_m
    pts[:, 1] = j.ravel() * square_m
    return pts


def find_board(image, pattern, *, name="image"):
    """Find a checkerboard's inner corners to sub-pixel accuracy.

    Parameters
    ----------
    image : numpy.ndarray
        Grey or colour image, any integer or float type (scaled to 8 bits for
        detection).
    pattern : tuple of int
        ``(cols, rows)`` inner corners.
    name : str
        Name used in error messages.

    Returns
    -------
    numpy.ndarray, shape (cols * rows, 2), or None
        Corner pixel positions (u, v) in OpenCV's order, or None when the board is not
        found.
    """
    import cv2

    gray = _gray8(image, name)
    flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
    found, corners = cv2.findChessboardCorners(gray, tuple(pattern), None, flags)
    if not found or corners is None:
        return None
    corners = corners.astype(np.float32).reshape(-1, 1, 2)
    # Search window: a third of the smallest corner spacing, at least 2 px, at most 11.
    pts = corners.reshape(-1, 2).astype(np.float64)
    cols, rows = pattern
    grid = pts.reshape(rows, cols, 2)
    spacing = min(np.min(np.linalg.norm(np.diff(grid, axis=1), axis=2)),
                  np.min(np.linalg.norm(np.diff(grid, axis=0), axis=2)))
    half = int(max(2, min(11, math.floor(spacing / 3.0))))
    crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 100, 1e-4)
    corners = cv2.cornerSubPix(gray, corners, (half, half), (-1, -1), crit)
    return corners.reshape(-1, 2).astype(np.float64)


def plane_scale(corners_px, pattern, square_m, *, camera=None, max_spread=0.01):
    """The metric scale of the board's plane from its corners in one image.

    Parameters
    ----------
    corners_px : array_like, shape (cols * rows, 2)
        Corners as :func:`find_board` returns them (observed pixels).
    pattern : tuple of int
        ``(cols, rows)`` inner corners.
    square_m : float
        Side of a square in m.
    camera : CameraCalibration, optional
        When given, the corners are undistorted first, so the scale is that of the
        ideal image the view mapping works in.
    max_spread : float
        Largest accepted relative spread (std / mean) of the neighbour spacings. A
        board parallel to the image plane is imaged by a similarity, so its spacings
        are equal; a larger spread means the board is tilted and one scale would be
        wrong.

    Returns
    -------
    Scale
        ``method="checkerboard"``: square_m * (number of neighbour pairs) / (sum of
        their pixel distances).

    Raises
    ------
    InputError
        Wrong number of corners, square_m not > 0, or the spacings spread more than
        ``max_spread`` (the board is not square to the camera).
    """
    cols, rows = parse_pattern(pattern)
    pts = np.asarray(corners_px, dtype=np.float64)
    if pts.shape != (cols * rows, 2):
        raise InputError(f"expected {cols * rows} corners for a {cols}x{rows} board, "
                         f"got shape {pts.shape}")
    if not (isinstance(square_m, (int, float)) and math.isfinite(square_m) and square_m > 0):
        raise InputError(f"square_m must be > 0, got {square_m!r}")
    if camera is not None:
        pts = undistort_points(pts, camera)
    grid = pts.reshape(rows, cols, 2)
    d = np.concatenate([np.linalg.norm(np.diff(grid, axis=1), axis=2).ravel(),
                        np.linalg.norm(np.diff(grid, axis=0), axis=2).ravel()])
    mean = float(d.mean())
    if not mean > 0:
        raise InputError("the board's corners coincide: no plane scale")
    spread = float(d.std() / mean)
    if spread > max_spread:
        raise InputError(f"the board's square spacing varies by {100 * spread:.1f} % "
                         f"(more than {100 * max_spread:.1f} %): it is not parallel to the "
                         "image plane, so it gives no single plane scale")
    m_per_px = float(square_m) * d.size / float(d.sum())
    return Scale(m_per_px=check_m_per_px(m_per_px, "the plane's scale (m_per_px)"),
                 method="checkerboard")


def calibrate_checkerboard(images, pattern, square_m, *, fix_k3=False, min_images=3,
                           progress=None):
    """Camera intrinsics and distortion from views of a checkerboard.

    Parameters
    ----------
    images : str, pathlib.Path, or sequence of (path or numpy.ndarray)
        A folder of images, or a list of image files and/or arrays (all one size).
    pattern : str or tuple of int
        Inner corners per row x per column, ``"9x6"`` or ``(9, 6)``.
    square_m : float
        Side of a board square in m (> 0).
    fix_k3 : bool
        Hold the sixth-order radial term k3 at 0 (advisable with few images or a
        mild lens).
    min_images : int
        Fewest images with the board found (>= 3).
    progress : callable, optional
        ``progress(iterable, total)`` returning an iterable (a progress bar) that the
        corner search loops over.

    Returns
    -------
    CameraCalibration
        fx, fy, cx, cy, (k1, k2, p1, p2, k3), the RMS reprojection error over all
        corners and per image (pixels), and the images used and rejected.

    Raises
    ------
    InputError
        Unreadable images, images of different sizes, fewer than ``min_images`` with
        the board found, bad pattern or square size.

    Notes
    -----
    Corners: ``cv2.findChessboardCorners`` + ``cv2.cornerSubPix``; model and fit:
    ``cv2.calibrateCamera`` (Zhang's method then Levenberg-Marquardt). The reported
    errors are recomputed with ``cv2.projectPoints`` from the fitted poses:
    rms = sqrt(mean over corners of |observed - projected|^2).
    """
    import cv2

    pattern = parse_pattern(pattern)
    if isinstance(square_m, bool) or not isinstance(square_m, (int, float)) \
            or not math.isfinite(square_m) or square_m <= 0:
        raise InputError(f"square_m must be a number > 0, got {square_m!r}")
    loaded = read_calibration_images(images)
    size = None
    used, rejected, image_pts = [], [], []
    loop = progress(loaded, len(loaded)) if progress is not None else loaded
    for name, img in loop:
        shape = img.shape[1::-1]
        if size is None:
            size = shape
        elif shape != size:
            raise InputError(f"{name}: image is {shape[0]}x{shape[1]} px but the first "
                             f"image is {size[0]}x{size[1]}; calibration images must all "
                             "be one size")
        corners = find_board(img, pattern, name=name)
        if corners is None:
            rejected.append(name)
        else:
            used.append(name)
            image_pts.append(corners)
    need = max(3, int(min_images))
    if len(used) < need:
        raise InputError(f"the {pattern[0]}x{pattern[1]} board was found in {len(used)} of "
                         f"{len(loaded)} images; at least {need} are needed"
                         + (f" (not found in: {', '.join(rejected)})" if rejected else ""))
    obj = board_points(pattern, float(square_m)).astype(np.float32)
    obj_list = [obj.reshape(-1, 1, 3)] * len(used)
    img_list = [p.astype(np.float32).reshape(-1, 1, 2) for p in image_pts]
    flags = cv2.CALIB_FIX_K3 if fix_k3 else 0
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-12)
    _, K, D, rvecs, tvecs = cv2.calibrateCamera(obj_list, img_list, tuple(size), None, None,
                                                flags=flags, criteria=crit)
    K = np.asarray(K, dtype=np.float64)
    D = np.asarray(D, dtype=np.float64).ravel()
    sq_sum, n_sum, per_image = 0.0, 0, []
    for pts, rvec, tvec in zip(image_pts, rvecs, tvecs):
        proj, _ = cv2.projectPoints(obj.astype(np.float64).reshape(-1, 1, 3), rvec, tvec, K, D)
        r2 = np.sum((proj.reshape(-1, 2) - pts) ** 2, axis=1)
        per_image.append(float(np.sqrt(r2.mean())))
        sq_sum += float(r2.sum())
        n_sum += r2.size
    return CameraCalibration(
        fx=float(K[0, 0]), fy=float(K[1, 1]), cx=float(K[0, 2]), cy=float(K[1, 2]),
        dist_coeffs=tuple(float(v) for v in D), image_size=(int(size[0]), int(size[1])),
        rms_px=math.sqrt(sq_sum / n_sum), per_image_rms_px=tuple(per_image),
        images=tuple(used), rejected=tuple(rejected), pattern=pattern,
        square_m=float(square_m),
    )


def checkerboard_calibration(images, pattern, square_m, *, plane_image=None, fix_k3=False,
                             progress=None):
    """A calibration file's content from checkerboard images: camera, and plane scale.

    Parameters
    ----------
    images : str, pathlib.Path, or sequence of (path or numpy.ndarray)
        Calibration images (see :func:`calibrate_checkerboard`).
    pattern : str or tuple of int
        Inner corners, ``"9x6"``.
    square_m : float
        Side of a board square in m.
    plane_image : str, pathlib.Path or numpy.ndarray, optional
        An image of the board lying in the throw plane, parallel to the image plane
        (it may be one of ``images``). When given, the file gets a ``[scale]`` table:
        the plane's metres per undistorted pixel (:func:`plane_scale`).
    fix_k3 : bool
        Hold k3 at 0.
    progress : callable, optional
        As in :func:`calibrate_checkerboard`.

    Returns
    -------
    CalibrationFile

    Raises
    ------
    InputError
        As :func:`calibrate_checkerboard`; the board not found in ``plane_image``, or
        the board there not parallel to the image plane.
    """
    camera = calibrate_checkerboard(images, pattern, square_m, fix_k3=fix_k3,
                                    progress=progress)
    scale = None
    if plane_image is not None:
        ((name, img),) = read_calibration_images([plane_image])
        if camera.image_size is not None and tuple(img.shape[1::-1]) != camera.image_size:
            raise InputError(f"{name}: the plane image is {img.shape[1]}x{img.shape[0]} px but "
                             f"the calibration images are {camera.image_size[0]}x"
                             f"{camera.image_size[1]}")
        corners = find_board(img, camera.pattern, name=name)
        if corners is None:
            raise InputError(f"{name}: the {camera.pattern[0]}x{camera.pattern[1]} board is "
                             "not found in the plane image")
        try:
            scale = plane_scale(corners, camera.pattern, camera.square_m, camera=camera)
        except InputError as exc:
            raise InputError(f"{name}: {exc}") from None
    return CalibrationFile(camera=camera, scale=scale)
