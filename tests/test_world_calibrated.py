"""vidtrack.world.calibrated: views of calibrated cameras to the world track.

Truth the code did not make: a drag-free throw evaluated here in closed form, imaged by
pinhole cameras assembled here and OpenCV's ``cv2.projectPoints``, written to plain
points files and read back through vidtrack's reader; the second camera's clock runs a
known fraction of a frame off. The real three-camera rig (easyWand DLT, DLTdv7 points)
runs when ../shared is present.
"""

import cv2
import numpy as np
import pandas as pd
import pytest

from calibration.projective import ProjectiveCamera
from vidtrack.errors import TrackError
from vidtrack.track.digitized import read_points
from pinhole import look_at
from vidtrack.world.calibrated import REPROJECTION, throw_rotation, triangulate_views

K = np.array([[1100.0, 0.0, 640.0], [0.0, 1100.0, 400.0], [0.0, 0.0, 1.0]])
G = 9.81
FPS = 200.0
UP = np.array([0.0, 0.0, 1.0])          # the calibration frame's z is up


def throw(t):
    """A drag-free throw along the calibration frame's (1, 1, 0)/sqrt 2, z up."""
    d = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    return (np.array([-0.5, -0.5, 0.2]) + np.outer(t, 3.0 * d + np.array([0, 0, 3.5]))
            - np.outer(0.5 * G * t * t, UP))


def image(xyz, R, t):
    uv, _ = cv2.projectPoints(xyz.reshape(-1, 1, 3), cv2.Rodrigues(R)[0], t, K, np.zeros(5))
    return uv.reshape(-1, 2)


def write_points(path, frames, uv):
    pd.DataFrame({"frame": frames, "u_px": uv[:, 0], "v_px": uv[:, 1]}).to_csv(path, index=False)
    return path


@pytest.fixture
def scene(tmp_path):
    """Two cameras 90 degrees apart, 2.5 m away; camera 2's clock 0.37 frames late."""
    rng = np.random.default_rng(7)
    cams, tracks = {}, {}
    offset_frames = {"cam1": 0.0, "cam2": 0.37}
    for name, az in (("cam1", 0.0), ("cam2", np.pi / 2)):
        R, t = look_at(2.5 * np.array([np.cos(az), np.sin(az), 0.25]), (0.0, 0.0, 0.3))
        cams[name] = ProjectiveCamera(K @ np.hstack([R, t[:, None]]), name=name)
        frames = np.arange(0, 150)
        times = frames / FPS - offset_frames[name] / FPS
        uv = image(throw(np.clip(times, 0, None)), R, t) + rng.normal(0, 0.15, (len(frames), 2))
        uv[times < 0] = np.nan
        tracks[name] = read_points(write_points(tmp_path / f"{name}.csv", frames, uv), fps=FPS,
                                   view=name)
    return cams, tracks, offset_frames


def test_points_file_round_trip(scene):
    _, tracks, _ = scene
    tr = tracks["cam1"]
    assert list(tr.data.columns)[:4] == ["frame", "t_s", "u_px", "v_px"]
    assert tr.usable.sum() == 150 and tr.fps == FPS


def test_auto_sync_finds_a_fraction_of_a_frame(scene):
    cams, tracks, offsets = scene
    w = triangulate_views(tracks, cams, fps={"cam1": FPS, "cam2": FPS}, up=UP)
    found = {n: w.offsets_s[n] * FPS for n in cams}
    assert found[w.reference] == 0
    other = "cam2" if w.reference == "cam1" else "cam1"
    expected = offsets[other] - offsets[w.reference]
    assert found[other] == pytest.approx(expected, abs=0.05)
    assert "reprojection" in w.sync[other]
    assert w.median_reprojection_px < 0.4
    assert not (w.data["flags"] != 0).any()


