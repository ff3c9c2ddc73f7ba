"""calibration.camera, .checkerboard and .calibration_file against rendered checkerboards.

Truth: tests/checkerboard_render.py renders the board through intrinsics and
distortion we chose (TRUE_K, TRUE_D) from known poses; OpenCV's projectPoints gives
the exact corner pixels. The code under test never sees the truth.
"""

import math

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from calibration import InputError
from calibration.calibration_file import calibration_to_toml, load_calibration
from calibration.camera import CameraCalibration, distort_points, undistort_points
from calibration.checkerboard import (
    calibrate_checkerboard,
    checkerboard_calibration,
    find_board,
    parse_pattern,
    plane_scale,
)
from calibration.scale import ruler_scale
from checkerboard_render import (
    PATTERN,
    PLANE_POSE,
    POSES,
    SIZE,
    SQUARE_M,
    TRUE_D,
    TRUE_K,
    render_board,
    true_corners,
)

TRUE_CAM = CameraCalibration(fx=TRUE_K[0, 0], fy=TRUE_K[1, 1], cx=TRUE_K[0, 2],
                             cy=TRUE_K[1, 2], dist_coeffs=tuple(TRUE_D), image_size=SIZE)


@pytest.fixture(scope="module")
def board_images():
    return [render_board(TRUE_K, TRUE_D, r, t, SIZE, PATTERN, SQUARE_M) for r, t in POSES]


@pytest.fixture(scope="module")
def plane_image():
    r, t = PLANE_POSE
    return render_board(TRUE_K, TRUE_D, r, t, SIZE, PATTERN, SQUARE_M)


@pytest.fixture(scope="module")
def calibrated(board_images):
    return calibrate_checkerboard(board_images, PATTERN, SQUARE_M)


def _image_grid(n=15):
    u, v = np.meshgrid(np.linspace(0, SIZE[0] - 1, n), np.linspace(0, SIZE[1] - 1, n))
    return np.column_stack([u.ravel(), v.ravel()])


# ----------------------------------------------------------------- corners and fit


def test_corners_found_to_sub_pixel_accuracy(board_images):
    errs = []
    for (r, t), img in zip(POSES, board_images):
        found = find_board(img, PATTERN)
        assert found is not None
        errs.append(found - true_corners(TRUE_K, TRUE_D, r, t, PATTERN, SQUARE_M))
    e = np.concatenate(errs)
    rms = math.sqrt(np.mean(np.sum(e ** 2, axis=1)))
    assert rms < 0.1, rms                       # measured 0.05 px
    assert np.max(np.abs(e.mean(axis=0))) < 0.02  # no systematic offset


def test_intrinsics_recovered(calibrated):
    cam = calibrated
    assert cam.fx == pytest.approx(TRUE_K[0, 0], rel=2e-3)   # measured 0.04 %
    assert cam.fy == pytest.approx(TRUE_K[1, 1], rel=2e-3)
    assert cam.cx == pytest.approx(TRUE_K[0, 2], abs=1.0)    # px; measured 0.07
    assert cam.cy == pytest.approx(TRUE_K[1, 2], abs=1.0)
    assert cam.image_size == SIZE
    assert len(cam.images) == len(POSES) and cam.rejected == ()


def test_distortion_recovered_as_a_mapping(calibrated):
    # Coefficients trade off (k2 against k3); the mapping they define must match.
    ideal = _image_grid()
    true_obs = distort_points(ideal, TRUE_CAM)
    inside = np.all((true_obs >= 0) & (true_obs <= np.array(SIZE) - 1), axis=1)
    got_obs = distort_points(ideal[inside], calibrated)
    diff = np.linalg.norm(got_obs - true_obs[inside], axis=1)
    assert diff.max() < 1.0, diff.max()          # px, whole frame; measured 0.41
    assert np.sqrt(np.mean(diff ** 2)) < 0.3     # measured 0.08


def test_distortion_coefficients_with_k3_fixed(board_images):
    cam = calibrate_checkerboard(board_images, PATTERN, SQUARE_M, fix_k3=True)
    k1, k2, p1, p2, k3 = cam.dist_coeffs
    assert k3 == 0.0
    assert k1 == pytest.approx(TRUE_D[0], abs=0.01)
    # k2 is the least constrained (the boards do not reach the frame's corners):
    # measured 0.083 against 0.06.
    assert k2 == pytest.approx(TRUE_D[1], abs=0.03)
    assert p1 == pytest.approx(TRUE_D[2], abs=5e-4)
    assert p2 == pytest.approx(TRUE_D[3], abs=5e-4)


