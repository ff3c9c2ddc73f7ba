"""The views put on one clock whatever the shift of one footage (issue 41, item 6).

run42's top footage, as an image folder, shifted by 60 frames (60 still frames before
it): the shared-X search finds the shift to a hundredth of a frame and k4 is the
unshifted run's. The same footage rolled by 60 frames (its last 60 frames first: a
footage cut and spliced) leaves the top view 54 usable frames; the fit is honest (a
wide interval) and a note says why (z measured over 16 % of the flight only).
Each case tracks run42 once (about 10 s).
"""

import json
import shutil
from pathlib import Path

import pytest

from conftest import run_vidtrack

RUN42 = Path(__file__).resolve().parents[1] / "datasets" / "run42"
FPS = 1200.0


def _run_with_top(tmp_path, order):
    """run42 with its top view as an image folder of the frames ``order(n)`` lists."""
    run = tmp_path / "run"
    shutil.copytree(RUN42, run, ignore=shutil.ignore_patterns("vidtrack", "truth.json",
                                                              "vidtrack-synth.toml"))
    res = run_vidtrack("frames", run / "top.avi", tmp_path / "all", "--fps", FPS, "-q")
    assert res.returncode == 0, res.stderr
    frames = sorted((tmp_path / "all").glob("frame_*.png"))
    (run / "topimg").mkdir()
    for i, j in enumerate(order(len(frames))):
        shutil.copy(frames[j], run / "topimg" / f"frame_{i:06d}.png")
    scene = run / "scene.toml"
    scene.write_text(scene.read_text().replace('source = "top.avi"', 'source = "topimg"'))
    return run


def _fit(run):
    res = run_vidtrack("fit", run, "--json", "--no-report")
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout), res.stderr


def test_a_shift_of_60_frames_is_found(tmp_path):
    run = _run_with_top(tmp_path, lambda n: [0] * 60 + list(range(n)))
    record, _ = _fit(run)
    t0 = record["world"]["t0_s"]
    # run42's top view alone puts t = 0 0.0101 s after its first frame, like the front
    assert (t0["top"] - t0["front"]) * FPS == pytest.approx(60.0, abs=0.01)
    k4 = record["coefficients"]["k4"]
    assert k4["determined"] and k4["value"] == pytest.approx(21.30, rel=0.002)
    assert k4["stderr_fit"] < 0.03


def test_a_spliced_footage_is_said_to_cover_part_of_the_flight(tmp_path):
    run = _run_with_top(tmp_path, lambda n: [(i - 60) % n for i in range(n)])
    record, stderr = _fit(run)
    note = [n for n in record["notes"] if n.startswith("view top measures z over")]
    assert note and "% of the flight" in note[0], record["notes"]
    assert "note: world track: view top measures z over" in stderr
    k4 = record["coefficients"]["k4"]
    # what the 54 frames can tell: the truth within the interval, which is wide
    assert abs(k4["value"] - 21.3) < 2 * k4["stderr_fit"] and k4["stderr_fit"] > 0.5
