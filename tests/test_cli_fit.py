"""``vidtrack fit`` end to end: footage rendered by ``vidtrack synth`` (known truth) ->
the real CLI as a subprocess -> tracks.h5, fit.json and reports checked against truth."""

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import assert_k_within

SMALL = ["--size", "320x150", "--top-size", "320x96", "--straw-length-m", "0.25",
         "--straw-diameter-m", "0.025", "--quality", "60", "--noise", "1.0"]


#: The motion blur averaged over 2 renders a frame, not 8 (a quarter of the rendering),
#: for the runs rendered to check what a fit reports (not determined, gravity alone,
#: replicate throws, a folder of runs), not how closely it tracks; the module's run,
#: whose k are checked against the issue's tolerances, keeps the renderer's 8.
#: (Measured: the drag-free run's k1, k2 1.20072, 0.80030 with 8 and 1.20075, 0.80031
#: with 2 (truth 1.2, 0.8); the front view's k1 2.1976 and 2.1973 (truth 2.2).)
BLUR_2 = ("--exposure-samples", "2")


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
    for c in assert_k_within(record, truth).values():
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


def test_verbose_says_what_each_view_tracked(vidtrack_cli, two_view_run):
    """``-v`` names what both views' tracking found, the one tracked in the worker
    process too (before: only the view tracked in the calling process was said)."""
    res = fit(vidtrack_cli, two_view_run, "--force", "-v", "--no-report")
    assert res.returncode == 0, res.stderr
    for view in ("front", "top"):
        said = [ln for ln in res.stderr.splitlines()
                if ln.startswith(f"vidtrack fit: {view}: ") and "frames tracked" in ln]
        assert len(said) == 1, (view, res.stderr)


def test_records_logged_in_the_worker_are_logged_again_in_the_caller():
    """What the worker process logs during a job travels (pickled) with its answer and is
    logged again by the caller's loggers, message, level and label kept."""
    import logging
    import pickle

    from vidtrack.run._workers import _Kept, _replay

    source = logging.getLogger("vidtrack.track.tracker")
    kept = _Kept(logging.INFO)
    source.addHandler(kept)
    try:
        source.warning("front: %d frames", 3, extra={"label": "note"})
        source.debug("not kept: below the level")
    finally:
        source.removeHandler(kept)
    records = pickle.loads(pickle.dumps(kept.take()))
    assert kept.take() == []
    got = []

    class Catch(logging.Handler):
        def emit(self, record):
            got.append(record)

    catch = Catch()
    top = logging.getLogger("vidtrack")
    top.addHandler(catch)
    try:
        _replay(records)
    finally:
        top.removeHandler(catch)
    assert [(r.name, r.levelno, r.getMessage(), r.label) for r in got] == [
        ("vidtrack.track.tracker", logging.WARNING, "front: 3 frames", "note")]


def test_front_view_only_reports_k4_not_determined(vidtrack_cli, tmp_path):
    run = synth(vidtrack_cli, tmp_path / "front", "--views", "front", "--flight-s", "0.3",
                *BLUR_2)
    record = json.loads(fit(vidtrack_cli, run, "--json").stdout)
    assert not record["coefficients"]["k4"]["determined"]
    assert "top view" in record["coefficients"]["k4"]["reason"]
    assert record["coefficients"]["k4"]["value"] is None
    truth = truth_k(run)
    assert record["coefficients"]["k1"]["value"] == pytest.approx(truth["k1"], rel=0.03)


def test_throw_without_descent_reports_k2_not_determined(vidtrack_cli, tmp_path):
    run = synth(vidtrack_cli, tmp_path / "up", "--flight-s", "0.09",
                "--state", "0.24,-0.05,0,7.3,3.5,2.0", *BLUR_2)
    record = json.loads(fit(vidtrack_cli, run, "--json").stdout)
    c = record["coefficients"]["k2"]
    assert not c["determined"] and "no descent" in c["reason"]


def test_drag_free_scene_fits_gravity_multipliers(vidtrack_cli, tmp_path):
    run = synth(vidtrack_cli, tmp_path / "free", "--cp", "0", "--k", "1.2,0.8,1,1",
                "--flight-s", "0.3", *BLUR_2)
    record = json.loads(fit(vidtrack_cli, run, "--json").stdout)
    assert record["coefficients"]["k1"]["value"] == pytest.approx(1.2, rel=0.03)
    assert record["coefficients"]["k2"]["value"] == pytest.approx(0.8, rel=0.03)
    for k in ("k3", "k4"):
        assert not record["coefficients"][k]["determined"]
        assert "Cp = 0" in record["coefficients"][k]["reason"]


