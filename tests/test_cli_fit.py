"""``vidtrack fit`` end to end: footage rendered by ``vidtrack synth`` (known truth) ->
the real CLI as a subprocess -> tracks.h5, fit.json and reports checked against truth."""

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

SMALL = ["--size", "320x150", "--top-size", "320x96", "--straw-length-m", "0.25",
         "--straw-diameter-m", "0.025", "--quality", "60", "--noise", "1.0"]


def synth(cli, out, *extra):
    res = cli("synth", out, *SMALL, *extra)
    assert res.returncode == 0, res.stderr
    return out


def fit(cli, *args):
    res = cli("fit", *map(str, args))
    return res


def truth_k(run):
    return json.loads((run / "truth.json").read_text())["truth"]["k"]


def digest_tree(folder):
    """sha256 of every file outside vidtrack/ (inputs must never change)."""
    h = {}
    for p in sorted(folder.rglob("*")):
        if p.is_file() and "vidtrack" not in p.relative_to(folder).parts:
            h[str(p.relative_to(folder))] = hashlib.sha256(p.read_bytes()).hexdigest()
    return h


@pytest.fixture(scope="module")
def two_view_run(tmp_path_factory):
    from conftest import run_vidtrack

    return synth(run_vidtrack, tmp_path_factory.mktemp("runs") / "run01", "--flight-s", "0.3")


def test_fit_recovers_k_within_the_issue_tolerances(vidtrack_cli, two_view_run):
    before = digest_tree(two_view_run)
    res = fit(vidtrack_cli, two_view_run, "--json", "--force")
    assert res.returncode == 0, res.stderr
    record = json.loads(res.stdout)
    truth = truth_k(two_view_run)
    for k, tol in (("k1", 0.03), ("k2", 0.03), ("k3", 0.03), ("k4", 0.05)):
        c = record["coefficients"][k]
        assert c["determined"], (k, c)
        assert c["value"] == pytest.approx(truth[k], rel=tol), k
        assert c["ci95"][0] < c["value"] < c["ci95"][1]
    assert digest_tree(two_view_run) == before                # inputs untouched


def test_outputs_follow_the_spec(vidtrack_cli, two_view_run):
    import h5py

    assert fit(vidtrack_cli, two_view_run).returncode == 0
    out = two_view_run / "vidtrack"
    record = json.loads((out / "fit.json").read_text())
    for key in ("schema", "run", "model", "cp_s_per_m", "factors", "coefficients",
                "initial_state", "residual_rms_m", "points", "throws", "timings_s"):
        assert key in record
    assert record["schema"] == 1 and record["model"] == "quadratic-drag"
    assert set(record["initial_state"]) == {"x0_m", "y0_m", "z0_m", "vx0_m_s", "vy0_m_s",
                                            "vz0_m_s"}
    with h5py.File(out / "tracks.h5", "r") as h:
        for view in ("front", "top"):
            for ds in ("frame", "t_s", "u_px", "v_px", "area_px", "angle_rad", "flags"):
                assert ds in h[view]
        for ds in ("t_s", "x_m", "y_m", "z_m"):
            assert ds in h["world"]
        assert h.attrs["scene_hash"] and h.attrs["vidtrack_version"]
    html = (out / "report.html").read_text()
    assert html.count("<img") >= 2 and "k4" in html
    assert "| k1 |" in (out / "report.md").read_text()
    assert not list(out.glob("*.part")) and not list(out.glob(".*.part"))


def test_unchanged_run_is_reused_and_force_reruns(vidtrack_cli, two_view_run):
    assert fit(vidtrack_cli, two_view_run).returncode == 0
    first = json.loads((two_view_run / "vidtrack" / "fit.json").read_text())
    again = json.loads(fit(vidtrack_cli, two_view_run, "--json").stdout)
    assert again["coefficients"] == first["coefficients"]
    assert again["timings_s"] == first["timings_s"]                # the same record, reused
    forced = json.loads(fit(vidtrack_cli, two_view_run, "--json", "--force").stdout)
    assert forced["stages_reused"] == []
    assert forced["coefficients"] == first["coefficients"]          # deterministic


