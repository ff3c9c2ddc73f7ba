"""vidtrack synth with pinhole cameras, and the perspective of the orthogonal rig.

Truth the code did not make:

- the straw's world positions from ``fits.throw.position`` at the frame times, imaged
  here with OpenCV's ``cv2.projectPoints`` (lens included) from each camera's pose, and
  compared with truth.json, with the camera the scene.toml describes (DLT bottom-left,
  projection with a lens) and with the coverage centroid of the rendered frames;
- the camera geometry against the options (distance to the flight's middle, the angle
  between the optical axes, image columns along world X);
- the orthogonal rig's perspective correction on pixels imaged by ``cv2.projectPoints``
  through square pinhole cameras (tracks assembled here), and end to end on footage;
- ``vidtrack fit`` of a perspective run (noise and MJPG compression on) recovering k.
"""

import json
import math

import cv2
import numpy as np
import pandas as pd
import pytest

from fits.throw import position
from vidtrack.errors import SceneError, VidtrackError
from vidtrack.footage import open_source
from vidtrack.scene import load_scene, parse_scene
from vidtrack.synth import SynthSpec, render_run
from vidtrack.track.tracker import Track
from vidtrack.world.orthogonal import merge_tracks

LENS = (-0.12, 0.03, 0.0005, -0.0003, 0.0)
#: A short thick straw: its silhouette's centroid is the projected centre to ~0.01 px
#: (a rod slanted in depth is off by up to f L^2 / (8 depth^2)).
CLEAN = dict(size_px=(200, 150), flight_s=0.05, release_frame=3, exposure_samples=4,
             straw_length_m=0.03, straw_diameter_m=0.02, texture_amplitude=0.0,
             vignetting=0.0, draw_machine=False, read_noise_dn=0.0, output_format="png",
             bit_depth=16)


def load_truth(folder):
    return json.loads((folder / "truth.json").read_text())


def table(truth, view):
    return pd.DataFrame(truth["views"][view]["per_frame"])


def world_truth(spec, t):
    """The straw's centre at t >= 0 from the throw model (not from the renderer)."""
    return position(t, spec.state, spec.k, spec.cp_s_per_m, g=spec.gravity_m_s2,
                    v1=spec.speed_kmh / 3.6)


def cv2_pixels(cam, xyz):
    """World (throw frame) points imaged by OpenCV from the truth's pose and lens."""
    R, t = np.array(cam["R"]), np.array(cam["t"])
    dist = np.zeros(5) if cam["dist"] is None else np.array(cam["dist"])
    uv, _ = cv2.projectPoints(np.asarray(xyz, float).reshape(-1, 1, 3), cv2.Rodrigues(R)[0],
                              t, np.array(cam["K"]), dist)
    return uv.reshape(-1, 2)


def coverage_centroid(frame, spec):
    cov = (frame / 65535.0 - spec.background_grey) / (spec.straw_grey - spec.background_grey)
    cov[np.abs(cov) < 1e-3] = 0.0
    rows, cols = np.indices(cov.shape)
    return (cov * cols).sum() / cov.sum(), (cov * rows).sum() / cov.sum()


# ------------------------------------------------------------------------ perspective

@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    out = tmp_path_factory.mktemp("persp") / "clean"
    spec = SynthSpec(**CLEAN, cameras="perspective", camera_distance_m=1.2,
                     camera_angle_deg=70.0, distortion=LENS)
    render_run(out, spec)
    return out, spec


def test_camera_geometry_is_what_was_asked(clean):
    out, spec = clean
    truth = load_truth(out)
    cams = {v: truth["views"][v]["camera"] for v in ("cam1", "cam2")}
    axes = [np.array(c["R"])[2] for c in cams.values()]
    angle = math.degrees(math.acos(float(np.dot(*axes))))
    assert angle == pytest.approx(70.0, abs=1e-9)
    for c in cams.values():
        R = np.array(c["R"])
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0)
        np.testing.assert_allclose(R[0], [1.0, 0.0, 0.0], atol=1e-12)   # columns along X
        # both optical axes meet at the flight's middle, 1.2 m from each camera
        target = np.array(c["centre_m"]) + 1.2 * R[2]
        other = next(o for o in cams.values() if o is not c)
        d_other = target - np.array(other["centre_m"])
        assert np.linalg.norm(d_other) == pytest.approx(1.2, rel=1e-9)
        np.testing.assert_allclose(d_other / 1.2, np.array(other["R"])[2], atol=1e-9)
    assert cams["cam1"]["dist"] == list(LENS) and cams["cam2"]["dist"] is None
    assert cams["cam2"]["written_as"] == "dlt"


