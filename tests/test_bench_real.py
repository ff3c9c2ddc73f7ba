"""``vidtrack bench track --real``: the tracker scoreboard (vidtrack/bench/real.py, scenes.py).

The scorers against hand-made references whose answer is known (a perfect track is 0 px
from them and gives their own figure; a track shifted by a known amount is that far),
and the real command as a subprocess on one small real clip (balltoss, from
``../shared``: skipped without it) and one synthetic scene, with a clip that is absent.
"""

import math
import os

import numpy as np
import pandas as pd
import pytest

from conftest import run_vidtrack
from vidtrack.bench import _score, real, scenes
from vidtrack.errors import VidtrackError


class _Track:
    """What the scorers read of a track: ``data`` (frame, t_s, u_px, v_px, flags) and
    ``usable``."""

    def __init__(self, frames, u, v, fps, flags=None):
        frames = np.asarray(frames, dtype=int)
        flags = np.zeros(frames.size, int) if flags is None else np.asarray(flags, int)
        self.data = pd.DataFrame({"frame": frames, "t_s": frames / fps, "u_px": u,
                                  "v_px": v, "flags": flags})

    @property
    def usable(self):
        d = self.data
        return ((d["flags"].to_numpy() == 0) & np.isfinite(d["u_px"].to_numpy())
                & np.isfinite(d["v_px"].to_numpy()))


# ------------------------------------------------------------------- the fits

def test_quadratic_accel_and_two_arc_fit_recover_known_curvatures():
    t = np.linspace(0.0, 0.3, 40)
    assert _score.quadratic_accel(t, 1.0 + 2.0 * t - 0.5 * 9.81 * t ** 2) == \
        pytest.approx(-9.81, rel=1e-9)
    assert math.isnan(_score.quadratic_accel(t[:3], t[:3]))
    # rows: an apex at 0.12 s, 3000 px/s^2 up and 2700 down (k2/k1 = 0.9)
    ta, v = 0.12, np.empty_like(t)
    v[t < ta] = 100.0 + 0.5 * 3000.0 * (t[t < ta] - ta) ** 2
    v[t >= ta] = 100.0 + 0.5 * 2700.0 * (t[t >= ta] - ta) ** 2
    assert _score.descent_over_ascent(t, v) == pytest.approx(0.9, rel=1e-6)
    assert math.isnan(_score.descent_over_ascent(t, 5.0 * t))      # no apex
    assert _score.accel_2d(t, 3.0 * t ** 2, 4.0 * t ** 2) == pytest.approx(10.0)


def test_linear_drag_k_recovers_k():
    t = np.arange(60) / 60.0
    g, k, v0 = 9.81, 0.8, -0.2
    y = 4.0 - g / k * t + (v0 + g / k) * (1.0 - np.exp(-k * t)) / k
    assert _score.linear_drag_k(t, y, g=g) == pytest.approx(k, rel=1e-5)


# ------------------------------------------------------------------- the scorers

def _launcher_ref():
    frames = np.arange(259, 330)
    t = (frames - 259) / 240.0
    u = 35.8 + 800.0 * t
    v = 89.5 - 400.0 * t + 0.5 * 3066.0 * t ** 2            # apex at 0.13 s, drag-free
    return pd.DataFrame({"frame": frames, "u_px": u, "v_px": v})


def test_launcher_perfect_track_is_0_px_and_ratio_1_and_a_shift_is_its_size():
    ref = _launcher_ref()
    frames = np.arange(0, 663)
    u = np.full(frames.size, np.nan)
    v = np.full(frames.size, np.nan)
    u[259:330], v[259:330] = ref["u_px"], ref["v_px"]
    row = real.score_launcher(_Track(frames, u, v, 240.0), ref).to_row()
    assert row["flight_frames"] == row["unflagged"] == row["scored"] == 71
    assert row["max_px"] == pytest.approx(0.0, abs=1e-9)
    assert row["fit_ref"] == pytest.approx(1.0, rel=1e-6)
    assert row["fit_ratio"] == pytest.approx(1.0, rel=1e-6)
    # 0.6 px to the right, every second frame flagged: 0.6 px, 36 of 71, k2/k1 still 1
    flags = np.zeros(frames.size, int)
    flags[259:330:2] = 1
    row = real.score_launcher(_Track(frames, u + 0.6, v, 240.0, flags), ref).to_row()
    assert row["unflagged"] == 35 and row["unflagged_frac"] == pytest.approx(35 / 71)
    assert row["median_px"] == pytest.approx(0.6) and row["p95_px"] == pytest.approx(0.6)
    assert row["fit_ratio"] == pytest.approx(1.0, rel=1e-6)
    assert row["fit_ref_same"] == pytest.approx(1.0, rel=1e-6)


