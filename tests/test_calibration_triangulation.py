"""calibration.projective and calibration.triangulation against cameras built independently.

Truth the code did not make: pinhole cameras assembled here from K, R, t and imaged with
OpenCV's own ``cv2.projectPoints`` (lens distortion included); scipy's ``least_squares``
as the independent nonlinear triangulation; and two real multi-camera rigs calibrated by
other people (easyWand DLT with DLTdv7 points; OpenCV projection matrices with labelled
pixels), which run when ../shared is present.
"""

import ast
import configparser

import cv2
import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import least_squares

from calibration.errors import InputError
from calibration.projective import ProjectiveCamera
from calibration.triangulation import triangulate
from pinhole import look_at

K = np.array([[900.0, 0.0, 640.0], [0.0, 880.0, 360.0], [0.0, 0.0, 1.0]])
DIST = np.array([-0.25, 0.08, 0.001, -0.0005, -0.01])


def opencv_image(xyz, R, t, k=K, dist=DIST):
    """Observed pixels of world points, by OpenCV alone."""
    rvec, _ = cv2.Rodrigues(R)
    uv, _ = cv2.projectPoints(np.asarray(xyz, float).reshape(-1, 1, 3), rvec, t, k, dist)
    return uv.reshape(-1, 2)


def rig(angle_deg=90.0, distance_m=2.0, *, lens=True):
    """Two cameras ``angle_deg`` apart round the origin, and the means to image with them."""
    cams, params = [], []
    for j, az in enumerate((0.0, np.radians(angle_deg))):
        centre = distance_m * np.array([np.cos(az), np.sin(az), 0.3])
        R, t = look_at(centre)
        P = K @ np.hstack([R, t[:, None]])
        if lens:
            cams.append(ProjectiveCamera.from_projection(P, intrinsics=K, distortion=DIST,
                                                         name=f"cam{j + 1}"))
        else:
            cams.append(ProjectiveCamera(P, name=f"cam{j + 1}"))
        params.append((R, t))
    return cams, params


POINTS = np.array([[0.0, 0.0, 0.0], [0.3, -0.2, 0.5], [-0.4, 0.25, 0.1], [0.1, 0.4, -0.3],
                   [0.45, 0.45, 0.45]])


def test_projection_matches_opencv_with_distortion():
    cams, params = rig()
    for cam, (R, t) in zip(cams, params):
        np.testing.assert_allclose(cam.project(POINTS), opencv_image(POINTS, R, t), atol=1e-6)
        # undistorting the observed pixels gives P's ideal pixels
        np.testing.assert_allclose(cam.ideal(opencv_image(POINTS, R, t)),
                                   cam.project_ideal(POINTS), atol=1e-6)
        np.testing.assert_allclose(cam.centre, -R.T @ t, atol=1e-12)
        assert np.all(cam.depth(POINTS) > 0)


def test_new_camera_matrix_of_opencv_is_honoured():
    # P = K' [R | t] with K' from getOptimalNewCameraMatrix while the lens goes with K
    R, t = look_at([2.0, 0.5, 0.6])
    k_new, _ = cv2.getOptimalNewCameraMatrix(K, DIST, (1280, 720), 1.0)
    cam = ProjectiveCamera.from_projection(k_new @ np.hstack([R, t[:, None]]), intrinsics=K,
                                           distortion=DIST)
    np.testing.assert_allclose(cam.project(POINTS), opencv_image(POINTS, R, t), atol=1e-6)


@pytest.mark.parametrize("angle", [60.0, 90.0, 120.0])
def test_exact_pixels_give_the_points_back(angle):
    cams, params = rig(angle)
    uvs = [opencv_image(POINTS, R, t) for R, t in params]
    tri = triangulate(cams, uvs)
    np.testing.assert_allclose(tri.xyz, POINTS, atol=1e-7)
    assert np.nanmax(tri.residual_px) < 1e-5
    assert list(tri.views) == [2] * len(POINTS)