def test_given_sync_frames_and_the_throw_frame(scene):
    cams, tracks, offsets = scene
    w = triangulate_views(tracks, cams, fps={"cam1": FPS, "cam2": FPS},
                          sync={"cam1": 0, "cam2": 0}, up=UP)
    assert w.sync == {"cam1": "sync_frame 0", "cam2": "sync_frame 0"}
    d = w.data
    ok = d["flags"] == 0
    t = d["t_s"][ok].to_numpy()
    # Y is up, X along the throw's horizontal direction, Z = X x Y: a drag-free throw
    # is a parabola in y with -g, straight in x with the horizontal speed, still in z
    coef = {a: np.polyfit(t, d[f"{a}_m"][ok], 2) for a in "xyz"}
    assert 2 * coef["y"][0] == pytest.approx(-G, rel=0.02)
    assert coef["x"][1] == pytest.approx(3.0, rel=0.02)
    assert abs(coef["z"][1]) < 0.05 and abs(2 * coef["z"][0]) < 0.3
    assert w.forward_from == "initial velocity"
    np.testing.assert_allclose(w.rotation @ w.rotation.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(w.rotation) == pytest.approx(1.0)
    np.testing.assert_allclose(w.rotation[1], UP)
    np.testing.assert_allclose(w.rotation[0], [np.sqrt(0.5), np.sqrt(0.5), 0], atol=0.01)


def test_a_bad_frame_is_flagged_and_not_fitted(scene, tmp_path):
    cams, tracks, _ = scene
    data = tracks["cam2"].data.copy()
    # across the epipolar line (these cameras sit level: their epipolar lines are nearly
    # rows): an error along it is invisible to any two-view triangulation
    data.loc[60, "v_px"] += 25.0
    path = write_points(tmp_path / "bad.csv", data["frame"], data[["u_px", "v_px"]].to_numpy())
    bad = {"cam1": tracks["cam1"], "cam2": read_points(path, fps=FPS, view="cam2")}
    w = triangulate_views(bad, cams, fps={"cam1": FPS, "cam2": FPS}, up=UP)
    assert w.reference == "cam1"
    flagged = w.data["frame"][w.data["flags"] == REPROJECTION].tolist()
    # camera 2 is read between its frames (0.37 frames off): the rows whose cubic
    # interpolation takes its bad frame 60 are flagged, and only those
    assert 60 in flagged and set(flagged) <= {57, 58, 59, 60, 61}
    row = w.data.set_index("frame").loc[60]
    assert np.isnan(row["x_m"]) and row["reprojection_px_cam2"] > 3
    assert np.isfinite(row["X_m"])           # kept in the calibration frame, for the record


def test_one_view_is_not_enough(scene):
    cams, tracks, _ = scene
    with pytest.raises(TrackError, match="two or more views"):
        triangulate_views({"cam1": tracks["cam1"]}, cams, fps={"cam1": FPS}, up=UP)


def test_views_that_never_overlap_are_refused(scene, tmp_path):
    cams, tracks, _ = scene
    d = tracks["cam2"].data
    early = write_points(tmp_path / "early.csv", d["frame"][:5], d[["u_px", "v_px"]][:5].to_numpy())
    with pytest.raises(TrackError):
        triangulate_views({"cam1": tracks["cam1"], "cam2": read_points(early, fps=FPS)}, cams,
                          fps={"cam1": FPS, "cam2": FPS}, up=UP)


def test_throw_rotation_limits():
    t = np.linspace(0, 1, 20)
    drop = np.column_stack([np.zeros_like(t), np.zeros_like(t), 1 - 0.5 * G * t * t])
    rot, source = throw_rotation(drop, t, UP)
    assert source == "none"                    # no horizontal motion: any horizontal X
    assert abs(rot[0] @ UP) < 1e-12 and np.linalg.det(rot) == pytest.approx(1.0)
    rot, source = throw_rotation(drop, t, UP, forward=[0.0, 2.0, 1.0])
    assert source == "given"
    np.testing.assert_allclose(rot[0], [0, 1, 0], atol=1e-12)


def test_real_three_camera_rig_end_to_end(shared_dir):
    from fits.lsq import fit_throw

    d = shared_dir / "data" / "real" / "multicam3_dlt"
    L = np.loadtxt(d / "2018-08-17_wand_dltCoefs.csv", delimiter=",")
    cams = {f"cam{j + 1}": ProjectiveCamera.from_dlt(L[:, j], pixel_origin="bottom-left",
                                                     name=f"cam{j + 1}") for j in range(3)}
    tracks = {n: read_points(d / "DLTdv7_data_gravityxypts.csv", fps=25, fmt="dltdv",
                             camera=j + 1, point=1, view=n) for j, n in enumerate(cams)}
    for sync in ({n: 0 for n in cams}, None):
        w = triangulate_views(tracks, cams, fps=dict.fromkeys(cams, 25.0), sync=sync, up=UP)
        assert w.median_reprojection_px <= 1.2
        if sync is None:      # the cameras were synchronised: the offsets found are ~0
            assert all(abs(v) * 25 < 0.2 for v in w.offsets_s.values())
        ok = w.data["flags"] == 0
        t = w.data["t_s"][ok].to_numpy()
        xyz = w.data.loc[ok, ["x_m", "y_m", "z_m"]].to_numpy()
        # a drag-free fit with a free acceleration vector: |g| of 9.5-10.5 m/s^2 along -Y
        coef, *_ = np.linalg.lstsq(np.column_stack([np.ones_like(t), t, t * t]), xyz, rcond=None)
        accel = 2 * coef[2]
        assert 9.5 <= np.linalg.norm(accel) <= 10.5
        assert np.degrees(np.arccos(-accel[1] / np.linalg.norm(accel))) < 12
        # and the throw model without drag: k1 g (rising) and k2 g (falling) agree with it
        fit = fit_throw(w.data[["t_s", "x_m", "y_m", "z_m"]], 0.0, model="free")
        for k in ("k1", "k2"):
            c = fit.coefficients[k]
            assert c.determined
            assert abs(c.value * 9.80665 - np.linalg.norm(accel)) < 3 * c.stderr * 9.80665