def test_front_view_only_reports_k4_not_determined(vidtrack_cli, tmp_path):
    run = synth(vidtrack_cli, tmp_path / "front", "--views", "front", "--flight-s", "0.3")
    record = json.loads(fit(vidtrack_cli, run, "--json").stdout)
    assert not record["coefficients"]["k4"]["determined"]
    assert "top view" in record["coefficients"]["k4"]["reason"]
    assert record["coefficients"]["k4"]["value"] is None
    truth = truth_k(run)
    assert record["coefficients"]["k1"]["value"] == pytest.approx(truth["k1"], rel=0.03)


def test_throw_without_descent_reports_k2_not_determined(vidtrack_cli, tmp_path):
    run = synth(vidtrack_cli, tmp_path / "up", "--flight-s", "0.09",
                "--state", "0.24,-0.05,0,7.3,3.5,2.0")
    record = json.loads(fit(vidtrack_cli, run, "--json").stdout)
    c = record["coefficients"]["k2"]
    assert not c["determined"] and "no descent" in c["reason"]


def test_drag_free_scene_fits_gravity_multipliers(vidtrack_cli, tmp_path):
    run = synth(vidtrack_cli, tmp_path / "free", "--cp", "0", "--k", "1.2,0.8,1,1",
                "--flight-s", "0.3")
    record = json.loads(fit(vidtrack_cli, run, "--json").stdout)
    assert record["coefficients"]["k1"]["value"] == pytest.approx(1.2, rel=0.03)
    assert record["coefficients"]["k2"]["value"] == pytest.approx(0.8, rel=0.03)
    for k in ("k3", "k4"):
        assert not record["coefficients"][k]["determined"]
        assert "Cp = 0" in record["coefficients"][k]["reason"]


def test_replicate_throws_are_fitted_and_averaged(vidtrack_cli, tmp_path):
    run = synth(vidtrack_cli, tmp_path / "throws", "--throws", "2", "--flight-s", "0.25")
    record = json.loads(fit(vidtrack_cli, run, "--json").stdout)
    assert record["throws"] == 2
    per = [json.loads((run / "vidtrack" / d / "fit.json").read_text())
           for d in ("01", "02")]
    for d in ("01", "02"):                      # each throw's tables beside its tracks.h5
        for name in ("tracks.h5", "tracks.csv", "world.csv"):
            assert (run / "vidtrack" / d / name).is_file(), (d, name)
    for k in ("k1", "k2", "k3", "k4"):
        values = [p["coefficients"][k]["value"] for p in per]
        assert record["coefficients"][k]["value"] == pytest.approx(np.mean(values))


def test_folder_of_runs_in_parallel(vidtrack_cli, tmp_path, two_view_run):
    runs = tmp_path / "runs"
    synth(vidtrack_cli, runs / "a", "--flight-s", "0.2", "--seed", "1")
    synth(vidtrack_cli, runs / "b", "--flight-s", "0.2", "--seed", "2")
    res = fit(vidtrack_cli, runs, "--jobs", "2", "--json")
    assert res.returncode == 0, res.stderr
    records = json.loads(res.stdout)
    assert [r["run"] for r in records] == ["a", "b"]


def test_dask_local_cluster(tmp_path):
    import distributed                      # in the test extra (the dask extra for users)
    from conftest import run_vidtrack

    run = synth(run_vidtrack, tmp_path / "d", "--flight-s", "0.2")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        res = run_vidtrack("fit", run, "--scheduler", cluster.scheduler_address, "--json")
    assert res.returncode == 0, res.stderr
    assert json.loads(res.stdout)["coefficients"]["k1"]["determined"]