def test_reprojection_error_reported(calibrated):
    cam = calibrated
    assert cam.rms_px < 0.1, cam.rms_px          # measured 0.05 px
    assert len(cam.per_image_rms_px) == len(POSES)
    assert all(0 < e < 0.15 for e in cam.per_image_rms_px)
    # Overall RMS is the corner-weighted mean of the per-image ones (same corner count).
    assert cam.rms_px == pytest.approx(math.sqrt(np.mean(np.square(cam.per_image_rms_px))),
                                       rel=1e-9)


def test_bad_image_is_rejected_not_fatal(board_images):
    blank = np.full_like(board_images[0], 128)
    cam = calibrate_checkerboard([*board_images[:4], blank], PATTERN, SQUARE_M)
    assert cam.rejected == ("image 4",)
    assert len(cam.images) == 4


def test_sixteen_bit_images(board_images):
    imgs16 = [img.astype(np.uint16) * 257 for img in board_images[:4]]
    found = find_board(imgs16[0], PATTERN)
    r, t = POSES[0]
    e = found - true_corners(TRUE_K, TRUE_D, r, t, PATTERN, SQUARE_M)
    assert np.sqrt(np.mean(np.sum(e ** 2, axis=1))) < 0.1


# ----------------------------------------------------------------- (un)distortion


def test_undistort_matches_the_pinhole_projection():
    # Truth: the same 3-D corners projected with and without distortion by OpenCV.
    r, t = POSES[3]
    observed = true_corners(TRUE_K, TRUE_D, r, t, PATTERN, SQUARE_M)
    ideal = true_corners(TRUE_K, np.zeros(5), r, t, PATTERN, SQUARE_M)
    assert np.max(np.abs(undistort_points(observed, TRUE_CAM) - ideal)) < 1e-6
    assert np.max(np.abs(distort_points(ideal, TRUE_CAM) - observed)) < 1e-9


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(0, SIZE[0] - 1), st.floats(0, SIZE[1] - 1)),
                min_size=1, max_size=20))
def test_undistort_distort_round_trip(points):
    uv = np.array(points, dtype=np.float64)
    back = distort_points(undistort_points(uv, TRUE_CAM), TRUE_CAM)
    assert np.max(np.abs(back - uv)) < 1e-6


def test_points_shapes_and_nan():
    one = undistort_points([100.0, 200.0], TRUE_CAM)
    assert one.shape == (2,)
    many = undistort_points([[100.0, 200.0], [np.nan, 1.0]], TRUE_CAM)
    assert many.shape == (2, 2) and np.all(np.isnan(many[1]))
    assert np.allclose(many[0], one)
    with pytest.raises(InputError, match=r"\(N, 2\)"):
        undistort_points(np.zeros((3, 3)), TRUE_CAM)


# ----------------------------------------------------------------- plane scale


def test_plane_scale_of_a_board_in_the_throw_plane(calibrated, plane_image):
    # A plane parallel to the image at depth Z is imaged (after undistortion) at
    # f / Z pixels per metre: the truth is Z / f metres per pixel.
    truth = PLANE_POSE[1][2] / TRUE_K[0, 0]
    corners = find_board(plane_image, PATTERN)
    scale = plane_scale(corners, PATTERN, SQUARE_M, camera=calibrated)
    assert scale.method == "checkerboard"
    assert scale.m_per_px == pytest.approx(truth, rel=3e-3)   # measured 0.01 %
    # Without undistortion the wide lens shrinks the squares: the scale is off.
    raw = plane_scale(corners, PATTERN, SQUARE_M, camera=None, max_spread=1.0)
    assert abs(raw.m_per_px / truth - 1) > 3e-3


def test_plane_scale_refuses_a_tilted_board(board_images, calibrated):
    corners = find_board(board_images[1], PATTERN)    # tilted 0.35 rad
    with pytest.raises(InputError, match="not parallel to the image plane"):
        plane_scale(corners, PATTERN, SQUARE_M, camera=calibrated)


def test_checkerboard_calibration_with_plane(board_images, plane_image):
    result = checkerboard_calibration(board_images, PATTERN, SQUARE_M, plane_image=plane_image)
    assert result.camera.rms_px < 0.1
    assert result.scale.m_per_px == pytest.approx(PLANE_POSE[1][2] / TRUE_K[0, 0], rel=3e-3)


# ----------------------------------------------------------------- files


def test_calibration_file_round_trip(tmp_path, calibrated):
    scale = ruler_scale(0.5, (80, 482), (205, 482))
    path = tmp_path / "front.toml"
    path.write_text(calibration_to_toml(camera=calibrated, scale=scale))
    back = load_calibration(path)
    assert back.camera == calibrated
    assert back.scale == scale
    assert back.path == path