def test_minimises_the_reprojection_error_as_an_independent_solver_does():
    cams, params = rig(75.0, 1.5)
    rng = np.random.default_rng(4)
    pts = rng.uniform(-0.5, 0.5, (40, 3))
    uvs = [opencv_image(pts, R, t) + rng.normal(0, 3.0, (40, 2)) for R, t in params]
    tri = triangulate(cams, uvs)
    for i in range(len(pts)):
        def res(x, i=i):
            return np.concatenate([c.project(x[None])[0] - u[i] for c, u in zip(cams, uvs)])
        ref = least_squares(res, tri.linear_xyz[i], xtol=1e-14, ftol=1e-14, gtol=1e-14)
        ours = np.sum(res(tri.xyz[i]) ** 2)
        assert ours <= 2 * ref.cost * (1 + 1e-9) + 1e-12
        np.testing.assert_allclose(tri.xyz[i], ref.x, atol=1e-6)
    # and the linear start is worse: it minimises an algebraic error
    lin = np.array([[np.sum((c.project(tri.linear_xyz[i][None])[0] - u[i]) ** 2)
                     for c, u in zip(cams, uvs)] for i in range(len(pts))]).sum(axis=1)
    assert np.all(np.nansum(tri.residual_px ** 2, axis=1) <= lin + 1e-9)


def test_a_point_seen_once_is_not_triangulated():
    cams, params = rig(lens=False)
    uvs = [opencv_image(POINTS, R, t, dist=np.zeros(5)) for R, t in params]
    uvs[1][2] = np.nan
    tri = triangulate(cams, uvs)
    assert np.all(np.isnan(tri.xyz[2])) and tri.views[2] == 1
    assert np.isnan(tri.residual_px[2, 1])
    np.testing.assert_allclose(np.delete(tri.xyz, 2, axis=0), np.delete(POINTS, 2, axis=0),
                               atol=1e-7)


@settings(max_examples=40, deadline=None)
@given(st.floats(-0.6, 0.6), st.floats(-0.6, 0.6), st.floats(-0.6, 0.6),
       st.floats(40, 140), st.floats(1.0, 3.0))
def test_any_point_any_angle_round_trips(x, y, z, angle, distance):
    cams, params = rig(angle, distance, lens=False)
    p = np.array([[x, y, z]])
    tri = triangulate(cams, [opencv_image(p, R, t, dist=np.zeros(5)) for R, t in params])
    np.testing.assert_allclose(tri.xyz, p, atol=1e-7)


def test_dlt_and_bottom_left_pixels():
    # the same camera as an 11-parameter DLT with pixels counted up from the bottom edge
    R, t = look_at([0.4, -2.2, 0.8])
    P = K @ np.hstack([R, t[:, None]])
    height = 720
    flip = np.array([[1.0, 0, 0], [0, -1.0, height], [0, 0, 1.0]])
    Pb = flip @ P
    Pb = Pb / Pb[2, 3]
    L = np.concatenate([Pb[0], Pb[1], Pb[2, :3]])
    cam = ProjectiveCamera.from_dlt(L, pixel_origin="bottom-left")
    top = opencv_image(POINTS, R, t, dist=np.zeros(5))
    bottom = cam.from_image_pixels(top, height)
    np.testing.assert_allclose(bottom[:, 1], height - top[:, 1])
    np.testing.assert_allclose(cam.project(POINTS), bottom, atol=1e-6)
    assert np.all(cam.depth(POINTS) > 0)


@pytest.mark.parametrize("make, match", [
    (lambda: ProjectiveCamera(np.zeros((3, 4))), "singular"),
    (lambda: ProjectiveCamera(np.ones((2, 4))), "shape"),
    (lambda: ProjectiveCamera.from_dlt([1.0] * 10), "11 coefficients"),
    (lambda: ProjectiveCamera.from_dlt([np.nan] * 11), "finite"),
    (lambda: ProjectiveCamera(np.eye(3, 4), pixel_origin="centre"), "pixel_origin"),
    (lambda: ProjectiveCamera.from_projection(np.eye(3, 4), distortion=[0.1] * 5),
     "needs intrinsics"),
    (lambda: ProjectiveCamera.from_projection(np.eye(3, 4), intrinsics=np.eye(3) * 2),
     "intrinsics must be"),
    (lambda: ProjectiveCamera.from_projection(np.eye(3, 4), intrinsics=K, distortion=[0.1] * 3),
     "distortion must be"),
])
def test_bad_cameras_are_refused(make, match):
    with pytest.raises(InputError, match=match):
        make()


