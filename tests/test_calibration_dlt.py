"""calibration.dlt: the 11-parameter DLT against known pinhole cameras.

Truth: projection matrices P = K [R | t] built from chosen intrinsics and poses, and
3-D points we chose; the estimator only sees the points and their projections.
"""

import cv2
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from calibration import InputError
from calibration.dlt import DLT, estimate_dlt, project, reconstruct_with_known, triangulate


def camera_matrix(f, cx, cy, rvec, centre):
    """P = K [R | -R c] for a camera at ``centre`` (m) with rotation vector ``rvec``."""
    K = np.array([[f, 0, cx], [0, f * 1.01, cy], [0, 0, 1.0]])
    R, _ = cv2.Rodrigues(np.asarray(rvec, dtype=float))
    return K @ np.column_stack([R, -R @ np.asarray(centre, dtype=float)])


def looking_at(target, eye):
    """Rotation vector of a camera at ``eye`` whose optical axis points at ``target``."""
    z = np.asarray(target, float) - np.asarray(eye, float)
    z /= np.linalg.norm(z)
    up = np.array([0.0, 1.0, 0.0]) if abs(z[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(up, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    rvec, _ = cv2.Rodrigues(np.vstack([x, y, z]))
    return rvec.ravel()


def apply(P, X):
    h = np.column_stack([X, np.ones(len(X))]) @ P.T
    return h[:, :2] / h[:, 2:]


VOLUME = ([-0.2, -0.5, -0.5], [1.5, 1.2, 0.5])   # a throw's space, m


def random_points(rng, n):
    return rng.uniform(*VOLUME, size=(n, 3))


camera_poses = st.tuples(
    st.floats(600, 2000),                                  # focal length, px
    st.floats(-40, 40), st.floats(-40, 40),                # principal point offset
    st.floats(2.0, 6.0),                                   # distance from the volume, m
    st.floats(-1.2, 1.2), st.floats(-0.6, 0.6),            # azimuth, elevation, rad
)


def build(pose):
    f, dx, dy, dist, az, el = pose
    target = np.array([0.65, 0.35, 0.0])
    eye = target + dist * np.array([np.sin(az) * np.cos(el), np.sin(el), np.cos(az) * np.cos(el)])
    return camera_matrix(f, 640 + dx, 512 + dy, looking_at(target, eye), eye)


@settings(max_examples=40, deadline=None)
@given(pose=camera_poses, seed=st.integers(0, 2**32 - 1), n=st.integers(6, 40))
def test_dlt_recovers_a_known_projection(pose, seed, n):
    rng = np.random.default_rng(seed)
    P = build(pose)
    X = random_points(rng, n)
    sv = np.linalg.svd(X - X.mean(axis=0), compute_uv=False)
    assume(sv[-1] > 0.05 * sv[0])                         # well spread in depth
    dlt = estimate_dlt(X, apply(P, X))
    assert dlt.n_points == n and dlt.rms_px < 1e-6
    Y = random_points(rng, 50)                            # points it never saw
    assert np.max(np.abs(dlt.project(Y) - apply(P, Y))) < 1e-5
    # The same camera up to scale: P / P[2, 3].
    assert np.allclose(dlt.matrix, P / P[2, 3], rtol=1e-6, atol=1e-9 * np.abs(P / P[2, 3]).max())


@settings(max_examples=40, deadline=None)
@given(a=camera_poses, b=camera_poses, seed=st.integers(0, 2**32 - 1))
def test_two_view_triangulation(a, b, seed):
    assume(abs(a[4] - b[4]) + abs(a[5] - b[5]) > 0.5)      # views at least ~30 deg apart
    rng = np.random.default_rng(seed)
    Pa, Pb = build(a), build(b)
    X = random_points(rng, 12)
    da, db = estimate_dlt(X, apply(Pa, X)), estimate_dlt(X, apply(Pb, X))
    Y = random_points(rng, 30)
    got = triangulate([da, db], [apply(Pa, Y), apply(Pb, Y)])
    assert np.max(np.abs(got - Y)) < 1e-6


@settings(max_examples=40, deadline=None)
@given(pose=camera_poses, seed=st.integers(0, 2**32 - 1), axis=st.sampled_from("xyz"))
def test_one_view_with_a_known_coordinate(pose, seed, axis):
    rng = np.random.default_rng(seed)
    P = build(pose)
    X = random_points(rng, 10)
    dlt = estimate_dlt(X, apply(P, X))
    Y = random_points(rng, 30)
    k = "xyz".index(axis)
    got = reconstruct_with_known(dlt, apply(P, Y), axis, Y[:, k])
    ok = np.all(np.isfinite(got), axis=1)
    assert ok.mean() > 0.9     # rays nearly parallel to the known plane give NaN
    assert np.max(np.abs(got[ok] - Y[ok])) < 1e-5


def test_noisy_calibration_and_triangulation():
    # 0.3 px of pixel noise on 20 calibration points 3 m away: millimetres in 3-D.
    rng = np.random.default_rng(3)
    Pa = build((1200, 0, 0, 3.0, 0.6, 0.2))
    Pb = build((1200, 0, 0, 3.0, -0.7, 0.1))
    X = random_points(rng, 20)
    da = estimate_dlt(X, apply(Pa, X) + rng.normal(0, 0.3, (20, 2)))
    db = estimate_dlt(X, apply(Pb, X) + rng.normal(0, 0.3, (20, 2)))
    assert 0.1 < da.rms_px < 0.5
    Y = random_points(rng, 200)
    got = triangulate([da, db], [apply(Pa, Y) + rng.normal(0, 0.3, (200, 2)),
                                 apply(Pb, Y) + rng.normal(0, 0.3, (200, 2))])
    err = np.linalg.norm(got - Y, axis=1)
    assert np.sqrt(np.mean(err ** 2)) < 0.005                        # m


def test_front_and_top_views_as_dlt_cameras():
    # The two SPEC cameras, but not square to the axes (tilted 10 deg): the two-view
    # reconstruction gives X, Y and Z of a straw; the front alone with Z known too.
    rng = np.random.default_rng(5)
    front = camera_matrix(1000, 640, 512, looking_at([0.6, 0.3, 0], [0.6, 0.3, 4.0])
                          + np.array([0.17, 0, 0]), [0.6, 0.3, 4.0])
    top = camera_matrix(1000, 640, 512, looking_at([0.6, 0.0, 0.0], [0.6, 4.0, 0.0])
                        + np.array([0, 0, 0.17]), [0.6, 4.0, 0.0])
    X = random_points(rng, 16)
    df, dt = estimate_dlt(X, apply(front, X)), estimate_dlt(X, apply(top, X))
    t = np.linspace(0, 0.4, 50)
    path = np.column_stack([0.25 + 7 * t, 0.15 + 4.5 * t - 4.9 * t**2, 0.5 * t])
    assert np.allclose(triangulate([df, dt], [apply(front, path), apply(top, path)]), path,
                       atol=1e-9)
    assert np.allclose(reconstruct_with_known(df, apply(front, path), "z", path[:, 2]), path,
                       atol=1e-9)


def test_nan_input_gives_nan():
    rng = np.random.default_rng(1)
    P = build((1000, 0, 0, 3, 0.3, 0.1))
    Q = build((1000, 0, 0, 3, -0.5, 0.2))
    X = random_points(rng, 10)
    d1, d2 = estimate_dlt(X, apply(P, X)), estimate_dlt(X, apply(Q, X))
    uv1, uv2 = apply(P, X[:3]), apply(Q, X[:3])
    uv1[1] = np.nan
    got = triangulate([d1, d2], [uv1, uv2])
    assert np.all(np.isnan(got[1])) and np.allclose(got[[0, 2]], X[[0, 2]])
    assert np.all(np.isnan(project(d1, [np.nan, 0, 0])))


def test_refusals():
    rng = np.random.default_rng(2)
    P = build((1000, 0, 0, 3, 0.3, 0.1))
    X = random_points(rng, 10)
    with pytest.raises(InputError, match="at least 6 points, got 5"):
        estimate_dlt(X[:5], apply(P, X[:5]))
    flat = X.copy()
    flat[:, 2] = 0.1
    with pytest.raises(InputError, match="coplanar"):
        estimate_dlt(flat, apply(P, flat))
    with pytest.raises(InputError, match="xyz has 10 points but uv has 9"):
        estimate_dlt(X, apply(P, X)[:9])
    bad = apply(P, X)
    bad[0, 0] = np.nan
    with pytest.raises(InputError, match="finite"):
        estimate_dlt(X, bad)
    d = estimate_dlt(X, apply(P, X))
    with pytest.raises(InputError, match="at least two cameras"):
        triangulate([d], [apply(P, X)])
    with pytest.raises(InputError, match="same number of points"):
        triangulate([d, d], [apply(P, X), apply(P, X)[:3]])
    with pytest.raises(InputError, match="axis must be one of"):
        reconstruct_with_known(d, apply(P, X), "w", 0.0)
    with pytest.raises(InputError, match="11 finite parameters"):
        DLT(params=(1.0,) * 10)
    M = np.hstack([np.eye(3), np.zeros((3, 1))])   # camera centre at the world origin
    with pytest.raises(InputError, match="focal plane"):
        DLT.from_matrix(M)


def test_to_dict_round_trip():
    rng = np.random.default_rng(4)
    P = build((900, 5, -5, 3, 0.4, 0.2))
    X = random_points(rng, 8)
    d = estimate_dlt(X, apply(P, X))
    again = DLT(params=tuple(d.to_dict()["params"]))
    assert np.allclose(again.project(X), d.project(X), atol=1e-12)
