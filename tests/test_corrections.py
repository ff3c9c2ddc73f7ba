"""Correcting the tracker from scene.toml: target, exclude_frames, manual_points (issue 13).

Every fit here is the real command line in a subprocess on a synthetic run whose truth
(truth.json: the true centroid of every frame, k1..k4) the tracker never sees. The
figures are checked against that truth, never against the code's own output:

- an excluded range is flagged EXCLUDED in tracks.csv and leaves the world track: the
  y points of fit.json drop by exactly the frames excluded (y comes from the front view
  alone);
- points placed by hand at the true pixels in frames the tracker flagged are used (flags
  0, ``manual`` 1) and the fit stays within 1 % of the true k; placed 30 px off, the fit
  moves (they are used), and an edited CSV counts: applied to the views' tracks kept
  from the tracker (views.h5: the tracker does not read it), the world track rebuilt;
- a flag set by hand in tracks.h5 counts: the world track is rebuilt from the edited views;
- calibrated cameras: exclude_frames on cam1 and a target on cam1 work.
"""

import csv
import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from conftest import run_vidtrack
from synth_runs import truth

#: A two-view run long enough for the descent (k2 determined): 0.3 s of flight, at the
#: renderer's defaults (noise, motion blur, MJPG compression; the straw leaves the top
#: view after about 0.07 s).
SYNTH = ("--size", "320x240", "--flight-s", "0.3", "-q")
_SRC = {}


def synth_run(name, **_):
    """The synthetic run of this module, rendered once by the real ``vidtrack synth``."""
    if "run" not in _SRC:
        import atexit
        import tempfile

        root = Path(tempfile.mkdtemp(prefix="vidtrack-tests-corrections-"))
        atexit.register(shutil.rmtree, root, True)
        res = run_vidtrack("synth", root / name, *SYNTH)
        assert res.returncode == 0, res.stderr
        _SRC["run"] = root / name
    return _SRC["run"]


RUN = {}
EXCLUDED = 256
TOL = 0.01      # relative error of k1..k4 against truth (measured: below 0.3 %)


def _inputs_digest(folder):
    out = {}
    for p in sorted(Path(folder).rglob("*")):
        if p.is_file() and "vidtrack" not in p.relative_to(folder).parts:
            out[str(p.relative_to(folder))] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


@pytest.fixture
def run(tmp_path):
    src = synth_run("corrections", **RUN)
    dst = tmp_path / "run"
    shutil.copytree(src, dst, ignore=shutil.ignore_patterns("vidtrack"))
    return dst


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """The run fitted without corrections: (its folder, with vidtrack/, the fit's record).
    Shared by the tests: copied, never changed."""
    dst = tmp_path_factory.mktemp("base") / "run"
    shutil.copytree(synth_run("corrections", **RUN), dst,
                    ignore=shutil.ignore_patterns("vidtrack"))
    res = run_vidtrack("fit", dst, "--json", "--no-report", "-q")
    assert res.returncode == 0, res.stderr
    return dst, json.loads(res.stdout)


@pytest.fixture(scope="module")
def baseline(fitted):
    """The run fitted without corrections: fit.json and tracks.csv."""
    dst, record = fitted
    return record, pd.read_csv(dst / "vidtrack" / "tracks.csv")


def _add_to_view(folder, view, lines):
    path = Path(folder) / "scene.toml"
    text = path.read_text()
    head = f"[views.{view}]\n"
    assert head in text
    path.write_text(text.replace(head, head + "".join(f"{x}\n" for x in lines), 1))


def _fit(cli, folder, *extra):
    res = cli("fit", folder, "--json", "--no-report", *extra)
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout), res


def _k_errors(record, folder):
    true = truth(folder)["truth"]["k"]
    return {k: record["coefficients"][k]["value"] / true[k] - 1 for k in true}


def _front(folder):
    tr = pd.read_csv(Path(folder) / "vidtrack" / "tracks.csv")
    return tr[tr["view"] == "front"].set_index("frame")


def _truth_pixels(folder, view, frames):
    pf = pd.DataFrame(truth(folder)["views"][view]["per_frame"]).set_index("frame")
    return pf.loc[list(frames), ["u_px", "v_px"]]


def _write_manual(path, frames, uv, extra_column=False):
    with open(path, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["frame", "u_px", "v_px"] + (["note"] if extra_column else []))
        for fr, (u, v) in zip(frames, uv):
            w.writerow([int(fr), repr(float(u)), repr(float(v))]
                       + (["placed by hand"] if extra_column else []))