def test_bad_triangulation_input_is_refused():
    cams, _ = rig(lens=False)
    with pytest.raises(InputError, match="at least two cameras"):
        triangulate(cams[:1], [np.zeros((3, 2))])
    with pytest.raises(InputError, match="same number of points"):
        triangulate(cams, [np.zeros((3, 2)), np.zeros((4, 2))])


# ------------------------------------------------------------------ real rigs


def test_real_three_camera_dlt_rig(shared_dir):
    """easyWand DLT of three thermal cameras and DLTdv7 points of a thrown object (25 fps)."""
    d = shared_dir / "data" / "real" / "multicam3_dlt"
    L = np.loadtxt(d / "2018-08-17_wand_dltCoefs.csv", delimiter=",")
    pts = pd.read_csv(d / "DLTdv7_data_gravityxypts.csv")
    cams = [ProjectiveCamera.from_dlt(L[:, j], pixel_origin="bottom-left", name=f"cam{j + 1}")
            for j in range(3)]
    uvs = [pts[[f"pt1_cam{j + 1}_X", f"pt1_cam{j + 1}_Y"]].to_numpy() for j in range(3)]
    tri = triangulate(cams, uvs)
    ok = np.isfinite(tri.xyz[:, 0])
    assert np.flatnonzero(ok).tolist() == list(range(4, 30))      # 26 frames, 2+ views
    assert np.nanmedian(tri.residual_px[ok]) <= 1.2
    # a drag-free fit (a free acceleration vector) gives g along -z (z is up there)
    t = np.arange(len(pts))[ok] / 25.0
    coef, *_ = np.linalg.lstsq(np.column_stack([np.ones_like(t), t, t * t]), tri.xyz[ok],
                               rcond=None)
    accel = 2 * coef[2]
    assert 9.5 <= np.linalg.norm(accel) <= 10.5
    assert np.degrees(np.arccos(-accel[2] / np.linalg.norm(accel))) < 12


def badminton(shared_dir):
    d = shared_dir / "data" / "real" / "badminton_2cam"
    cams, uvs, centres = [], [], []
    for j in (1, 2):
        cfg = configparser.ConfigParser()
        cfg.read(d / f"CameraReader_{j}.cfg")
        o = {k: np.array(ast.literal_eval(v)) for k, v in cfg["Other"].items()}
        cams.append(ProjectiveCamera.from_projection(o["projection_mat"], intrinsics=o["ks"],
                                                     distortion=o["dist"].ravel(),
                                                     name=f"cam{j}"))
        E = o["extrinsic_mat"]
        centres.append(-E[:, :3].T @ E[:, 3])
        t = pd.read_csv(d / f"CameraReader_{j}.csv")
        uv = t[["X", "Y"]].to_numpy(float)
        uv[t["Visibility"].to_numpy() == 0] = np.nan
        uvs.append(uv)
    n = min(len(u) for u in uvs)
    return cams, [u[:n] for u in uvs], centres


def test_real_two_camera_rig_with_a_rough_calibration(shared_dir):
    cams, uvs, centres = badminton(shared_dir)
    # the centres of the projection matrices are those of the files' [R | t]
    for cam, centre in zip(cams, centres):
        np.testing.assert_allclose(cam.centre, centre, atol=1e-6)
    tri = triangulate(cams, uvs)
    ok = np.isfinite(tri.xyz[:, 0])
    assert ok.sum() == 1071                        # the frames both cameras labelled
    lin = np.stack([np.linalg.norm(c.project(tri.linear_xyz) - u, axis=1)
                    for c, u in zip(cams, uvs)], axis=1)
    nonlin = np.nanmedian(tri.residual_px[ok])
    # never worse than the linear solution; the rig's calibration and labels disagree by
    # some 16 px, and the two solutions place the points centimetres apart
    assert np.all(np.nansum(tri.residual_px[ok] ** 2, 1) <= np.nansum(lin[ok] ** 2, 1) + 1e-6)
    assert nonlin < np.nanmedian(lin[ok])
    assert 5 < nonlin < 30
    # the shuttlecock stays over the court and below the hall's roof
    assert np.nanmin(tri.xyz[ok, 2]) > -0.5 and np.nanmax(tri.xyz[ok, 2]) < 8
