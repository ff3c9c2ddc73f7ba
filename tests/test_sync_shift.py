"""The views put on one clock whatever the shift of one footage (issue 41, item 6).

run42's top footage, as an image folder, shifted by 60 frames (60 still frames before
it): the shared-X search finds the shift within what the render's centroids allow
(0.007 frame off with the flight tracker's tracks, against a bound of 0.14 frame) and
k4 is the unshifted run's. Cut in three and spliced in reverse order, no piece shows
half the flight: the fit is honest (a wider interval) and a note says why (z measured
over 31 % of the flight only). Each case tracks run42 once (about 10 s).
"""

import json
import shutil
from pathlib import Path

import numpy as np
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


def _truth():
    return json.loads((RUN42 / "truth.json").read_text())


def _sync_bound_frames():
    """How far from the truth the shared X may put a view's clock, in frames, by the
    render's own account: each view's coverage centroid may sit up to 1 / (8 w) px
    off the straw's centre (truth.json's conventions, w its width in px), so the views
    may disagree on X by the sum, which the offset search takes for a shift of time at
    the X speed; bounded at the slowest X speed of the flight in either view
    (0.060 px at 0.43 px/frame: 0.14 frame)."""
    tr = _truth()
    bias = 0.0
    speeds = []
    for v in ("front", "top"):
        view = tr["views"][v]
        bias += 1.0 / (8.0 * 2.0 * view["straw_radius_px"])
        pf = view["per_frame"]
        flight = np.asarray(pf["frame"]) >= view["release_frame"]
        speeds.append(float(np.min(np.diff(np.asarray(pf["u_px"], float)[flight]))))
    speed = min(speeds)
    assert speed > 0
    return bias / speed


def _shift_frames(record):
    t0 = record["world"]["t0_s"]
    return (t0["top"] - t0["front"]) * FPS


def test_a_shift_of_60_frames_is_found(tmp_path):
    run = _run_with_top(tmp_path, lambda n: [0] * 60 + list(range(n)))
    record, stderr = _fit(run)
    # the truth: both views rendered on one clock (truth.json: top_delay_s 0, the same
    # release frame), the top one 60 frames later here; found 59.993 (0.007 frame off;
    # 59.979 while the scales moved on a difference the refined ratio did not show)
    assert _shift_frames(record) == pytest.approx(60.0, abs=_sync_bound_frames())
    assert "measures z over" not in stderr
    k4 = record["coefficients"]["k4"]
    assert k4["determined"] and k4["value"] == pytest.approx(21.30, rel=0.002)
    # the shift costs no precision: z over the whole flight, as unshifted. Measured with
    # the flight tracker's tracks: 0.033 here, 0.039 on the unshifted footage (the bound
    # of 0.03 was measured on the rules tracker's); the footage cut in three below, 0.31
    assert abs(k4["value"] - 21.3) < 2 * k4["stderr_fit"] < 0.1


def test_a_spliced_footage_is_said_to_cover_part_of_the_flight(tmp_path):
    def thirds_reversed(n):
        return list(range(2 * n // 3, n)) + list(range(n // 3, 2 * n // 3)) + \
            list(range(n // 3))

    run = _run_with_top(tmp_path, thirds_reversed)
    record, stderr = _fit(run)
    tr = _truth()
    n = tr["views"]["top"]["frames"]
    rows = record["world"]["rows"]
    # the truth: each third (124 frames) shows under half the flight's 360 rows, in
    # place (shift 0: the middle third), 248 frames late (the first) or 248 early (the
    # last); the kept third is put on the clock at its own shift (measured: the first,
    # 247.989)
    shift = _shift_frames(record)
    third = n // 3
    assert min(abs(shift - s) for s in (-2 * third, 0, 2 * third)) < _sync_bound_frames()
    z = record["world"]["measured"]["z"]
    assert z <= third < rows / 2                              # 111 measured
    note = [x for x in record["notes"] if x.startswith("view top measures z over")]
    assert note and "% of the flight" in note[0], record["notes"]
    assert f"({z} of {rows} rows, " in note[0]
    assert "note: world track: view top measures z over" in stderr
    k4 = record["coefficients"]["k4"]
    # what a third of the flight can tell: the truth within the interval, which is
    # wider than the whole flight's (0.31 measured, against 0.033..0.039)
    assert abs(k4["value"] - 21.3) < 2 * k4["stderr_fit"] and k4["stderr_fit"] > 0.1