def test_baseline_is_within_tolerance_of_truth(baseline):
    record, _ = baseline
    src = synth_run("corrections", **RUN)
    errors = _k_errors(record, src)
    assert all(abs(e) < TOL for e in errors.values()), errors


def test_excluded_range_is_flagged_and_leaves_the_fit(run, baseline, vidtrack_cli):
    base, base_tracks = baseline
    bf = base_tracks[base_tracks["view"] == "front"].set_index("frame")
    a, b = 100, 130
    usable_before = int((bf.loc[a:b - 1, "flags"] == 0).sum())
    assert usable_before >= 20
    _add_to_view(run, "front", [f"exclude_frames = [[{a}, {b}]]"])
    before = _inputs_digest(run)
    record, _ = _fit(vidtrack_cli, run)
    front = _front(run)
    flags = front["flags"].to_numpy()
    inside = (front.index >= a) & (front.index < b)
    assert np.all(flags[inside] & EXCLUDED) and not np.any(flags[~inside] & EXCLUDED)
    assert all("EXCLUDED" in n for n in front.loc[a:b - 1, "flag_names"])
    # y is seen by the front view only: exactly the excluded frames are gone
    assert record["points"]["y"] == base["points"]["y"] - usable_before
    # x comes from the top view where it still sees the straw
    assert base["points"]["x"] - usable_before <= record["points"]["x"] <= base["points"]["x"]
    assert record["views"]["front"]["flags"]["excluded"] == b - a
    errors = _k_errors(record, run)
    assert all(abs(e) < TOL for e in errors.values()), errors
    assert _inputs_digest(run) == before


def test_manual_points_at_truth_replace_flagged_frames(run, baseline, vidtrack_cli):
    base, base_tracks = baseline
    bf = base_tracks[base_tracks["view"] == "front"].set_index("frame")
    flagged = [int(f) for f, fl in bf["flags"].items() if fl != 0 and not fl & 32]
    assert len(flagged) >= 5, "the run should have frames the tracker flagged after release"
    uv = _truth_pixels(run, "front", flagged).to_numpy()
    _write_manual(run / "front_manual.csv", flagged, uv, extra_column=True)
    _add_to_view(run, "front", ['manual_points = "front_manual.csv"'])
    before = _inputs_digest(run)
    # the speed cross-check compares the views over the stretch of X both see; the
    # frames by the blade, now measured in the front view, lengthen it there (the top
    # view reads 1.06 times the front's speed): accepted, the coefficients are checked
    # against truth below
    record, _ = _fit(vidtrack_cli, run, "--accept-disagreement")
    front = _front(run)
    assert (front.loc[flagged, "manual"] == 1).all() and (front.loc[flagged, "flags"] == 0).all()
    assert int(front["manual"].sum()) == len(flagged)
    np.testing.assert_array_equal(front.loc[flagged, ["u_px", "v_px"]].to_numpy(), uv)
    # every one of them from the release on is fitted: y (front only) gains exactly
    # these frames (the release is found again on the corrected track: a frame by the
    # blade may fall just before it)
    after = [f for f in flagged
             if front.loc[f, "t_s"] >= record["views"]["front"]["release_t_s"]]
    assert len(after) >= len(flagged) - 1
    assert record["points"]["y"] == base["points"]["y"] + len(after)
    errors = _k_errors(record, run)
    assert all(abs(e) < TOL for e in errors.values()), errors
    assert _inputs_digest(run) == before
    # tracks.h5 keeps the column too
    import h5py

    with h5py.File(run / "vidtrack" / "tracks.h5") as h:
        assert int(h["front/manual"][()].sum()) == len(flagged)
        assert "manual" not in h["top"]


def test_wrong_manual_points_move_the_fit_and_an_edited_csv_counts(run, vidtrack_cli):
    frames = [150, 151, 152]
    uv = _truth_pixels(run, "front", frames).to_numpy()
    csv_path = run / "front_manual.csv"
    _write_manual(csv_path, frames, uv)
    _add_to_view(run, "front", ['manual_points = "front_manual.csv"'])
    good, _ = _fit(vidtrack_cli, run)
    again, res = _fit(vidtrack_cli, run)
    assert again["stages_reused"] == ["tracks", "fit"], res.stderr      # nothing changed
    _write_manual(csv_path, frames, uv + [0.0, 30.0])                    # 30 px down
    bad, res = _fit(vidtrack_cli, run)
    # the tracker's tracks reused, the CSV applied to them, the world track rebuilt
    assert bad["stages_reused"] == ["views"], res.stderr
    front = _front(run)
    np.testing.assert_array_equal(front.loc[frames, "v_px"].to_numpy(), uv[:, 1] + 30.0)
    # 30 px is about 14 cm: the residual and k1 move far beyond their uncertainty
    assert bad["residual_rms_m"]["y"] > 5 * good["residual_rms_m"]["y"]
    k1_good, k1_bad = good["coefficients"]["k1"], bad["coefficients"]["k1"]
    assert abs(k1_bad["value"] - k1_good["value"]) > 3 * k1_good["stderr"]