@pytest.fixture(scope="module")
def replicate_run(tmp_path_factory):
    """A run of two replicate throws, rendered and fitted once (``fit --json``): (the
    run, the fit's record). Shared: the tests copy it before changing anything."""
    from conftest import run_vidtrack

    run = synth(run_vidtrack, tmp_path_factory.mktemp("replicate") / "run", "--throws", "2",
                "--flight-s", "0.25", *BLUR_2)
    res = run_vidtrack("fit", run, "--json")
    assert res.returncode == 0, res.stderr
    return run, json.loads(res.stdout)


def test_replicate_throws_are_fitted_and_averaged(replicate_run):
    run, record = replicate_run
    assert record["throws"] == 2
    per = [json.loads((run / "vidtrack" / d / "fit.json").read_text())
           for d in ("01", "02")]
    for d in ("01", "02"):                      # each throw's tables beside its tracks.h5
        for name in ("tracks.h5", "tracks.csv", "world.csv"):
            assert (run / "vidtrack" / d / name).is_file(), (d, name)
    for k in ("k1", "k2", "k3", "k4"):
        values = [p["coefficients"][k]["value"] for p in per]
        assert record["coefficients"][k]["value"] == pytest.approx(np.mean(values))


def test_folder_of_runs_in_parallel(vidtrack_cli, tmp_path):
    runs = tmp_path / "runs"
    synth(vidtrack_cli, runs / "a", "--flight-s", "0.2", "--seed", "1", *BLUR_2)
    synth(vidtrack_cli, runs / "b", "--flight-s", "0.2", "--seed", "2", *BLUR_2)
    res = fit(vidtrack_cli, runs, "--jobs", "2", "--json")
    assert res.returncode == 0, res.stderr
    records = json.loads(res.stdout)
    assert [r["run"] for r in records] == ["a", "b"]


def test_dask_local_cluster(tmp_path, two_view_run):
    import distributed                      # in the test extra (the dask extra for users)
    from conftest import run_vidtrack

    # the module's rendered run, without its outputs: tracked and fitted on the cluster
    run = tmp_path / "d"
    shutil.copytree(two_view_run, run, ignore=shutil.ignore_patterns("vidtrack"))
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
    # (interrupted while it tracks: once the worker for the second view runs. A fixed
    # 1.5 s wait hit the interpreter still importing its site module on a loaded
    # machine: "Fatal Python error: init_import_site", not vidtrack's handling)
    deadline = time.monotonic() + 60.0
    while (proc.poll() is None and time.monotonic() < deadline
           and not [c for c in _session_members(proc.pid) if "spawn_main" in c]):
        time.sleep(0.05)
    time.sleep(0.2)
    if proc.poll() is None:
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
    # copied with its outputs: its tracks reused (or tracked, if not yet), the fit and
    # the reports made
    shutil.copytree(two_view_run, run)
    assert fit(vidtrack_cli, run).returncode == 0
    out = run / "vidtrack"
    for name in ("fit.json", "report.md", "report.html"):
        assert (out / name).exists(), name
    tf = read_tracks(out / "tracks.h5")
    tf.world.data["y_m"] = tf.world.data["y_m"] * 1e300
    write_tracks(out / "tracks.h5", tf.tracks, tf.world, scene_hash=tf.scene_hash,
                 calibration=tf.calibration)
    res = fit(vidtrack_cli, run)
    assert res.returncode == 2, res.stderr
    # the edited tracks.h5 is used as edited, and said so in a note
    assert "tracks.h5 changed since" in res.stderr and "using it as edited" in res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip() and ": note: " not in ln]
    assert len(lines) == 1 and "Traceback" not in res.stderr
    assert "did not converge" in lines[0] and "the y fit" in lines[0]
    assert "points over t =" in lines[0]
    for name in ("fit.json", "report.md", "report.html"):
        assert not (out / name).exists()
    assert (out / "tracks.h5").exists()


# ---------------------------------------------------------------- hostile inputs
# ---------------------------------------------------------------- helpers

RUN42 = Path(__file__).resolve().parents[1] / "datasets" / "run42"