def test_balltoss_offset_and_scales_found_and_g_read_in_metres():
    t = np.arange(22) / 30.0
    x = -0.5 + 1.2 * t
    y = 2.5 * t - 0.5 * 9.9 * t ** 2
    ref = np.column_stack([t, x, y])
    n, off, px_per_m = 32, 7, 420.0
    frames = np.arange(n)
    u = np.full(n, np.nan)
    v = np.full(n, np.nan)
    u[off:off + 22] = 300.0 + 410.0 * x                    # its own scale across
    v[off:off + 22] = 350.0 - px_per_m * y
    u[2:off], v[2:off] = 60.0, 300.0                       # the hand, flagged
    flags = np.zeros(n, int)
    flags[2:off] = 1
    score = real.score_balltoss(_Track(frames, u, v, 30.0, flags), ref)
    row = score.to_row()
    assert "frame 7" in score.note and "420.0 px/m" in score.note
    assert row["unflagged"] == 22 and row["max_px"] == pytest.approx(0.0, abs=1e-6)
    assert row["fit_ref"] == pytest.approx(9.9, rel=1e-9)
    assert row["fit_ratio"] == pytest.approx(1.0, rel=1e-9)


def test_bear_offset_and_scale_found_vertical_distance_and_drag_k():
    frames = np.arange(1, 56)
    tt = frames / 60.0
    k, g = 0.35, 9.81
    y = 4.28 - g / k * tt + g / k * (1.0 - np.exp(-k * tt)) / k
    ref = pd.DataFrame({"Frame": frames, "Y_metros": y})
    n = 59
    v = np.full(n, np.nan)
    v[frames - 1] = 200.0 - 210.0 * y                      # their frame k is ours k - 1
    u = np.where(np.isfinite(v), 540.0, np.nan)
    score = real.score_bear(_Track(np.arange(n), u, v, 60.0), ref)
    row = score.to_row()
    assert "offset -1" in score.note and "210.0 px/m" in score.note
    assert row["rms_px"] == pytest.approx(0.0, abs=1e-6)
    assert row["fit_ref"] == pytest.approx(k, rel=1e-4)
    assert row["fit_ratio"] == pytest.approx(1.0, rel=1e-6)


def test_diabolo_offset_of_the_marked_spot_taken_out():
    frames = np.arange(410)
    t = frames / 240.0
    ru, rv = 457.0 + 900.0 * t, 500.0 - 700.0 * t + 0.5 * 4000.0 * t ** 2
    ref = np.column_stack([frames, t, ru, rv])
    tr = _Track(frames, ru + 2.0, rv - 3.3, 240.0)
    score = real.score_diabolo(tr, ref)
    row = score.to_row()
    assert row["flight_frames"] == 409 and "(+2.0, -3.3)" in score.note
    assert row["max_px"] == pytest.approx(0.0, abs=1e-9)
    assert row["fit_ref"] == pytest.approx(4000.0 / 459.448, rel=1e-9)
    assert row["fit_ratio"] == pytest.approx(1.0, rel=1e-9)


def test_badminton_plain_distance_to_the_labels():
    frames = np.arange(732, 872)
    t = frames / 119.12
    lab = pd.DataFrame({"Frame": frames, "X": 900.0 + 300 * (t - t[0]),
                        "Y": 600.0 - 200 * (t - t[0]) + 150 * (t - t[0]) ** 2})
    tr = _Track(frames, lab["X"] - 3.0, lab["Y"] + 4.0, 119.12)
    row = real.score_badminton(tr, lab).to_row()
    assert row["median_px"] == pytest.approx(5.0) and row["unflagged"] == 140
    assert row["fit_ref"] == pytest.approx(300.0, rel=1e-9)
    assert row["fit_ratio"] == pytest.approx(1.0, rel=1e-9)


def test_synthetic_view_scored_on_clean_frames_against_the_coverage_centroid():
    n = 40
    t = np.arange(n) / 1200.0
    u, v = 10.0 + 2000.0 * t, 50.0 + 3000.0 * t ** 2
    phase = ["blade"] * 5 + ["flight"] * 35
    overlap = [False] * n
    overlap[20] = True                                       # another straw: not clean
    per_frame = {"frame": list(range(n)), "t_s": list(t), "phase": phase,
                 "u_coverage_px": list(u), "v_coverage_px": list(v),
                 "fully_in_view": [True] * n, "blade_overlap": [False] * n,
                 "overlap": overlap}
    tu, tv = u.copy(), v.copy()
    tu[20] += 9.0                                            # off where not clean
    row = scenes.score_view(_Track(np.arange(n), tu, tv, 1200.0),
                            {"per_frame": per_frame}).to_row()
    assert row["flight_frames"] == 35 and row["unflagged"] == 35 and row["scored"] == 34
    assert row["max_px"] == pytest.approx(0.0, abs=1e-9)
    assert row["fit_ratio"] == pytest.approx(1.0, rel=1e-9)


def test_cases_and_clip_names():
    assert {"shadow", "arm_along", "small_dark_highlight"} <= set(scenes.CASES)
    assert real.select_clips("synth:shadow") == ["synth:shadow/front", "synth:shadow/top"]
    assert real.select_clips("bear,balltoss") == ["balltoss", "oso_sin_globo",
                                                  "oso_globo_grande"]
    with pytest.raises(VidtrackError, match="no clip 'nonsense'"):
        real.select_clips("nonsense")
    with pytest.raises(VidtrackError, match="--engine nope"):
        real.engines_to_run(["nope"])
    assert "rules" in real.engines_to_run()


