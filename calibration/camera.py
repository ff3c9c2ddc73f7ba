"""Checkerboard camera calibration through OpenCV, lens (un)distortion, calibration files.

A lab films a printed checkerboard from several poses; :func:`calibrate_checkerboard`
finds its inner corners (``cv2.findChessboardCorners`` refined by ``cv2.cornerSubPix``)
and estimates the pinhole intrinsics and the Brown-Conrady distortion
(``cv2.calibrateCamera``), reporting the reprojection error overall and per image.
With one more image of the board lying in the throw plane, the metric scale of that
plane (m per pixel) follows (:func:`plane_scale`).

:func:`undistort_points` takes observed (distorted) pixel positions to where an ideal
pinhole camera with the same camera matrix would have seen them; :func:`distort_points`
is its inverse. Calibration files (TOML, schema 1) are written by
:func:`calibration_to_toml` and read by :func:`load_calibration`; the format is
documented in ``docs/calibration.md``.
"""

import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from calibration.errors import InputError
from calibration.scale import Scale, _point_array, check_m_per_px, ruler_scale

__all__ = [
    "CameraCalibration", "CalibrationFile", "calibrate_checkerboard",
    "checkerboard_calibration", "find_board",
    "board_points", "plane_scale", "undistort_points", "distort_points",
    "calibration_to_toml", "calibration_to_dict", "load_calibration", "parse_calibration",
    "read_calibration_images", "parse_pattern", "compact_toml", "CALIBRATION_SCHEMA",
]

#: Version of the calibration file format written and read here.
CALIBRATION_SCHEMA = 1

#: Image file extensions a calibration folder is searched for.
IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".pgm", ".ppm")

_DIST_LENGTHS = (4, 5, 8, 12, 14)


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


@dataclass(frozen=True)
class CalibrationFile:
    """The content of a calibration file: a camera, a plane scale, or both.

    Attributes
    ----------
    camera : CameraCalibration or None
        Intrinsics and distortion (``[camera]``).
    scale : Scale or None
        Metric scale of the throw plane (``[scale]``).
    path : pathlib.Path or None
        The file it was read from.
    """

    camera: CameraCalibration | None = None
    scale: Scale | None = None
    path: Path | None = field(default=None, compare=False)

    def to_dict(self):
        """The file's content as a dict (``schema``, ``[camera]``, ``[scale]``)."""
        return calibration_to_dict(camera=self.camera, scale=self.scale)


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


# --------------------------------------------------------------------------- images


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


# --------------------------------------------------------------------------- files


def calibration_to_dict(*, camera=None, scale=None):
    """The content of a calibration file (schema 1) as a dict.

    Parameters
    ----------
    camera : CameraCalibration, optional
    scale : Scale, optional
        At least one of the two.

    Returns
    -------
    dict
        ``{"schema": 1, "camera": {...}, "scale": {...}}`` (absent parts left out).
    """
    if camera is None and scale is None:
        raise InputError("a calibration file needs a camera, a scale, or both")
    out = {"schema": CALIBRATION_SCHEMA}
    if scale is not None:
        out["scale"] = scale.to_dict()
    if camera is not None:
        out["camera"] = camera.to_dict()
    return out


_ARRAY_RE = re.compile(r"\[\n((?:[ ]+[^\[\]{}\n]*,\n)+)[ ]*\]")


def compact_toml(text):
    """Put tomli_w's one-item-per-line arrays of plain values on one line.

    The result is checked to parse to the same content; if it would not, the text is
    returned unchanged.
    """
    def join(m):
        items = [line.strip().rstrip(",") for line in m.group(1).splitlines()]
        return "[" + ", ".join(items) + "]"

    compact = _ARRAY_RE.sub(join, text)
    try:
        same = tomllib.loads(compact) == tomllib.loads(text)
    except tomllib.TOMLDecodeError:
        same = False
    return compact if same else text


def calibration_to_toml(*, camera=None, scale=None):
    """A calibration file's text (TOML, schema 1); write it with an atomic writer.

    Parameters
    ----------
    camera : CameraCalibration, optional
    scale : Scale, optional

    Returns
    -------
    str
        TOML text that :func:`load_calibration` reads back to the same values.
    """
    import tomli_w

    head = ("# vidtrack calibration file (schema 1); see docs/calibration.md\n"
            "# [scale]: metres per pixel on the throw plane; [camera]: intrinsics and\n"
            "# distortion (OpenCV model, pixels).\n")
    return head + compact_toml(tomli_w.dumps(calibration_to_dict(camera=camera, scale=scale)))