def test_calibration_file_camera_only(tmp_path):
    path = tmp_path / "cam.toml"
    path.write_text(calibration_to_toml(camera=TRUE_CAM))
    back = load_calibration(path)
    assert back.scale is None and back.camera == TRUE_CAM


BAD_FILES = [
    ("schema = 2\n[scale]\nm_per_px = 0.1\n", "schema must be 1"),
    ("[scale]\nm_per_px = 0.1\n", "schema is required"),
    ("schema = 1\n", r"needs a \[scale\] table, a \[camera\] table"),
    ("schema = 1\ncolour = 1\n[scale]\nm_per_px = 0.1\n", "colour is not a known key"),
    ("schema = 1\n[scale]\nm_per_px = 0\n", "scale.m_per_px must be > 0, got 0"),
    ("schema = 1\n[scale]\nm_per_px = 'x'\n", "scale.m_per_px must be a finite number"),
    ("schema = 1\n[scale]\nmethod = 'tape'\nm_per_px = 0.1\n", "scale.method must be one of"),
    ("schema = 1\n[scale]\nmethod = 'ruler'\nm_per_px = 0.1\nlength_m = 0.5\n"
     "from_px = [0, 0]\nto_px = [100, 0]\n", "disagrees with length_m"),
    ("schema = 1\n[camera]\nfx = 0\nfy = 800\ncx = 1\ncy = 1\ndist_coeffs = [0, 0, 0, 0]\n",
     "camera.fx must be > 0, got 0"),
    ("schema = 1\n[camera]\nfx = 800\nfy = 800\ncx = 1\ncy = 1\ndist_coeffs = [0, 0, 0]\n",
     "camera.dist_coeffs must have 4, 5, 8, 12, 14 values"),
    ("schema = 1\n[camera]\nfx = 800\nfy = 800\ncx = 1\ndist_coeffs = [0, 0, 0, 0]\n",
     "camera.cy is required"),
    ("schema = 1\n[camera]\nfx = 800\nfy = 800\ncx = 1\ncy = 1\ndist_coeffs = [0, 0, 0, 0]\n"
     "fz = 3\n", "camera.fz is not a known key"),
    ("schema = 1\n[scale\n", "not valid TOML"),
]


@pytest.mark.parametrize("text,message", BAD_FILES)
def test_bad_calibration_files(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(InputError, match=message) as info:
        load_calibration(path)
    assert "bad.toml" in str(info.value)


def test_missing_calibration_file(tmp_path):
    with pytest.raises(InputError, match="no such calibration file"):
        load_calibration(tmp_path / "nope.toml")


# ----------------------------------------------------------------- bad input


def test_bad_inputs(tmp_path, board_images):
    with pytest.raises(InputError, match="found in 1 of 1 images; at least 3"):
        calibrate_checkerboard(board_images[:1], PATTERN, SQUARE_M)
    with pytest.raises(InputError, match="must all be one size"):
        calibrate_checkerboard([board_images[0], board_images[1][:400]], PATTERN, SQUARE_M)
    with pytest.raises(InputError, match="square_m must be a number > 0"):
        calibrate_checkerboard(board_images, PATTERN, 0)
    with pytest.raises(InputError, match="no image files"):
        calibrate_checkerboard(tmp_path, PATTERN, SQUARE_M)
    (tmp_path / "junk.png").write_bytes(b"not a png")
    with pytest.raises(InputError, match="junk.png: not an image"):
        calibrate_checkerboard(tmp_path, PATTERN, SQUARE_M)
    with pytest.raises(InputError, match="no such image file"):
        calibrate_checkerboard([tmp_path / "missing.png"], PATTERN, SQUARE_M)


def test_folder_in_natural_order(tmp_path, board_images):
    for k, img in enumerate(board_images[:4]):
        cv2.imwrite(str(tmp_path / f"b{[10, 2, 1, 33][k]}.png"), img)
    cam = calibrate_checkerboard(tmp_path, PATTERN, SQUARE_M)
    assert [p.rsplit("/", 1)[-1] for p in cam.images] == ["b1.png", "b2.png", "b10.png",
                                                           "b33.png"]


@pytest.mark.parametrize("text", ["9", "9x", "1x6", "axb", "9x6x2"])
def test_bad_patterns(text):
    with pytest.raises(InputError, match="pattern"):
        parse_pattern(text)


def test_pattern_parsing():
    assert parse_pattern("9x6") == (9, 6)
    assert parse_pattern(" 7X5 ") == (7, 5)
    assert parse_pattern((4, 3)) == (4, 3)