def run42_copy(dest, scene=None):
    """datasets/run42 without its outputs; ``scene(text)`` edits its scene.toml."""
    import shutil

    shutil.copytree(RUN42, dest, ignore=shutil.ignore_patterns("vidtrack"))
    if scene is not None:
        path = dest / "scene.toml"
        path.write_text(scene(path.read_text()))
    return dest


def in_view(view, key, value):
    """A scene.toml edit: ``key = value`` in ``[views.VIEW]`` (replacing the key)."""
    def edit(text):
        head = f"[views.{view}]\n"
        start = text.index(head) + len(head)
        end = text.find("\n[", start)
        body = text[start:end]
        lines = [ln for ln in body.split("\n") if not ln.startswith(f"{key} =")]
        return text[:start] + f"{key} = {value}\n" + "\n".join(lines) + text[end:]
    return edit


def one_line(res):
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in res.stderr, res.stderr
    return lines[0]


def outputs(run):
    out = run / "vidtrack"
    return sorted(p.name for p in out.iterdir()) if out.is_dir() else []


# ---------------------------------------------------------------- cross-checks (item 3)

WRONG_INPUTS = {
    # the top camera's rate given as 600 instead of 1200: k4 came out 2.75 for 21.3
    "top-fps-halved": lambda t: in_view("top", "fps", "600")(t),
    "views-swapped": lambda t: t.replace('source = "front.avi"', 'source = "@"').replace(
        'source = "top.avi"', 'source = "front.avi"').replace('source = "@"',
                                                              'source = "top.avi"'),
}


@pytest.mark.parametrize("name", sorted(WRONG_INPUTS))
def test_inputs_that_disagree_stop_the_fit_unless_accepted(vidtrack_cli, tmp_path, name):
    run = run42_copy(tmp_path / "run", WRONG_INPUTS[name])
    before = digest_tree(run)
    res = fit(vidtrack_cli, run)
    assert res.returncode == 2, res.stderr
    line = one_line(res)
    assert "the inputs disagree" in line and "--accept-disagreement" in line
    assert "the views disagree on the X they both see" in line
    assert "followed another object" in line and "vidtrack overlay" in line
    if name == "top-fps-halved":
        assert "views.top.fps = 600" in line and "0.5 times" in line
    assert not (run / "vidtrack" / "fit.json").exists()
    assert not (run / "vidtrack" / "report.html").exists()
    # accepted: fitted, the warning on the terminal and in fit.json
    res = fit(vidtrack_cli, run, "--accept-disagreement", "--json")
    assert res.returncode == 0, res.stderr
    assert "warning:" in res.stderr and "accepted with --accept-disagreement" in res.stderr
    record = json.loads(res.stdout)
    assert {c["check"] for c in record["checks"]} >= {"x_disagreement"}
    assert any("inputs disagree" in n for n in record["notes"])
    # and refused again without the option (the check is made on every run)
    assert fit(vidtrack_cli, run).returncode == 2
    assert not (run / "vidtrack" / "fit.json").exists()
    assert digest_tree(run) == before


def test_good_runs_pass_the_cross_checks_with_a_margin(vidtrack_cli, run42_fit, two_view_run):
    """run42 (the module's fit of it from scratch) and a rendered run: no finding, and
    each measure far inside its limit."""
    from vidtrack.run.checks import SPEED_RATIO_TOL, X_RMS_MAX_PX

    for res in (run42_fit[1], fit(vidtrack_cli, two_view_run, "--json")):
        assert res.returncode == 0, res.stderr
        record = json.loads(res.stdout)
        assert record["checks"] == [] and "warning" not in res.stderr
        assert record["world"]["x_rms_px"] < X_RMS_MAX_PX / 5
    # the speed ratio and accelerations, measured on the rendered run's tracks
    from vidtrack.run.checks import mean_accelerations, speed_ratio
    from vidtrack.run.tracks_file import read_tracks
    from vidtrack.scene import load_scene

    tf = read_tracks(two_view_run / "vidtrack" / "tracks.h5")
    scene = load_scene(two_view_run)
    sr = speed_ratio(tf.world, tf.tracks, {n: v.mapping() for n, v in scene.views.items()})
    assert abs(sr["ratio"] - 1) < SPEED_RATIO_TOL / 5
    acc = mean_accelerations(tf.world)
    assert 1.0 < -acc["y"][0] / 9.80665 < 5.0


