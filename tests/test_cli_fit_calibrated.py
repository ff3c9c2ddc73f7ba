"""``vidtrack fit`` on scenes with calibrated cameras at any angle, through the real CLI.

Truth the code did not make: a quadratic-drag throw integrated by scipy's solve_ivp
(``fits.throw.ode``, the reference the closed forms are tested against), placed at an
angle in a calibration frame, imaged by two pinhole cameras assembled here with OpenCV's
``cv2.projectPoints`` (lens distortion included), written as points files. And the real
three-camera rig (easyWand DLT, DLTdv7 points) when ../shared is present.
"""

import json

import cv2
import numpy as np
import pandas as pd
import pytest

from fits.throw.ode import solve_throw
from pinhole import look_at

K = np.array([[1400.0, 0.0, 960.0], [0.0, 1400.0, 540.0], [0.0, 0.0, 1.0]])
DIST = [-0.12, 0.03, 0.0005, -0.0003, 0.0]
TRUTH_K = (2.2, 2.5, 4.6, 21.3)
CP = 0.115
STATE = (0.25, 0.15, 0.0, 7.0, 4.5, 2.0)
FPS = 500.0
HEADING = np.radians(35.0)      # the throw's X in the calibration frame (z up there)


def throw_frame_to_calibration():
    x = np.array([np.cos(HEADING), np.sin(HEADING), 0.0])
    y = np.array([0.0, 0.0, 1.0])
    return np.vstack([x, y, np.cross(x, y)])       # rows: the throw frame's axes


def write_run(folder, rng, *, distortion=True):
    t = np.arange(0, 0.6, 1 / FPS)
    local = solve_throw(t, STATE, TRUTH_K, CP)
    xyz = local @ throw_frame_to_calibration()       # to the calibration frame
    target = xyz.mean(axis=0)
    folder.mkdir()
    lines = ["schema = 1", "[straw]", f"cp_s_per_m = {CP}", "[world]", "up = [0.0, 0.0, 1.0]",
             f"forward = [{float(np.cos(HEADING))!r}, {float(np.sin(HEADING))!r}, 0.0]"]
    for name, az in (("left", HEADING - np.radians(50)), ("right", HEADING + np.radians(45))):
        centre = target + 2.2 * np.array([np.sin(az), -np.cos(az), 0.35])
        R, tvec = look_at(centre, target)
        dist = np.array(DIST if distortion else [0.0] * 5)
        uv, _ = cv2.projectPoints(xyz.reshape(-1, 1, 3), cv2.Rodrigues(R)[0], tvec, K, dist)
        uv = uv.reshape(-1, 2) + rng.normal(0, 0.1, (len(t), 2))
        pd.DataFrame({"frame": np.arange(len(t)), "u_px": uv[:, 0], "v_px": uv[:, 1]}).to_csv(
            folder / f"{name}.csv", index=False)
        P = K @ np.hstack([R, tvec[:, None]])
        lines += [f"[views.{name}]", f'points = "{name}.csv"', f"fps = {FPS}",
                  "projection = " + json.dumps(P.tolist()),
                  "intrinsics = " + json.dumps(K.tolist()),
                  "distortion = " + json.dumps(list(dist)), "sync_frame = 0"]
    (folder / "scene.toml").write_text("\n".join(lines) + "\n")
    return folder


def _fit_json(vidtrack_cli, run, *extra):
    """``vidtrack fit RUN --json`` (exit 0): the run's record and the terminal's stderr."""
    r = vidtrack_cli("fit", run, *extra, "--json")
    assert r.returncode == 0, r.stderr
    rec = json.loads(r.stdout)
    return (rec[0] if isinstance(rec, list) else rec), r.stderr


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return write_run(tmp_path_factory.mktemp("cal") / "run", np.random.default_rng(11))