def test_truth_pixels_are_cv2_projections_and_the_scene_describes_the_cameras(clean):
    out, spec = clean
    truth = load_truth(out)
    scene = load_scene(out)
    assert scene.calibrated and scene.view_names == ("cam1", "cam2")
    assert scene.views["cam2"].pixel_origin == "bottom-left"
    assert "dlt" in scene.views["cam2"].model and "projection" in scene.views["cam1"].model
    assert scene.views["cam1"].model["distortion"] == list(LENS)
    frame = truth["calibration_frame"]
    rot, off = np.array(frame["rotation"]), np.array(frame["offset_m"])
    np.testing.assert_allclose(scene.world.up, rot @ [0, 1, 0], atol=1e-12)
    for view in ("cam1", "cam2"):
        tab = table(truth, view)
        info = truth["views"][view]
        fl = tab["t_s"].to_numpy() >= 0
        xyz = world_truth(spec, tab["t_s"].to_numpy()[fl])
        np.testing.assert_allclose(tab[["x_m", "y_m", "z_m"]].to_numpy()[fl], xyz, atol=1e-12)
        uv = cv2_pixels(info["camera"], xyz)
        np.testing.assert_allclose(tab[["u_px", "v_px"]].to_numpy()[fl], uv, atol=1e-6)
        # the scene's camera (read back from scene.toml) images the same pixels, in its
        # own convention (DLTdv's: v counted up from the bottom edge)
        cam = scene.views[view].camera
        got = cam.project(xyz @ rot.T + off)
        if view == "cam2":
            got[:, 1] = info["height_px"] - got[:, 1]
        np.testing.assert_allclose(got, uv, atol=1e-6)
        assert np.all(tab["in_view"]) and np.all(tab["fully_in_view"])


def test_rendered_frames_show_the_straw_where_opencv_projects_it(clean):
    # the whole render path (pinhole, radius at depth, blur, the lens by remap) against
    # cv2.projectPoints of the throw model's positions: a straw 3 cm long is imaged
    # centred on its projected centre to ~0.01 px
    out, spec = clean
    truth = load_truth(out)
    checked = 0
    for view in ("cam1", "cam2"):
        tab = table(truth, view)
        cam = truth["views"][view]["camera"]
        exposure = spec.exposure_fraction / spec.fps
        offs = ((np.arange(spec.exposure_samples) + 0.5) / spec.exposure_samples - 0.5)
        with open_source(out / view, fps=spec.fps) as src:
            for i in range(len(src)):
                t = tab["t_s"][i] + offs * exposure
                if t.min() < 0 or not tab["fully_in_view"][i]:
                    continue
                # the blurred straw: the mean of the exposure's projected centres
                want = cv2_pixels(cam, world_truth(spec, t)).mean(axis=0)
                u, v = coverage_centroid(src[i], spec)
                tol = 0.06 if cam["dist"] else 0.03
                assert abs(u - want[0]) < tol and abs(v - want[1]) < tol, (view, i, u - want[0],
                                                                           v - want[1])
                checked += 1
    assert checked >= 80


def test_square_rig_truth_scale_and_perspective_correction(tmp_path):
    spec = SynthSpec(**{**CLEAN, "straw_length_m": 0.10}, cameras="square",
                     camera_distance_m=1.5, scale_in_scene="m_per_px", draw_ruler=False)
    render_run(tmp_path / "sq", spec)
    truth = load_truth(tmp_path / "sq")
    scene = load_scene(tmp_path / "sq")
    for view in ("front", "top"):
        info, tab = truth["views"][view], table(truth, view)
        cam = info["camera"]
        K = np.array(cam["K"])
        # square to the axes, the principal point at the image centre
        assert K[0, 2] == (info["width_px"] - 1) / 2 and K[1, 2] == (info["height_px"] - 1) / 2
        vs = scene.views[view]
        assert vs.camera_distance_m == 1.5
        assert vs.m_per_px == pytest.approx(1.5 / K[0, 0], rel=1e-12)
        # the world origin lies on the scale plane: origin_px is where OpenCV images it
        np.testing.assert_allclose(cv2_pixels(cam, [[0.0, 0.0, 0.0]])[0], vs.origin_px,
                                   atol=1e-9)
        fl = tab["t_s"].to_numpy() >= 0
        xyz = world_truth(spec, tab["t_s"].to_numpy()[fl])
        uv = cv2_pixels(cam, xyz)
        np.testing.assert_allclose(tab[["u_px", "v_px"]].to_numpy()[fl], uv, atol=1e-6)
        m = vs.mapping()
        axis, sign = m.toward_camera
        assert (view, axis, sign) in (("front", "z", 1.0), ("top", "y", 1.0))
        seen = xyz[:, [0, 1] if view == "front" else [0, 2]]
        depth = sign * xyz[:, "xyz".index(axis)]
        got = m.pixel_to_world_at_depth(uv, depth,
                                        principal_px=(K[0, 2], K[1, 2]))
        np.testing.assert_allclose(got, seen, atol=1e-9)
        # orthographic, the same pixels are off by the parallax
        assert np.abs(m.pixel_to_world(uv) - seen).max() > 0.002