def test_an_engine_refusing_or_raising_is_a_row_not_the_end_of_the_run():
    def refused():
        raise VidtrackError("front: no usable point\nmore")

    def broken():
        raise ValueError("a bug")

    tr, timing, status, msg = _score.timed_track(refused, "rules", view="front", repeats=2,
                                                 warmup=0)
    assert tr is None and status == "failed" and msg == "front: no usable point"
    assert timing.calls == 2 and timing.cpu_min_s >= 0.0 and timing.wall_min_s >= 0.0
    tr, *_, status, msg = _score.timed_track(broken, "rules", view="front", repeats=1,
                                             warmup=0)
    assert tr is None and status == "error" and msg == "ValueError: a bug"


# ------------------------------------------------------------------- the command

COLUMNS = ["clip", "engine", "status", "flight_frames", "unflagged", "median_px", "p95_px",
           "max_px", "rms_px", "fit", "fit_track", "fit_ref", "fit_ratio", "fit_ref_same",
           "track_cpu_s",
           "decode_cpu_s", "x_decode", "note", "track_cpu_median_s", "track_wall_median_s",
           "decode_wall_s", "x_decode_wall", "calls"]


def test_scoreboard_on_balltoss_and_a_synthetic_scene_launcher_absent(real_footage,
                                                                       tmp_path):
    # a shared folder holding only the balltoss (a link to it: nothing copied)
    shared = tmp_path / "shared"
    (shared / "data" / "real").mkdir(parents=True)
    os.symlink(real_footage / "balltoss", shared / "data" / "real" / "balltoss")
    out = tmp_path / "out"
    res = run_vidtrack("bench", "track", "--real", "--engine", "rules", "--shared", shared,
                       "--clips", "balltoss,launcher,synth:shadow/front", "--out", out,
                       "--repeats", "1", "--warmup", "0")
    assert res.returncode == 0, res.stderr
    assert "skipped launcher:" in res.stdout and "not there" in res.stdout
    for head in ("clip", "engine", "unflagged", "median px", "p95 px", "max px", "fit",
                 "cpu s", "wall s", "x decode", "the min of 1 warm call(s)"):
        assert head in res.stdout
    table = pd.read_csv(out / "bench_track_real.csv")
    assert list(table.columns[:3]) == ["clip", "engine", "status"]
    assert set(COLUMNS) <= set(table.columns)
    rows = table.set_index("clip")
    assert rows.loc["launcher", "status"] == "skipped"
    for clip in ("balltoss", "synth:shadow/front"):
        r = rows.loc[clip]
        assert r["status"] == "ok" and r["engine"] == "rules"
        for col in ("median_px", "p95_px", "max_px", "fit_track", "fit_ref", "fit_ratio",
                    "fit_ref_same", "track_cpu_s", "decode_cpu_s", "x_decode"):
            assert np.isfinite(r[col]), (clip, col)
        assert 0 < r["unflagged"] <= r["flight_frames"]
        assert r["calls"] == 1
        assert r["median_px"] <= r["p95_px"] <= r["max_px"]
    # what tests/test_real_footage.py holds the ball to: g within 2 % of the reference's
    assert rows.loc["balltoss", "fit"] == "g m/s2"
    assert rows.loc["balltoss", "fit_ratio"] == pytest.approx(1.0, abs=0.02)
    assert rows.loc["synth:shadow/front", "max_px"] < 1.0


def test_scoreboard_without_footage_skips_saying_so(tmp_path):
    res = run_vidtrack("bench", "track", "--real", "--shared", tmp_path / "nowhere",
                       "--clips", "balltoss,diabolo", "--out", tmp_path / "out", "-q")
    assert res.returncode == 0, res.stderr
    assert "skipped balltoss:" in res.stdout and "skipped diabolo:" in res.stdout
    table = pd.read_csv(tmp_path / "out" / "bench_track_real.csv")
    assert (table["status"] == "skipped").all() and len(table) == 2


@pytest.mark.parametrize("args", [["--clips", "balltoss"],
                                  ["--real", "--clips", "nonsense"],
                                  ["--real", "--engine", "nope"]])
def test_scoreboard_options_misused_exit_2(tmp_path, args):
    res = run_vidtrack("bench", "track", *args, "--out", tmp_path / "out")
    assert res.returncode == 2, res.stderr
    assert not (tmp_path / "out" / "bench_track_real.csv").exists()


def test_scoreboard_without_a_folder_of_real_footage_skips_the_real_clips(tmp_path):
    res = run_vidtrack("bench", "track", "--real", "--clips", "balltoss,launcher",
                       "--out", tmp_path / "out", "-q")
    assert res.returncode == 0, res.stderr
    table = pd.read_csv(tmp_path / "out" / "bench_track_real.csv")
    assert (table["status"] == "skipped").all() and len(table) == 2
    assert "no folder of real footage given (--shared DIR" in res.stdout