def test_a_flag_set_by_hand_in_tracks_h5_counts(fitted, tmp_path, vidtrack_cli):
    import h5py

    src, first = fitted
    run = shutil.copytree(src, tmp_path / "run")
    h5 = run / "vidtrack" / "tracks.h5"
    a, b = 100, 120
    with h5py.File(h5, "r+") as h:
        frames, flags = h["front/frame"][()], h["front/flags"][()]
        hit = (frames >= a) & (frames < b) & (flags == 0)
        n = int(hit.sum())
        flags[hit] |= EXCLUDED
        h["front/flags"][...] = flags
        world_t = h["world/t_s"][()]
    assert n >= 15
    edited, res = _fit(vidtrack_cli, run)
    assert "using it as edited, the world track rebuilt from its edited views" in res.stderr
    assert edited["points"]["y"] == first["points"]["y"] - n
    assert edited["coefficients"]["k1"]["value"] != first["coefficients"]["k1"]["value"]
    world = pd.read_csv(run / "vidtrack" / "world.csv")
    assert len(world) <= len(world_t)
    assert int(world["y_m"].notna().sum()) == edited["points"]["y"]
    with h5py.File(h5) as h:            # the edit is kept, /world rebuilt from it
        assert int(np.count_nonzero(h["front/flags"][()] & EXCLUDED)) == n
        assert int(np.isfinite(h["world/y_m"][()]).sum()) == edited["points"]["y"]
    again, res = _fit(vidtrack_cli, run)
    assert again["stages_reused"] == ["tracks", "fit"], res.stderr
    assert again["points"] == edited["points"]


# ------------------------------------------------------------------ calibrated cameras

def _calibrated_copy(src, dst, distance_m=1e4):
    """The synthetic run's footage seen as two calibrated pinhole cameras far away (the
    renderer's views are orthographic: a camera 10 km off with the focal length of the
    view's scale images them to 2e-5 of a pixel per pixel)."""
    from vidtrack.scene import load_scene, write_scene

    dst.mkdir()
    for name in ("front.avi", "top.avi", "truth.json"):
        shutil.copy(src / name, dst / name)
    scene = load_scene(src)

    def projection(view, rows):
        f = distance_m / view.m_per_px
        k = np.array([[f, 0, view.origin_px[0]], [0, f, view.origin_px[1]], [0, 0, 1.0]])
        return (k @ np.hstack([np.array(rows, float), [[0], [0], [distance_m]]])).tolist()

    views = {"cam1": {"source": "front.avi", "fps": 1200,
                      "projection": projection(scene.views["front"],
                                               [[1, 0, 0], [0, -1, 0], [0, 0, -1]])},
             "cam2": {"source": "top.avi", "fps": 1200,
                      "projection": projection(scene.views["top"],
                                               [[1, 0, 0], [0, 0, 1], [0, -1, 0]])}}
    write_scene(dst, {"schema": 1, "straw": {"cp_s_per_m": 0.115},
                      "world": {"up": [0, 1, 0], "forward": [1, 0, 0]}, "views": views})
    return dst


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """The run as two calibrated cameras (:func:`_calibrated_copy`) fitted: (its folder,
    with vidtrack/, the fit's record). Shared by the tests: copied, never changed."""
    run = _calibrated_copy(synth_run("corrections", **RUN),
                           tmp_path_factory.mktemp("cal") / "cal")
    return run, _fit(run_vidtrack, run)[0]