def test_calibrated_points_give_k_back(run, vidtrack_cli):
    rec, _ = _fit_json(vidtrack_cli, run)
    for name, truth in zip(("k1", "k2", "k3", "k4"), TRUTH_K):
        c = rec["coefficients"][name]
        assert c["determined"], (name, c)
        tol = 0.02 if name == "k4" else 0.01
        assert c["value"] == pytest.approx(truth, rel=tol), (name, c)
    world = rec["world"]
    assert world["median_reprojection_px"] < 0.3
    assert world["forward_from"] == "given"
    np.testing.assert_allclose(world["rotation"], throw_frame_to_calibration(), atol=1e-9)
    out = run / "vidtrack"
    for name in ("tracks.h5", "tracks.csv", "world.csv", "fit.json", "report.html"):
        assert (out / name).is_file()
    w = pd.read_csv(out / "world.csv")
    assert {"reprojection_px_left", "reprojection_px_right", "views", "flags"} <= set(w.columns)
    tracks = pd.read_csv(out / "tracks.csv")
    assert set(tracks["view"]) == {"left", "right"}


def test_the_same_run_without_the_lens_model_is_biased(run, tmp_path, vidtrack_cli):
    # the points saw the lens; a scene that leaves the distortion out is biased, and two
    # views hardly show it in their reprojection error (it runs along epipolar lines)
    run = write_run(tmp_path / "run", np.random.default_rng(11))
    text = (run / "scene.toml").read_text()
    text = "\n".join(ln for ln in text.splitlines() if not ln.startswith("distortion"))
    (run / "scene.toml").write_text(text + "\n")
    rec, _ = _fit_json(vidtrack_cli, run)
    k4 = rec["coefficients"]["k4"]["value"]
    assert abs(k4 / TRUTH_K[3] - 1) > 0.03
    assert rec["world"]["median_reprojection_px"] < 1.0


def test_real_three_camera_rig(shared_dir, tmp_path, vidtrack_cli):
    d = shared_dir / "data" / "real" / "multicam3_dlt"
    L = np.loadtxt(d / "2018-08-17_wand_dltCoefs.csv", delimiter=",")
    run = tmp_path / "multicam3"
    run.mkdir()
    lines = ["schema = 1", "[world]", "up = [0.0, 0.0, 1.0]"]
    for j in range(3):
        lines += [f"[views.cam{j + 1}]",
                  f'points = {{ file = "{d / "DLTdv7_data_gravityxypts.csv"}", camera = {j + 1} }}',
                  "fps = 25", "dlt = " + json.dumps(L[:, j].tolist()),
                  'pixel_origin = "bottom-left"']
    (run / "scene.toml").write_text("\n".join(lines) + "\n")
    rec, _ = _fit_json(vidtrack_cli, run, "--model", "free")
    assert rec["world"]["median_reprojection_px"] <= 1.2
    for name in ("k1", "k2"):
        g = rec["coefficients"][name]["value"] * 9.80665
        assert 9.5 <= g <= 10.5, (name, g)


def _badminton_run(shared_dir, run, *, footage, first_frame=732):
    """One flight between two hits (frames 732-872; the hits are where the court-length
    velocity reverses) of the two calibrated badminton cameras (OpenCV projections,
    lens): the labelled pixels as ``points``, or with ``footage`` the videos, tracked,
    with a ``target`` on the shuttlecock in frame 802 (the labelled pixel there).
    ``first_frame`` starts the flight later (the frames fitted: first_frame..872)."""
    import ast
    import configparser

    d = shared_dir / "data" / "real" / "badminton_2cam"
    run.mkdir()
    lines = ["schema = 1", "[straw]", "cp_s_per_m = 0.149",     # terminal speed 6.7 m/s
             "[world]", "up = [0.0, 0.0, 1.0]"]
    for j in (1, 2):
        cfg = configparser.ConfigParser()
        cfg.read(d / f"CameraReader_{j}.cfg")
        o = {k: ast.literal_eval(v) for k, v in cfg["Other"].items()}
        labels = pd.read_csv(d / f"CameraReader_{j}.csv")
        lines.append(f"[views.cam{j}]")
        if footage:
            at = labels.set_index("Frame").loc[802]
            (run / f"cam{j}.mp4").symlink_to(d / f"CameraReader_{j}.mp4")
            lines += [f'source = "cam{j}.mp4"', "sync_frame = 732",
                      f"target = {{ frame = 802, at_px = [{at.X:.1f}, {at.Y:.1f}] }}"]
        else:
            labels = labels[labels["Visibility"] == 1]
            pd.DataFrame({"frame": labels["Frame"], "u_px": labels["X"],
                          "v_px": labels["Y"]}).to_csv(run / f"cam{j}.csv", index=False)
            lines += [f'points = "cam{j}.csv"', "sync_frame = 0"]
        lines += ["fps = 119.12",
                  "projection = " + json.dumps(o["projection_mat"]),
                  "intrinsics = " + json.dumps(o["ks"]),
                  "distortion = " + json.dumps(np.ravel(o["dist"]).tolist()),
                  f"frames = [{int(first_frame)}, 872]"]
    (run / "scene.toml").write_text("\n".join(lines) + "\n")
    return run