# ------------------------------------------------------------------ the merge, by hand

def _square_camera(view, d, centre_in_plane, f, size):
    """A pinhole camera square to the front (axes +x, -y) or top (+x, +z) plane."""
    u = np.array([1.0, 0.0, 0.0])
    v = np.array([0.0, -1.0, 0.0]) if view == "front" else np.array([0.0, 0.0, 1.0])
    look = np.cross(u, v)
    R = np.vstack([u, v, look])
    centre = centre_in_plane[0] * u + centre_in_plane[1] * v - d * look
    K = np.array([[f, 0.0, (size[0] - 1) / 2], [0.0, f, (size[1] - 1) / 2], [0, 0, 1.0]])
    return R, centre, K


def _track(view, frames, t, uv, size):
    data = pd.DataFrame({"frame": frames, "t_s": t, "u_px": uv[:, 0], "v_px": uv[:, 1],
                         "area_px": 50.0, "angle_rad": 0.0, "length_px": 20.0,
                         "flags": np.zeros(len(t), dtype=np.int32)})
    return Track(data=data, view=view, release_frame=0 if view == "front" else None,
                 release_note="", release_t_s=0.0 if view == "front" else None, fps=1200.0,
                 frame_shape=(size[1], size[0]), noise_sigma=1.0, k_sigma=5.0,
                 straw_level=200.0, scatter_px=0.05)


def test_merge_corrects_perspective_from_the_other_views_depth():
    from calibration.views import ViewMapping

    state, k, cp = (0.24, -0.05, 0.0, 7.3, 2.6, 1.0), (2.2, 2.5, 4.6, 21.3), 0.115
    fps, d, f, size = 1200.0, 1.5, 300.0, (640, 360)
    delay = 0.37 / fps                          # the top camera's frames are later
    tracks, mappings = {}, {}
    for view in ("front", "top"):
        frames = np.arange(300)
        t = frames / fps                        # each camera's own clock
        xyz = position(t + (delay if view == "top" else 0.0), state, k, cp, v1=0.0)
        R, centre, K = _square_camera(view, d, (0.8, -0.05 if view == "front" else -0.1),
                                      f, size)
        uv, _ = cv2.projectPoints(xyz.reshape(-1, 1, 3), cv2.Rodrigues(R)[0], -R @ centre,
                                  K, np.zeros(5))
        uv = uv.reshape(-1, 2)
        tracks[view] = _track(view, frames, t, uv, size)
        origin = cv2.projectPoints(np.zeros((1, 1, 3)), cv2.Rodrigues(R)[0], -R @ centre, K,
                                   np.zeros(5))[0].ravel()
        axes = ("+x", "-y") if view == "front" else ("+x", "+z")
        mappings[view] = ViewMapping(axes=axes, origin_px=tuple(origin), m_per_px=d / f,
                                     camera_distance_m=d)
    t_rows = np.arange(300) / fps
    truth = position(t_rows, state, k, cp, v1=0.0)
    w = merge_tracks(tracks, mappings, sync={"front": 0})
    assert (w.t0_s["front"] - w.t0_s["top"]) * fps == pytest.approx(0.37, abs=0.01)
    assert w.x_rms_px < 0.01
    got = w.data.set_index("t_s")
    want = pd.DataFrame(truth, index=t_rows, columns=["x_m", "y_m", "z_m"]).loc[got.index]
    err = np.abs(got[["x_m", "y_m", "z_m"]].to_numpy() - want.to_numpy())
    assert np.nanmax(err) < 2e-5 and len(got) >= 280
    notes = [s for s in w.warnings if s.startswith("perspective corrected")]
    assert len(notes) == 2 and "camera 1.5 m from the plane Z = 0" in notes[0]
    # without the distance: the views disagree on X by pixels, the world is off by cm,
    # and the merge says nothing of perspective (the fit stage weighs it against k:
    # tests/test_perspective_note.py)
    plain = {v: ViewMapping(axes=m.axes, origin_px=m.origin_px, m_per_px=m.m_per_px)
             for v, m in mappings.items()}
    w0 = merge_tracks(tracks, plain, sync={"front": 0})
    assert w0.x_rms_px > 1.0
    got0 = w0.data.set_index("t_s")
    assert np.nanmax(np.abs(got0["x_m"] - want["x_m"].reindex(got0.index))) > 0.02
    assert not [s for s in w0.warnings if "perspective" in s]