@pytest.mark.parametrize("breakage, words", [
    (lambda run: (run / "front.avi").unlink(), ["front", "does not exist"]),
    (lambda run: (run / "top.avi").write_bytes(b"not a video"), ["top.avi"]),
    (lambda run: (run / "scene.toml").write_text(
        (run / "scene.toml").read_text().replace("fps = 1200", "fps = 0", 1)),
     ["scene.toml", "fps"]),
    (lambda run: (run / "scene.toml").write_text(
        (run / "scene.toml").read_text().replace("fps = 1200", "fps = 1200\nframes = [5000, 6000]",
                                                 1)), ["nothing"]),
])
def test_bad_runs_exit_2_with_one_line_and_no_fit(vidtrack_cli, tmp_path, two_view_run,
                                                  breakage, words):
    import shutil

    run = tmp_path / "bad"
    shutil.copytree(two_view_run, run, ignore=shutil.ignore_patterns("vidtrack"))
    breakage(run)
    res = fit(vidtrack_cli, run)
    assert res.returncode == 2, res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in res.stderr
    for w in words:
        assert w in lines[0]
    assert not (run / "vidtrack" / "fit.json").exists()


def _session_members(sid):
    """Command lines of the processes still alive in session ``sid`` (Linux /proc)."""
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
            cmd = (stat.parent / "cmdline").read_bytes().replace(b"\0", b" ").decode()
        except OSError:
            continue
        if int(fields[3]) == sid and fields[0] != "Z":
            out.append(cmd)
    return out


def test_interrupted_fit_leaves_no_partial_file_and_reruns(tmp_path, two_view_run):
    import shutil

    run = tmp_path / "intr"
    shutil.copytree(two_view_run, run, ignore=shutil.ignore_patterns("vidtrack"))
    env = dict(os.environ, MPLBACKEND="Agg")
    # a session of its own, and SIGINT to the whole group, as Ctrl-C in a terminal does:
    # the worker process tracking the second view gets it too
    proc = subprocess.Popen([sys.executable, "-m", "vidtrack", "fit", str(run)], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    time.sleep(1.5)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode in (0, 130), err
    assert "Traceback" not in err and "leaked" not in err, err
    # the worker is stopped before the command exits (left alone it would track on for
    # seconds); multiprocessing's resource tracker leaves once the command's end closes
    # its pipe: allow it a moment on a busy machine
    time.sleep(0.3)
    assert not [c for c in _session_members(proc.pid) if "spawn_main" in c], \
        "the worker process outlived the command"
    deadline = time.monotonic() + 10.0
    while _session_members(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert _session_members(proc.pid) == [], "a process outlived the command"
    out = run / "vidtrack"
    assert not [p for p in out.rglob("*") if p.name.endswith(".part")] if out.exists() else True
    if (out / "fit.json").exists():
        json.loads((out / "fit.json").read_text())             # whole, never half-written
    from conftest import run_vidtrack

    res = run_vidtrack("fit", run, "--json")
    assert res.returncode == 0, res.stderr
    assert json.loads(res.stdout)["coefficients"]["k1"]["determined"]


def test_a_fit_that_does_not_converge_says_why_and_leaves_no_fit(vidtrack_cli, tmp_path,
                                                                 two_view_run):
    """The stored world track is replaced by one no starting value can fit (positions
    of 1e300 m: every trial overflows). The tracks stage is reused (its inputs did not
    change), the fit fails: exit 2, one line naming the axis and the diagnostics, and
    the earlier fit.json and reports are gone, not left to stand for this fit."""
    import shutil

    from vidtrack.run.tracks_file import read_tracks, write_tracks

    run = tmp_path / "nofit"
    shutil.copytree(two_view_run, run, ignore=shutil.ignore_patterns("vidtrack"))
    assert fit(vidtrack_cli, run).returncode == 0
    out = run / "vidtrack"
    assert (out / "fit.json").exists()
    tf = read_tracks(out / "tracks.h5")
    tf.world.data["y_m"] = tf.world.data["y_m"] * 1e300
    write_tracks(out / "tracks.h5", tf.tracks, tf.world, scene_hash=tf.scene_hash,
                 calibration=tf.calibration)
    res = fit(vidtrack_cli, run)
    assert res.returncode == 2, res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in res.stderr
    assert "did not converge" in lines[0] and "the y fit" in lines[0]
    assert "points over t =" in lines[0]
    for name in ("fit.json", "report.md", "report.html"):
        assert not (out / name).exists()
    assert (out / "tracks.h5").exists()