def test_real_two_camera_rig_one_flight_between_hits(shared_dir, tmp_path, vidtrack_cli):
    """A shuttlecock rally filmed by two calibrated cameras, from the labelled pixels,
    fitted with the quadratic drag model."""
    run = _badminton_run(shared_dir, tmp_path / "badminton", footage=False)
    rec, stderr = _fit_json(vidtrack_cli, run)
    # the terminal says how badly the calibration and the labels agree
    assert "the calibration and the points disagree: median reprojection error" in stderr
    assert rec["world"]["rows"] == 140 and 5 < rec["world"]["median_reprojection_px"] < 15
    for name in ("k1", "k2", "k3"):
        assert rec["coefficients"][name]["determined"], name
    html = (run / "vidtrack" / "report.html").read_text()
    assert "Calibrated cameras" in html and "reprojection" in html
    assert "the calibration and the points disagree" in html


def test_real_two_camera_rig_tracked_from_the_footage(shared_dir, tmp_path, vidtrack_cli):
    """The same flight from the videos: the shuttlecock tracked in both cameras (named by
    a ``target`` in one frame), triangulated and fitted. The two cameras' centroids agree
    better with the calibration than the labels do (which mark the cork, ahead of the
    centroid by a share of the apparent length that differs between the cameras), and
    the coefficients agree with the labels' within their uncertainty, over the same
    stretch of the flight: the quadratic model is not a shuttlecock's exact law, so its
    k1 depends on the stretch fitted. The tracker loses camera 1's first 17 frames after
    the hit (the world track starts at frame 749; the rules tracker's at 768), and the
    labels fitted over 732..871 give k1 1.907 +- 0.035, over 749..871 1.800 +- 0.067:
    tracked, 119 rows, k1 1.732 +- 0.028, k2 0.694 +- 0.006, k3 1.419 +- 0.017 (labels
    over 749..871: 0.692 +- 0.013, 1.438 +- 0.051); median reprojection 6.5 px
    (labels 7.0 px)."""
    rec, _ = _fit_json(vidtrack_cli, _badminton_run(shared_dir, tmp_path / "trk",
                                                    footage=True))
    frames = pd.read_csv(tmp_path / "trk" / "vidtrack" / "world.csv")["frame"]
    first = int(frames.min())
    assert first < 802 and int(frames.max()) >= 860           # the flight, not a piece
    lab, _ = _fit_json(vidtrack_cli, _badminton_run(shared_dir, tmp_path / "lab",
                                                    footage=False, first_frame=first))
    print(f"\nbadminton from footage: {rec['world']['rows']} rows from frame {first}, "
          f"median reprojection {rec['world']['median_reprojection_px']:.2f} px (labels: "
          f"{lab['world']['median_reprojection_px']:.2f} px); " + ", ".join(
              f"{k} {rec['coefficients'][k]['value']:.3f} +- "
              f"{rec['coefficients'][k]['stderr']:.3f} (labels "
              f"{lab['coefficients'][k]['value']:.3f} +- {lab['coefficients'][k]['stderr']:.3f})"
              for k in ("k1", "k2", "k3")))
    assert rec["world"]["rows"] >= 80
    assert rec["world"]["median_reprojection_px"] < lab["world"]["median_reprojection_px"]
    for k in ("k1", "k2", "k3"):
        a, b = rec["coefficients"][k], lab["coefficients"][k]
        assert a["determined"] and b["determined"], k
        assert abs(a["value"] - b["value"]) <= 3.0 * np.hypot(a["stderr"], b["stderr"]), k