def _num(d, key, where, *, positive=False, nonneg=False, required=True):
    if key not in d:
        if required:
            raise InputError(f"{where}{key} is required")
        return None
    v = d[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise InputError(f"{where}{key} must be a finite number, got {v!r}")
    if positive and not v > 0:
        raise InputError(f"{where}{key} must be > 0, got {v!r}")
    if nonneg and not v >= 0:
        raise InputError(f"{where}{key} must be >= 0, got {v!r}")
    return float(v)


def _num_list(d, key, where, *, length=None, lengths=None, integer=False, required=True):
    if key not in d:
        if required:
            raise InputError(f"{where}{key} is required")
        return None
    v = d[key]
    want = (f"{length} " if length else "") + ("integers" if integer else "numbers")
    if not isinstance(v, list) or any(isinstance(x, bool) or not isinstance(x, (int, float))
                                      or not math.isfinite(x) for x in v):
        raise InputError(f"{where}{key} must be a list of {want}, got {v!r}")
    if integer and any(not isinstance(x, int) for x in v):
        raise InputError(f"{where}{key} must be a list of {want}, got {v!r}")
    if length is not None and len(v) != length:
        raise InputError(f"{where}{key} must be a list of {want}, got {len(v)}: {v!r}")
    if lengths is not None and len(v) not in lengths:
        raise InputError(f"{where}{key} must have {', '.join(map(str, lengths))} values "
                         f"(OpenCV's distortion models), got {len(v)}")
    return tuple(int(x) if integer else float(x) for x in v)


def _str_list(d, key, where):
    v = d.get(key, [])
    if not isinstance(v, list) or any(not isinstance(x, str) for x in v):
        raise InputError(f"{where}{key} must be a list of strings, got {v!r}")
    return tuple(v)


def _check_keys(d, allowed, where):
    unknown = sorted(set(d) - set(allowed))
    if unknown:
        raise InputError(f"{where}{unknown[0]} is not a known key (expected one of: "
                         f"{', '.join(sorted(allowed))})")


def parse_calibration(data, *, name="calibration file"):
    """Validate a calibration file's parsed content.

    Parameters
    ----------
    data : dict
        As ``tomllib`` reads it.
    name : str
        The file's name, for messages (``front.toml: camera.fx must be > 0, got 0``).

    Returns
    -------
    CalibrationFile

    Raises
    ------
    InputError
        Unknown or missing keys, wrong types, impossible values.
    """
    pre = f"{name}: "
    if not isinstance(data, dict):
        raise InputError(f"{pre}expected a TOML table")
    _check_keys(data, {"schema", "scale", "camera"}, pre)
    if "schema" not in data:
        raise InputError(f"{pre}schema is required (schema = {CALIBRATION_SCHEMA})")
    if data["schema"] != CALIBRATION_SCHEMA or isinstance(data["schema"], bool):
        raise InputError(f"{pre}schema must be {CALIBRATION_SCHEMA}, got {data['schema']!r}")
    if "scale" not in data and "camera" not in data:
        raise InputError(f"{pre}needs a [scale] table, a [camera] table, or both")
    scale = camera = None
    if "scale" in data:
        s = data["scale"]
        w = pre + "scale."
        if not isinstance(s, dict):
            raise InputError(f"{w[:-1]} must be a table, got {s!r}")
        _check_keys(s, {"method", "m_per_px", "length_m", "from_px", "to_px", "span_px"}, w)
        method = s.get("method", "given")
        if method not in ("ruler", "given", "checkerboard"):
            raise InputError(f"{w}method must be one of 'ruler', 'given', 'checkerboard', "
                             f"got {method!r}")
        m = _num(s, "m_per_px", w, positive=True)
        if method == "ruler":
            length = _num(s, "length_m", w, positive=True)
            fr = _num_list(s, "from_px", w, length=2)
            to = _num_list(s, "to_px", w, length=2)
            try:
                scale = ruler_scale(length, fr, to)
            except InputError as exc:
                raise InputError(f"{w[:-1]}: {exc}") from None
            if not math.isclose(scale.m_per_px, m, rel_tol=1e-9):
                raise InputError(f"{w}m_per_px = {m!r} disagrees with length_m / span of "
                                 f"from_px..to_px = {scale.m_per_px!r}")
        else:
            extra = sorted({"length_m", "from_px", "to_px", "span_px"} & set(s))
            if extra:
                raise InputError(f"{w}{extra[0]} applies only to method = 'ruler'")
            try:
                scale = Scale(m_per_px=check_m_per_px(m), method=method)
            except InputError as exc:
                raise InputError(f"{w}{exc}") from None
    if "camera" in data:
        c = data["camera"]
        w = pre + "camera."
        if not isinstance(c, dict):
            raise InputError(f"{w[:-1]} must be a table, got {c!r}")
        _check_keys(c, {"fx", "fy", "cx", "cy", "dist_coeffs", "image_size", "rms_px",
                        "images", "per_image_rms_px", "rejected", "pattern", "square_m"}, w)
        images = _str_list(c, "images", w)
        per = _num_list(c, "per_image_rms_px", w, required=False) or ()
        if len(per) != len(images):
            raise InputError(f"{w}per_image_rms_px has {len(per)} values for "
                             f"{len(images)} images")
        size = _num_list(c, "image_size", w, length=2, integer=True, required=False)
        if size is not None and min(size) <= 0:
            raise InputError(f"{w}image_size must be two integers > 0, got {list(size)}")
        pattern = _num_list(c, "pattern", w, length=2, integer=True, required=False)
        if pattern is not None and min(pattern) < 2:
            raise InputError(f"{w}pattern must be two integers >= 2, got {list(pattern)}")
        camera = CameraCalibration(
            fx=_num(c, "fx", w, positive=True), fy=_num(c, "fy", w, positive=True),
            cx=_num(c, "cx", w), cy=_num(c, "cy", w),
            dist_coeffs=_num_list(c, "dist_coeffs", w, lengths=_DIST_LENGTHS),
            image_size=size, rms_px=_num(c, "rms_px", w, nonneg=True, required=False),
            per_image_rms_px=per, images=images, rejected=_str_list(c, "rejected", w),
            pattern=pattern, square_m=_num(c, "square_m", w, positive=True, required=False),
        )
    return CalibrationFile(camera=camera, scale=scale)


def load_calibration(path):
    """Read and validate a calibration file (TOML, schema 1).

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    CalibrationFile

    Raises
    ------
    InputError
        Missing or unreadable file, invalid TOML (with line), any bad key or value
        (named with the file and the key).
    """
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8")
    except FileNotFoundError:
        raise InputError(f"{path}: no such calibration file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read the calibration file ({exc})") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML: {exc}") from None
    parsed = parse_calibration(data, name=path.name)
    return CalibrationFile(camera=parsed.camera, scale=parsed.scale, path=path)
