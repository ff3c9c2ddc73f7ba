"""calibration.views: the orthographic mapping of the front and top views.

Truth: the world frame of SPEC.md (front sees X up-Y, top sees X and Z) worked by hand
for the SPEC example, and a pinhole camera square to the plane projected by OpenCV's
projectPoints (with lens distortion) for the calibrated mapping.
"""

import itertools

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from calibration import InputError
from calibration.camera import CameraCalibration
from calibration.views import ViewMapping, parse_axes, pixel_to_world, view_mapping, world_to_pixel

CAM = CameraCalibration(fx=900.0, fy=900.0, cx=512.0, cy=384.0,
                        dist_coeffs=(-0.2, 0.05, 0.0005, -0.0004, 0.0), image_size=(1024, 768))

#: Every valid axes pair for each view: column axis, row axis, both signs, both orders.
FRONT_AXES = [(f"{s}{a}", f"{t}{b}") for a, b in (("x", "y"), ("y", "x"))
              for s, t in itertools.product("+-", repeat=2)]
TOP_AXES = [(f"{s}{a}", f"{t}{b}") for a, b in (("x", "z"), ("z", "x"))
            for s, t in itertools.product("+-", repeat=2)]


def test_spec_front_example_by_hand():
    m = view_mapping(["+x", "-y"], [40.0, 330.0], 0.004)
    assert m.world_axes == ("x", "y")
    # 125 px right of the origin is 0.5 m out along X; 250 px up is 1 m up (+Y).
    world = m.pixel_to_world([[165.0, 330.0], [40.0, 80.0], [40.0, 330.0]])
    assert np.allclose(world, [[0.5, 0.0], [0.0, 1.0], [0.0, 0.0]], atol=1e-15)
    assert np.allclose(m.world_to_pixel([[0.5, -0.2]]), [[165.0, 380.0]])


def test_spec_top_example_by_hand():
    m = view_mapping(["+x", "+z"], [40.0, 300.0], 0.004)
    assert m.world_axes == ("x", "z")
    assert np.allclose(m.pixel_to_world([40.0, 550.0]), [0.0, 1.0])
    assert np.allclose(m.pixel_to_world([15.0, 300.0]), [-0.1, 0.0])


def test_rotated_camera_axes_order():
    # Column runs along -Y (camera on its side), row along +X: outputs stay (x, y).
    m = view_mapping(["-y", "+x"], [100.0, 100.0], 0.01)
    assert m.world_axes == ("x", "y")
    assert np.allclose(m.pixel_to_world([110.0, 130.0]), [0.3, -0.1])


@settings(max_examples=80, deadline=None)
@given(axes=st.sampled_from(FRONT_AXES + TOP_AXES),
       origin=st.tuples(st.floats(-2000, 3000), st.floats(-2000, 3000)),
       k=st.floats(1e-5, 1.0),
       pts=st.lists(st.tuples(st.floats(-5000, 5000), st.floats(-5000, 5000)),
                    min_size=1, max_size=30))
def test_pixel_world_pixel_round_trip(axes, origin, k, pts):
    m = view_mapping(axes, origin, k)
    uv = np.array(pts)
    back = m.world_to_pixel(m.pixel_to_world(uv))
    assert np.allclose(back, uv, rtol=0, atol=1e-9 * (1 + np.abs(uv).max()))


@settings(max_examples=60, deadline=None)
@given(axes=st.sampled_from(FRONT_AXES + TOP_AXES),
       k=st.floats(1e-4, 1e-2),
       pts=st.lists(st.tuples(st.floats(0, 1023), st.floats(0, 767)), min_size=1, max_size=30))
def test_round_trip_through_lens_distortion(axes, k, pts):
    m = view_mapping(axes, (300.0, 400.0), k, camera=CAM)
    uv = np.array(pts)
    back = m.world_to_pixel(m.pixel_to_world(uv))
    assert np.max(np.abs(back - uv)) < 1e-6


@settings(max_examples=60, deadline=None)
@given(axes=st.sampled_from(FRONT_AXES), k=st.floats(1e-4, 1.0),
       w=st.lists(st.tuples(st.floats(-50, 50), st.floats(-50, 50)), min_size=1, max_size=20))
def test_world_pixel_world_round_trip(axes, k, w):
    m = view_mapping(axes, (12.5, -7.0), k)
    world = np.array(w)
    assert np.allclose(m.pixel_to_world(m.world_to_pixel(world)), world, atol=1e-9)