def test_speed_ratio_does_not_depend_on_which_frames_a_view_kept(vidtrack_cli, two_view_run):
    """A view that lost the frames of one half of the flight (flagged) still crosses the
    stretch in the same time: a straight line through x(t) put the decelerating straw's
    speed where that view's points lay (vidtrack synth with its defaults, whose top view
    had half its frames flagged, was refused at 1.05)."""
    from vidtrack.run.checks import speed_ratio
    from vidtrack.run.tracks_file import read_tracks
    from vidtrack.scene import load_scene
    from vidtrack.track.tracker import LOST

    assert fit(vidtrack_cli, two_view_run, "--json").returncode == 0
    tf = read_tracks(two_view_run / "vidtrack" / "tracks.h5")
    scene = load_scene(two_view_run)
    maps = {n: v.mapping() for n, v in scene.views.items()}
    whole = speed_ratio(tf.world, tf.tracks, maps)["ratio"]
    for part in ("first", "last"):
        tracks = dict(tf.tracks)
        top = tracks["top"]
        d = top.data.copy()
        live = np.flatnonzero(top.usable)
        # every frame of one half but one in five (the stretch stays the same)
        half = live[: live.size // 2] if part == "first" else live[live.size // 2:]
        drop = np.setdiff1d(half, half[::5])
        d.loc[d.index[drop], "flags"] = LOST
        tracks["top"] = type(top)(**{**top.__dict__, "data": d})
        half = speed_ratio(tf.world, tracks, maps)
        assert half is not None and abs(half["ratio"] - whole) < 0.005, (part, half, whole)


# ---------------------------------------------------------------- the cache (item 4)

def _k1(run):
    return json.loads((run / "vidtrack" / "fit.json").read_text())["coefficients"]["k1"]


@pytest.fixture(scope="module")
def run42_fit(tmp_path_factory):
    """run42 copied and fitted from scratch by ``vidtrack fit --json``: (the run, the
    CompletedProcess of its fit)."""
    from conftest import run_vidtrack

    run = run42_copy(tmp_path_factory.mktemp("cache") / "run")
    res = run_vidtrack("fit", run, "--json")
    assert res.returncode == 0, res.stderr
    return run, res


@pytest.fixture(scope="module")
def fitted_run42(run42_fit):
    """The run of :func:`run42_fit`. Shared: the tests copy it before changing anything."""
    return run42_fit[0]


TAMPERING = {
    "k1-edited": lambda out: (out / "fit.json").write_text(
        (out / "fit.json").read_text().replace('"value": ', '"value": 999.0, "was": ', 1)),
    "fit-json-truncated": lambda out: (out / "fit.json").write_bytes(
        (out / "fit.json").read_bytes()[:100]),
    "fit-json-empty": lambda out: (out / "fit.json").write_bytes(b""),
    "stages-json-a-list": lambda out: (out / "stages.json").write_text("[]"),
    "stages-json-not-json": lambda out: (out / "stages.json").write_text("{"),
    "tracks-h5-bit-flipped": lambda out: _flip(out / "tracks.h5"),
    "tracks-h5-truncated": lambda out: (out / "tracks.h5").write_bytes(
        (out / "tracks.h5").read_bytes()[:5000]),
    "world-csv-edited": lambda out: (out / "world.csv").write_text("t_s,x_m\n0,1\n"),
    "report-removed": lambda out: (out / "report.html").unlink(),
}


def _flip(path):
    """One bit flipped in every dataset's data (the numbers, not the layout)."""
    import h5py

    with h5py.File(path, "r") as h:
        offsets = [h["world/y_m"].id.get_chunk_info(0).byte_offset]
    data = bytearray(path.read_bytes())
    for off in offsets:
        data[off + 20] ^= 0x08
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("name", sorted(TAMPERING))
def test_a_cached_stage_is_reused_only_when_its_files_are_the_ones_recorded(
        vidtrack_cli, tmp_path, fitted_run42, name):
    import shutil

    run = tmp_path / "run"
    shutil.copytree(fitted_run42, run)
    truth = _k1(run)
    before = digest_tree(run)
    TAMPERING[name](run / "vidtrack")
    res = fit(vidtrack_cli, run, "--json")
    assert res.returncode == 0, res.stderr
    assert "Traceback" not in res.stderr and "internal error" not in res.stderr
    assert ": note: " in res.stderr                         # said, not silently redone
    record = json.loads(res.stdout)
    # this run's result (tracked again, it may differ in the last digits)
    assert record["coefficients"]["k1"]["value"] == pytest.approx(truth["value"], rel=1e-6)
    if name.startswith("world-csv"):                         # the table, from tracks.h5
        assert (run / "vidtrack" / "world.csv").read_bytes() == \
            (fitted_run42 / "vidtrack" / "world.csv").read_bytes()
    else:                                                    # the fit, computed again
        assert record.get("stages_reused") != ["tracks", "fit"]
    assert _k1(run)["value"] == pytest.approx(truth["value"], rel=1e-6)   # right again
    assert (run / "vidtrack" / "report.html").is_file()
    again = fit(vidtrack_cli, run, "--json")                # and now reused, quietly
    assert again.returncode == 0 and ": note: " not in again.stderr
    assert json.loads(again.stdout)["stages_reused"] == ["tracks", "fit"]
    assert digest_tree(run) == before                       # inputs untouched


def test_a_reused_fit_says_so_and_when(vidtrack_cli, fitted_run42):
    res = fit(vidtrack_cli, fitted_run42)
    assert res.returncode == 0, res.stderr
    fitted_at = json.loads((fitted_run42 / "vidtrack" / "fit.json").read_text())["fitted_at"]
    assert f"run42: nothing changed: reused the fit of {fitted_at}" in res.stdout


def test_a_track_edited_through_hdf5_is_used_as_edited(vidtrack_cli, tmp_path, fitted_run42):
    """tracks.h5 changed with h5py (frames flagged by hand) reads back whole: its tracks
    are used and refitted, with a note; the tables follow the edit."""
    import shutil

    import h5py
    import pandas as pd

    run = tmp_path / "run"
    shutil.copytree(fitted_run42, run)
    out = run / "vidtrack"
    with h5py.File(out / "tracks.h5", "r+") as h:
        flags = h["front/flags"][()]
        flags[100:200] |= 64                                 # OUTLIER by hand
        h["front/flags"][...] = flags
    res = fit(vidtrack_cli, run, "--json")
    assert res.returncode == 0, res.stderr
    assert "using it as edited" in res.stderr
    record = json.loads(res.stdout)
    assert record["stages_reused"] == ["tracks"]
    tracks = pd.read_csv(out / "tracks.csv")
    front = tracks[tracks.view == "front"]
    assert (front["flags"].to_numpy()[100:200] & 64).all()


@pytest.mark.parametrize("how", ["--profile", "vidtrack --profile", "python -m cProfile"])
def test_a_run_can_be_profiled(tmp_path, fitted_run42, how):
    """``vidtrack fit --profile FILE`` (or ``vidtrack --profile FILE fit``), and cProfile
    round the command (the command does not end the interpreter under a profiler): a
    profile pstats reads, with the fit in it."""
    import pstats
    import shutil

    from conftest import run_vidtrack

    run = tmp_path / "run"
    shutil.copytree(fitted_run42, run)
    (run / "vidtrack" / "fit.json").unlink()                 # tracks reused, fitted again
    prof = tmp_path / "fit.prof"
    if how == "--profile":
        res = run_vidtrack("fit", "-q", "--no-report", run, "--profile", prof)
    elif how == "vidtrack --profile":
        res = run_vidtrack("--profile", prof, "fit", "-q", "--no-report", run)
    else:
        res = subprocess.run([sys.executable, "-m", "cProfile", "-o", str(prof), "-m",
                              "vidtrack", "fit", "-q", "--no-report", str(run)],
                             capture_output=True, text=True, timeout=600,
                             stdin=subprocess.DEVNULL)
    assert res.returncode == 0, res.stderr
    functions = {(Path(file).name, name) for file, _, name in pstats.Stats(str(prof)).stats}
    assert ("lsq.py", "fit_throw") in functions
    assert not list(tmp_path.glob(".fit.prof.*"))            # no temporary file left


# ---------------------------------------------------------------- stale outputs (item 5)

def test_a_refit_with_other_options_leaves_no_report_of_the_old_fit(vidtrack_cli, tmp_path,
                                                                    fitted_run42):
    run = shutil.copytree(fitted_run42, tmp_path / "run")     # its stages reused
    out = run / "vidtrack"
    assert "quadratic" in (out / "report.md").read_text()
    res = fit(vidtrack_cli, run, "--model", "linear", "--no-report")
    assert res.returncode == 0, res.stderr
    assert json.loads((out / "fit.json").read_text())["model"] == "linear-drag"
    assert not (out / "report.md").exists() and not (out / "report.html").exists()
    # a report asked for again is rebuilt; a deleted report is rebuilt on rerun
    assert fit(vidtrack_cli, run, "--model", "linear").returncode == 0
    assert "linear" in (out / "report.md").read_text()
    (out / "report.html").unlink()
    res = fit(vidtrack_cli, run, "--model", "linear")
    assert res.returncode == 0 and (out / "report.html").is_file()
    assert "report.html" in res.stderr and "missing" in res.stderr
    # --no-report with the fit unchanged keeps the report that shows it
    assert fit(vidtrack_cli, run, "--model", "linear", "--no-report").returncode == 0
    assert (out / "report.html").is_file()


def test_fit_json_is_written_before_the_reports(fitted_run42):
    out = fitted_run42 / "vidtrack"                 # the module's fit, run42 from scratch
    fit_ns = (out / "fit.json").stat().st_mtime_ns
    assert fit_ns <= (out / "report.md").stat().st_mtime_ns
    assert fit_ns <= (out / "report.html").stat().st_mtime_ns
    stages = json.loads((out / "stages.json").read_text())
    assert stages["schema"] == 2
    assert set(stages["fit"]["files"]) == {"fit.json", "report.md", "report.html"}


def test_a_failed_rerun_leaves_no_output_that_looks_current(vidtrack_cli, tmp_path,
                                                           fitted_run42):
    run = shutil.copytree(fitted_run42, tmp_path / "run")     # its stages reused
    top = run / "top.avi"
    top.write_bytes(top.read_bytes()[:top.stat().st_size // 2])   # footage now truncated
    before = digest_tree(run)
    res = fit(vidtrack_cli, run)
    assert res.returncode == 2, res.stderr
    line = one_line(res)
    assert "view top" in line and "could not be decoded" in line
    assert outputs(run) in ([], ["stages.json"])
    assert digest_tree(run) == before


def test_a_failed_throw_leaves_no_mean_and_names_run_throw_and_view(vidtrack_cli, tmp_path,
                                                                   replicate_run):
    # the module's fitted run of two throws, copied with its outputs
    run = shutil.copytree(replicate_run[0], tmp_path / "run")
    for name in ("fit.json", "report.md", "report.html"):
        assert (run / "vidtrack" / name).is_file(), name
    top = run / "throws" / "02" / "top.avi"
    top.write_bytes(top.read_bytes()[:top.stat().st_size // 2])
    res = fit(vidtrack_cli, run)
    assert res.returncode == 2, res.stderr
    line = one_line(res)
    assert "run 'run'" in line and "throw 02" in line and "view top" in line
    assert line.count("throw 02") == 1                   # said once
    for name in ("fit.json", "report.md", "report.html"):
        assert not (run / "vidtrack" / name).exists(), name          # the run's mean
        assert not (run / "vidtrack" / "02" / name).exists(), name   # the failed throw
    assert not (run / "vidtrack" / "02" / "tracks.h5").exists()
    assert (run / "vidtrack" / "01" / "fit.json").is_file()          # a finished throw


def test_a_throws_own_exclusion_changes_that_throw_only(vidtrack_cli, tmp_path,
                                                       replicate_run):
    """throws/02/throw.toml excludes front frames of throw 02 alone: against the throws
    fitted without it (the module's fit), throw 02 loses exactly the usable front frames
    of the range from y (only the front view sees y), throw 01 fits as before, and the
    run's k is the mean of the two. A bad value there: one line naming the file and the
    key, exit 2, nothing written."""
    import pandas as pd

    base_run = replicate_run[0]
    base = {d: json.loads((base_run / "vidtrack" / d / "fit.json").read_text())
            for d in ("01", "02")}
    tracks = pd.read_csv(base_run / "vidtrack" / "02" / "tracks.csv")
    front = tracks[tracks["view"] == "front"]
    a, b = 100, 130
    usable = int(((front["frame"] >= a) & (front["frame"] < b) & (front["flags"] == 0)).sum())
    assert usable >= 20
    run = shutil.copytree(base_run, tmp_path / "run")
    own = run / "throws" / "02" / "throw.toml"
    own.write_text(f"[views.front]\nexclude_frames = [[{a}, {b}]]   # the straw behind "
                   "the hub\n")
    before = digest_tree(run)
    res = fit(vidtrack_cli, run, "--json")
    assert res.returncode == 0, res.stderr
    mean = json.loads(res.stdout)
    after = {d: json.loads((run / "vidtrack" / d / "fit.json").read_text())
             for d in ("01", "02")}
    assert after["02"]["points"]["y"] == base["02"]["points"]["y"] - usable
    assert after["02"]["views"]["front"]["flags"]["excluded"] == b - a
    assert after["01"]["points"] == base["01"]["points"]
    assert after["01"]["views"]["front"]["flags"]["excluded"] == 0
    for k in ("k1", "k2", "k3", "k4"):
        assert after["01"]["coefficients"][k]["value"] == base["01"]["coefficients"][k]["value"]
        assert mean["coefficients"][k]["value"] == pytest.approx(
            np.mean([after[d]["coefficients"][k]["value"] for d in ("01", "02")]))
    assert digest_tree(run) == before                             # inputs untouched
    own.write_text("[views.front]\nexclude_frames = [[130, 100]]\n")
    written = {p: p.read_bytes() for p in (run / "vidtrack").rglob("*") if p.is_file()}
    res = fit(vidtrack_cli, run)
    assert res.returncode == 2
    line = one_line(res)
    assert "throw 02" in line
    assert f"{own}: views.front.exclude_frames[0] must be a non-empty range" in line
    assert {p: p.read_bytes() for p in (run / "vidtrack").rglob("*") if p.is_file()} == written


# ---------------------------------------------------------------- found early (items 6, 7, 10, 12)

def test_a_fifo_as_footage_is_refused_without_reading_it(vidtrack_cli, tmp_path):
    run = run42_copy(tmp_path / "run")
    (run / "top.avi").unlink()
    os.mkfifo(run / "top.avi")
    t0 = time.monotonic()
    res = vidtrack_cli("fit", run, timeout=60)         # the old code blocked here
    assert res.returncode == 2, res.stderr
    assert "views.top.source" in one_line(res) and "is a FIFO" in one_line(res)
    assert time.monotonic() - t0 < 30
    assert not (run / "vidtrack").exists()


def test_a_frame_range_past_the_end_is_said_on_the_terminal(vidtrack_cli, tmp_path):
    run = run42_copy(tmp_path / "run", in_view("top", "frames", "[0, 5000]"))
    res = fit(vidtrack_cli, run, "--json")
    assert res.returncode == 0, res.stderr
    assert "view top: frames [0, 5000] runs past the last frame; using [0, 372]" in res.stderr
    assert any("runs past the last frame" in n for n in json.loads(res.stdout)["notes"])


def test_an_unreachable_scheduler_is_bad_input_said_in_one_line(vidtrack_cli, tmp_path):
    import socket

    with socket.socket() as s:                       # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    run = run42_copy(tmp_path / "run")
    t0 = time.monotonic()
    res = fit(vidtrack_cli, run, "--scheduler", f"tcp://127.0.0.1:{port}")
    assert res.returncode == 2, res.stderr
    assert f"--scheduler tcp://127.0.0.1:{port}: no dask scheduler answered" in one_line(res)
    assert time.monotonic() - t0 < 25
    assert not (run / "vidtrack").exists()


def test_sigterm_to_the_command_alone_ends_it_and_its_worker_quietly(tmp_path):
    """SIGTERM to the command only (not its process group): it stops as on Ctrl-C (exit
    130, the true message), the worker ends without a word, nothing half-written."""
    run = run42_copy(tmp_path / "run")
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.Popen([sys.executable, "-m", "vidtrack", "fit", str(run)], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    deadline = time.monotonic() + 30
    while (time.monotonic() < deadline
           and not [c for c in _session_members(proc.pid) if "spawn_main" in c]):
        time.sleep(0.05)
    time.sleep(0.5)                                  # the worker is tracking by now
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    time.sleep(0.5)
    assert "Traceback" not in err and "Error" not in err, err
    assert proc.returncode in (0, 130), err
    if proc.returncode == 130:
        assert "run the same command again" in err
        assert "no partial output was kept" not in err
    deadline = time.monotonic() + 10
    while _session_members(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert _session_members(proc.pid) == [], "a process outlived the command"
    assert not [p for p in (run / "vidtrack").rglob("*") if p.name.endswith(".part")] \
        if (run / "vidtrack").exists() else True