# ------------------------------------------------------------------ bad input

@pytest.mark.parametrize("value, message", [
    (0, "views.front.camera_distance_m must be > 0, got 0"),
    (-1.5, "views.front.camera_distance_m must be > 0, got -1.5"),
    ("far", "views.front.camera_distance_m must be a number, got a string 'far'"),
    (float("inf"), "views.front.camera_distance_m must be a finite number, got inf"),
    (1e6, "views.front.camera_distance_m must be between 0.01 and 100000 m, got 1000000.0"),
])
def test_scene_camera_distance_is_checked(value, message):
    data = {"schema": 1, "views": {"front": {"source": "front.avi", "fps": 1200,
                                             "axes": ["+x", "-y"], "origin_px": [10, 20],
                                             "m_per_px": 0.005, "camera_distance_m": value}}}
    with pytest.raises(SceneError) as err:
        parse_scene(data, folder=None)
    assert str(err.value) == f"scene.toml: {message}"


def test_scene_camera_distance_round_trips_and_reaches_the_mapping():
    data = {"schema": 1, "views": {"top": {"source": "top.avi", "fps": 1200,
                                           "axes": ["+x", "+z"], "origin_px": [10, 20],
                                           "m_per_px": 0.005, "camera_distance_m": 2}}}
    scene = parse_scene(data, folder=None)
    assert scene.views["top"].camera_distance_m == 2.0
    assert scene.views["top"].mapping().camera_distance_m == 2.0
    assert scene.to_dict()["views"]["top"]["camera_distance_m"] == 2.0
    del data["views"]["top"]["camera_distance_m"]
    plain = parse_scene(data, folder=None)
    assert plain.views["top"].mapping().camera_distance_m is None
    assert "camera_distance_m" not in plain.to_dict()["views"]["top"]


@pytest.mark.parametrize("bad", [dict(cameras="fisheye"), dict(camera_distance_m=0.0),
                                 dict(camera_distance_m=float("nan")),
                                 dict(camera_angle_deg=5.0), dict(distortion=(0.1, 0.2)),
                                 dict(distortion=LENS),   # orthographic: no lens
                                 dict(cameras="square", distortion=LENS),
                                 dict(cameras="perspective", views=("front",)),
                                 dict(cameras="perspective", m_per_px=0.005),
                                 dict(cameras="perspective", dlt_views=("cam3",)),
                                 dict(cameras="perspective", distortion=LENS,
                                      dlt_views=("cam1", "cam2"))])
def test_bad_camera_options_are_refused(bad):
    with pytest.raises(VidtrackError):
        SynthSpec(**bad)


@pytest.mark.parametrize("bad", [("--cameras", "fisheye"), ("--camera-distance-m", "0"),
                                 ("--distortion", "1,2"), ("--camera-angle-deg", "179"),
                                 ("--cameras", "square", "--distortion", "0.1,0,0,0,0"),
                                 ("--cameras", "perspective", "--dlt-views", "cam9"),
                                 ("--cameras", "perspective", "--camera-distance-m", "0.3")])
def test_cli_bad_camera_options_exit_2_and_write_nothing(tmp_path, vidtrack_cli, bad):
    out = tmp_path / "nothing"
    res = vidtrack_cli("synth", out, "--size", "96x64", "--flight-s", "0.02", *bad)
    assert res.returncode == 2, res.stderr
    assert "error" in res.stderr and "Traceback" not in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
    assert not out.exists()


def test_orthographic_truth_has_no_camera_fields(tmp_path):
    render_run(tmp_path / "o", SynthSpec(size_px=(96, 64), flight_s=0.01, release_frame=2,
                                         exposure_samples=2, views=("front",)))
    spec = load_truth(tmp_path / "o")["spec"]
    assert "cameras" not in spec and "camera_distance_m" not in spec