def _square_camera_projection(view, depth_m, centre_m, world_pts):
    """Observed pixels of plane points through CAM looking square at the view's plane.

    front: camera x = +X, camera y (down) = -Y, optical axis = -Z, at Z = depth.
    top:   camera x = +X, camera y (down) = +Z, optical axis = -Y, at Y = depth.
    """
    if view == "front":
        R = np.array([[1, 0, 0], [0, -1, 0], [0, 0, -1]], dtype=float)   # world -> camera
        p3 = np.column_stack([world_pts[:, 0], world_pts[:, 1], np.zeros(len(world_pts))])
        c = np.array([centre_m[0], centre_m[1], depth_m])
    else:
        R = np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0]], dtype=float)
        p3 = np.column_stack([world_pts[:, 0], np.zeros(len(world_pts)), world_pts[:, 1]])
        c = np.array([centre_m[0], depth_m, centre_m[1]])
    rvec, _ = cv2.Rodrigues(R)
    tvec = -R @ c
    img, _ = cv2.projectPoints(p3, rvec, tvec, CAM.camera_matrix, CAM.dist_array)
    return img.reshape(-1, 2)


@pytest.mark.parametrize("view,axes", [("front", ("+x", "-y")), ("top", ("+x", "+z"))])
def test_calibrated_mapping_recovers_world_points(view, axes):
    rng = np.random.default_rng(7)
    depth, centre = 2.0, (0.6, 0.3)
    world = rng.uniform([-0.2, -0.4], [1.4, 1.0], size=(200, 2))
    observed = _square_camera_projection(view, depth, centre, world)
    origin = _square_camera_projection(view, depth, centre, np.zeros((1, 2)))[0]
    m = view_mapping(axes, origin, depth / CAM.fx, camera=CAM)
    assert np.max(np.abs(m.pixel_to_world(observed) - world)) < 1e-9
    assert np.max(np.abs(m.world_to_pixel(world) - observed)) < 1e-6
    # Ignoring the lens costs centimetres at the frame's edge: the camera matters.
    flat = view_mapping(axes, origin, depth / CAM.fx)
    assert np.max(np.abs(flat.pixel_to_world(observed) - world)) > 0.01


def test_nan_rows_and_shapes():
    m = view_mapping(["+x", "-y"], [0, 0], 0.01)
    out = m.pixel_to_world([[1.0, 2.0], [np.nan, 3.0]])
    assert out.shape == (2, 2) and np.all(np.isnan(out[1])) and np.all(np.isfinite(out[0]))
    assert m.pixel_to_world([1.0, 2.0]).shape == (2,)
    assert np.allclose(pixel_to_world([[1.0, 2.0]], m), [[0.01, -0.02]])
    assert np.allclose(world_to_pixel([[0.01, -0.02]], m), [[1.0, 2.0]])
    with pytest.raises(InputError, match=r"\(N, 2\)"):
        m.pixel_to_world(np.zeros((4, 3)))


@pytest.mark.parametrize("axes,message", [
    (["+x", "+x"], "two different world axes"),
    (["+x", "-x"], "two different world axes"),
    (["+x", "up"], "two of"),
    (["+x"], "two of"),
    ("+x-y", "two of"),
    ([1, 2], "two of"),
])
def test_bad_axes(axes, message):
    with pytest.raises(InputError, match=message):
        parse_axes(axes)


@pytest.mark.parametrize("origin,k,message", [
    ((0, 0), 0.0, "m_per_px must be a finite number > 0"),
    ((0, 0), -1.0, "m_per_px"),
    ((0, 0), float("nan"), "m_per_px"),
    ((0,), 0.01, "origin_px must be two finite numbers"),
    ((0, float("inf")), 0.01, "origin_px"),
])
def test_bad_mapping(origin, k, message):
    with pytest.raises(InputError, match=message):
        ViewMapping(axes=("+x", "-y"), origin_px=origin, m_per_px=k)


def test_axes_case_and_to_dict():
    m = view_mapping(["+X", "-Y"], [1, 2], 0.5)
    assert m.axes == ("+x", "-y")
    assert m.to_dict() == {"axes": ["+x", "-y"], "origin_px": [1.0, 2.0], "m_per_px": 0.5,
                           "world_axes": ["x", "y"]}
