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


def rod_tracks(cams_rt, frames, *, length=0.10, radius=0.01):
    """Tracks of a spinning rod (a capsule: ``length`` between its caps' centres) along
    :func:`throw`, as a tracker sees a silhouette of one width (how vidtrack synth draws
    a straw): the centroid is the midpoint of the ends imaged by ``cv2.projectPoints``,
    the angle theirs, ``area_px`` and ``length_px`` those of the 2-D capsule between them
    with the radius f r / depth at the centre."""
    from vidtrack.track.tracker import Track

    t = frames / FPS
    centre = throw(t)
    spin = 9.0 * t + 0.3
    axis = np.column_stack([np.cos(spin) * 0.8, np.sin(spin) * 0.8, 0.6 * np.cos(0.5 * spin)])
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    out = {}
    for name, (R, tv) in cams_rt.items():
        a = image(centre - 0.5 * length * axis, R, tv)
        b = image(centre + 0.5 * length * axis, R, tv)
        depth = (centre @ R.T + tv)[:, 2]
        rho = K[0, 0] * radius / depth
        ell = np.linalg.norm(b - a, axis=1)
        area = 2 * rho * ell + np.pi * rho ** 2
        moment = (rho * ell ** 3 / 6 + 4 * rho ** 3 * ell / 3 + np.pi * rho ** 2 * ell ** 2 / 4
                  + np.pi * rho ** 4 / 4)
        ang = np.arctan2(b[:, 1] - a[:, 1], b[:, 0] - a[:, 0])
        ang = np.where(ang > np.pi / 2, ang - np.pi, np.where(ang <= -np.pi / 2, ang + np.pi, ang))
        mid = 0.5 * (a + b)
        data = pd.DataFrame({"frame": frames, "t_s": t, "u_px": mid[:, 0], "v_px": mid[:, 1],
                             "area_px": area, "angle_rad": ang,
                             "length_px": np.sqrt(12 * moment / area), "flags": 0})
        out[name] = Track(data=data, view=name, release_frame=0, release_note="", release_t_s=0.0,
                          fps=FPS, frame_shape=(800, 1280), noise_sigma=1.0, k_sigma=4.0,
                          straw_level=200.0, scatter_px=0.0)
    return out, centre


def test_rod_perspective_corrected():
    # two cameras 60 degrees apart, 1 m from the flight: the rod's silhouette centroids
    # are 0.1..1.5 px off its projected centre; corrected, the triangulation finds the
    # centre (truth: the throw, not the code) within a twentieth of a millimetre
    cams, rt = {}, {}
    for name, el in (("cam1", 15.0), ("cam2", 75.0)):
        e = np.radians(el)
        R, t = look_at(np.array([0.0, -np.cos(e), np.sin(e)]) + throw(np.array([0.15]))[0],
                       throw(np.array([0.15]))[0])
        rt[name] = (R, t)
        cams[name] = ProjectiveCamera(K @ np.hstack([R, t[:, None]]), name=name)
    frames = np.arange(0, 60)
    tracks, centre = rod_tracks(rt, frames)
    sync = dict.fromkeys(cams, 0)
    fps = dict.fromkeys(cams, FPS)
    raw = triangulate_views(tracks, cams, fps=fps, sync=sync, up=UP, rod=None)
    fixed = triangulate_views(tracks, cams, fps=fps, sync=sync, up=UP, rod="uniform")
    real = triangulate_views(tracks, cams, fps=fps, sync=sync, up=UP)    # "perspective"

    def err(w):
        return np.linalg.norm(w.data[["X_m", "Y_m", "Z_m"]].to_numpy() - centre, axis=1)

    assert np.max(err(raw)) > 1e-3                     # the bias is real: over a millimetre
    assert np.max(err(fixed)) < 5e-5, np.max(err(fixed))
    # a real rod's silhouette is wider at its near end: that model moves the points the
    # same way, further (here wrongly: the tracks are of one width)
    xyz = {k: w.data[["X_m", "Y_m", "Z_m"]].to_numpy() for k, w in
           (("raw", raw), ("fixed", fixed), ("real", real))}
    move_f, move_r = xyz["fixed"] - xyz["raw"], xyz["real"] - xyz["raw"]
    ratio = np.linalg.norm(move_r, axis=1) / np.linalg.norm(move_f, axis=1)
    cosine = np.sum(move_f * move_r, axis=1) / np.linalg.norm(move_f, axis=1) \
        / np.linalg.norm(move_r, axis=1)
    assert 1.1 < np.median(ratio) < 1.7 and np.min(cosine) > 0.9, (np.median(ratio), cosine)
    summary = fixed.to_dict()["rod_correction"]
    assert summary["taper"] == "uniform"
    assert summary["length_m"] == pytest.approx(0.10, rel=1e-3)
    assert summary["radius_m"] == pytest.approx(0.01, rel=2e-2)
    assert summary["rows_corrected"] + summary["rows_not_corrected"] == len(frames)
    assert summary["rows_corrected"] >= 50
    assert 0.1 < summary["median_px"] < summary["max_px"] < 3.0
    assert "rod_correction" not in raw.to_dict()
    assert {"rod_shift_px_cam1", "rod_shift_px_cam2"} <= set(fixed.data.columns)


def test_rod_correction_needs_angles(scene):
    # points digitized elsewhere have no angle: nothing to correct, said nowhere
    cams, tracks, _ = scene
    w = triangulate_views(tracks, cams, fps={"cam1": FPS, "cam2": FPS}, up=UP)
    assert "rod_correction" not in w.to_dict()
    assert not any(c.startswith("rod_shift") for c in w.data.columns)
    with pytest.raises(ValueError, match="rod must be"):
        triangulate_views(tracks, cams, fps={"cam1": FPS, "cam2": FPS}, up=UP, rod="cone")


def test_a_frame_beside_a_gap_is_kept_when_the_offset_is_a_hair_off_a_whole_frame():
    """A view placed a few thousandths of a frame off (as a reprojection search finds
    synchronous views) is carried on, straight, the hair beyond a frame whose neighbour on
    that side is missing (an excluded frame, the track's end): before, each such frame was
    lost. A quarter of a frame is not carried on, and the search for the offsets itself
    sees only what lies between frames."""
    from vidtrack.world.calibrated import _REACH, _at

    fps = 100.0
    frames = np.r_[0:20, 25:40].astype(float)          # frames 20..24 excluded
    t = frames / fps

    def track(tt):                                      # a curved track, px
        return np.column_stack([3.0 * tt * fps + 0.4 * (tt * fps) ** 2, 5.0 - tt * fps])

    uv = track(t)
    for hair in (-0.004, 0.004):
        want = (frames + hair) / fps
        got = _at(want, t, uv, fps, reach=_REACH)
        assert np.isfinite(got).all()                   # 19 + hair, 25 + hair, the ends
        # the straight line through two frames misses the parabola by a r (1 + r) / 2
        assert np.abs(got - track(want)).max() <= 0.4 * abs(hair) * (1 + abs(hair)) + 1e-9
        bare = _at(want, t, uv, fps)
        assert np.isfinite(bare[:, 0]).sum() == len(frames) - 2   # an end, a side of the gap
    far = _at(np.array([19.25, 24.75]) / fps, t, uv, fps, reach=_REACH)
    assert np.isnan(far).all()