def test_calibrated_exclude_frames_on_cam1(calibrated, tmp_path, vidtrack_cli):
    src, base = calibrated
    run = shutil.copytree(src, tmp_path / "cal")
    world0 = pd.read_csv(run / "vidtrack" / "world.csv")
    seen = sorted(int(f) for f in world0["frame"])
    runs, start = [], seen[0]            # stretches of consecutive triangulated frames
    for f, g in zip(seen, seen[1:] + [None]):
        if g != f + 1:
            runs.append((start, f + 1))
            start = g
    a, end = max(runs, key=lambda r: r[1] - r[0])
    b = min(end, a + 15)
    assert b - a >= 8, runs
    _add_to_view(run, "cam1", [f"exclude_frames = [[{a}, {b}]]"])
    record, _ = _fit(vidtrack_cli, run)
    tracks = pd.read_csv(run / "vidtrack" / "tracks.csv")
    cam1 = tracks[tracks["view"] == "cam1"].set_index("frame")
    assert (cam1.loc[a:b - 1, "flags"] & EXCLUDED).all()
    world = pd.read_csv(run / "vidtrack" / "world.csv")
    # two views: a frame cam1 does not give is not triangulated, and no other frame is
    # lost (the reprojection outlier rule, on the errors of the frames left, may take
    # back a frame it flagged before; the clock offset, found again on the frames left,
    # moves by a thousandth of a frame, which must not lose cam1's frames beside a gap
    # of cam2's track: calibrated._REACH_GAP)
    assert not set(range(a, b)) & set(world["frame"])
    assert set(world0["frame"]) - set(range(a, b)) <= set(world["frame"])
    assert record["points"]["x"] == len(world)
    # both cameras see the straw for 0.07 s only: the coefficients that determines
    true = truth(run)["truth"]["k"]
    errors = {k: c["value"] / true[k] - 1 for k, c in record["coefficients"].items()
              if c["determined"]}
    assert len(errors) >= 2 and all(abs(e) < 0.03 for e in errors.values()), errors


def test_calibrated_target_is_passed_to_the_tracker(calibrated, tmp_path, vidtrack_cli):
    src = synth_run("corrections", **RUN)
    run = shutil.copytree(calibrated[0], tmp_path / "cal")
    plain = pd.read_csv(run / "vidtrack" / "tracks.csv")
    u, v = _truth_pixels(src, "front", [120]).to_numpy()[0]
    _add_to_view(run, "cam1", [f"target = {{ frame = 120, at_px = [{u:.2f}, {v:.2f}] }}"])
    _fit(vidtrack_cli, run)
    aimed = pd.read_csv(run / "vidtrack" / "tracks.csv")
    p = plain[plain["view"] == "cam1"].set_index("frame")
    q = aimed[aimed["view"] == "cam1"].set_index("frame")
    both = (p["flags"] == 0) & (q["flags"] == 0)
    assert both.sum() > 0.8 * len(p)
    assert np.max(np.abs(p.loc[both, "u_px"] - q.loc[both, "u_px"])) < 0.05
    # a target far from the straw finds nothing there: the target reached the tracker
    _add_to_view(run, "cam2", ["target = { frame = 120, at_px = [5.0, 5.0] }"])
    res = vidtrack_cli("fit", run, "--json", "--no-report")
    assert res.returncode == 2 and "target" in res.stderr, res.stderr


# ------------------------------------------------------------------ the scene keys

def test_scene_round_trip_and_hash(tmp_path):
    from vidtrack.scene import load_scene, write_scene

    src = synth_run("corrections", **RUN)
    run = tmp_path / "run"
    shutil.copytree(src, run, ignore=shutil.ignore_patterns("vidtrack"))
    _write_manual(run / "m.csv", [50, 51], [[100.0, 60.0], [101.0, 60.5]])
    plain = load_scene(run)
    _add_to_view(run, "front", ['exclude_frames = [[200, 215], [300, 301]]',
                                'manual_points = "m.csv"',
                                "target = { frame = 120, at_px = [64.0, 30.0] }"])
    scene = load_scene(run)
    front = scene.views["front"]
    assert front.exclude_frames == ((200, 215), (300, 301))
    assert front.manual_points == run / "m.csv" and front.target == (120, (64.0, 30.0))
    assert scene.hash != plain.hash
    out = tmp_path / "again"
    out.mkdir()
    shutil.copy(run / "m.csv", out / "m.csv")
    write_scene(out, scene.to_dict())
    again = load_scene(out)
    assert again.to_dict()["views"] == scene.to_dict()["views"]
    assert again.views["front"].exclude_frames == front.exclude_frames
    # calibrated views too
    cal = _calibrated_copy(src, tmp_path / "cal")
    shutil.copy(run / "m.csv", cal / "m.csv")
    _add_to_view(cal, "cam2", ['exclude_frames = [[10, 20]]', 'manual_points = "m.csv"',
                               "target = { frame = 120, at_px = [64.0, 30.0] }"])
    c = load_scene(cal)
    assert c.views["cam2"].exclude_frames == ((10, 20),)
    assert c.views["cam2"].target == (120, (64.0, 30.0))
    out2 = tmp_path / "cal2"
    out2.mkdir()
    shutil.copy(cal / "m.csv", out2 / "m.csv")
    write_scene(out2, c.to_dict())
    assert load_scene(out2).to_dict()["views"] == c.to_dict()["views"]