# ------------------------------------------------------------------ end to end

def _k_errors(record, truth):
    record = record[0] if isinstance(record, list) else record
    return {k: record["coefficients"][k]["value"] / truth[k] - 1 for k in truth}, record


def test_perspective_run_gives_k_back(tmp_path, vidtrack_cli):
    # cam1 with a lens (projection + intrinsics + distortion), cam2 a DLT counted from
    # the bottom-left; noise and MJPG compression on (the defaults); clocks found. The
    # motion blur averaged over 2 renders a frame, not 8 (a quarter of the rendering;
    # measured: k1..k4 off by 0.34, 0.03, 0.50, -0.39 % with 8, by 0.30, 0.04, 0.47,
    # -0.36 % with 2; median reprojection 0.023 and 0.024 px)
    out = tmp_path / "persp"
    r = vidtrack_cli("synth", out, "--cameras", "perspective", "--camera-distance-m", "1.5",
                     "--camera-angle-deg", "80", "--distortion=-0.12,0.03,0.0005,-0.0003,0",
                     "--size", "320x240", "--flight-s", "0.3", "--straw-diameter-m", "0.02",
                     "--seed", "3", "--exposure-samples", "2")
    assert r.returncode == 0, r.stderr
    fit = vidtrack_cli("fit", out, "--json", "--no-report")
    assert fit.returncode == 0, fit.stderr
    truth = load_truth(out)["truth"]["k"]
    err, rec = _k_errors(json.loads(fit.stdout), truth)
    assert abs(err["k1"]) < 0.01 and abs(err["k2"]) < 0.01 and abs(err["k3"]) < 0.01, err
    assert abs(err["k4"]) < 0.02, err
    assert rec["world"]["median_reprojection_px"] < 0.3
    assert rec["world"]["forward_from"] == "given"


def test_square_rig_bias_removed_by_the_camera_distance(tmp_path, vidtrack_cli):
    # pinhole cameras 1.5 m from the planes Z = 0 and Y = 0, read as the orthogonal rig:
    # without camera_distance_m k1 and k2 are biased by the parallax, with it not. The
    # motion blur averaged over 2 renders a frame, not 8, as tests/test_perspective_note.py
    # renders this rig (measured: k1, k2 off by 0.03, -0.01 % with 8 and 0.06, -0.02 %
    # with 2; without the distance by 11.9, -16.6 % and 12.2, -16.7 %)
    out = tmp_path / "square"
    r = vidtrack_cli("synth", out, "--cameras", "square", "--camera-distance-m", "1.5",
                     "--size", "400x184", "--top-size", "400x112", "--flight-s", "0.3",
                     "--straw-diameter-m", "0.02", "--quality", "40", "--noise", "1.0",
                     "--exposure-samples", "2")
    assert r.returncode == 0, r.stderr
    truth = load_truth(out)["truth"]["k"]
    # with the distance the views agree: the cross-checks pass, no option needed
    fit = vidtrack_cli("fit", out, "--json", "--no-report")
    assert fit.returncode == 0, fit.stderr
    err, rec = _k_errors(json.loads(fit.stdout), truth)
    assert abs(err["k1"]) < 0.01 and abs(err["k2"]) < 0.01, err
    assert rec["world"]["x_rms_px"] < 0.5
    assert sum(n.startswith("perspective corrected") for n in rec["notes"]) == 2
    scene = (out / "scene.toml").read_text()
    (out / "scene.toml").write_text("\n".join(
        ln for ln in scene.splitlines() if not ln.startswith("camera_distance_m")) + "\n")
    # without it the views disagree on X: refused, unless the user accepts it
    refused = vidtrack_cli("fit", out, "--json", "--no-report")
    assert refused.returncode == 2 and "--accept-disagreement" in refused.stderr
    fit = vidtrack_cli("fit", out, "--json", "--no-report", "--accept-disagreement")
    assert fit.returncode == 0, fit.stderr
    err0, rec0 = _k_errors(json.loads(fit.stdout), truth)
    assert abs(err0["k1"]) > 0.05 and abs(err0["k2"]) > 0.05, err0
    # each view's note: k would move by standard errors; give its camera_distance_m
    notes = [n for n in rec0["notes"] if n.startswith("perspective in the")]
    assert len(notes) == 2, rec0["notes"]
    for view, note in zip(("front", "top"), notes):
        assert note.startswith(f"perspective in the {view} view could move k")
        assert f"give views.{view}.camera_distance_m in scene.toml" in note
