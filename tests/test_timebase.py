"""Time base checks: rates, time stamps, duplicated and dropped frames."""

import json

import cv2
import numpy as np
import pytest

from vidtrack.footage.cine import write_cine
from vidtrack.footage import open_source
from vidtrack.footage.timebase import (check_time_base, check_time_stamps, compare_rates,
                               estimate_noise_sigma, find_duplicates, frame_differences)


# ---------------------------------------------------------------------------------------
# Rates and stamps
# ---------------------------------------------------------------------------------------
def test_compare_rates():
    note = compare_rates(1200, 30)
    assert "30 fps" in note and "1200 fps" in note and "ratio 40" in note
    assert compare_rates(1200, 1200.5) is None
    assert compare_rates(None, 30) is None and compare_rates(1200, None) is None


def test_regular_stamps():
    check = check_time_stamps(np.arange(50) / 1200 + 3.0, nominal_fps=1200)
    assert check.decimation == 1 and check.dropped == () and check.warnings == ()
    assert check.fps_time_stamps == pytest.approx(1200, rel=1e-9)
    assert check.interval_s == pytest.approx(1 / 1200)


def test_quantised_stamps_give_the_rate_without_false_drops():
    t = np.floor(np.arange(1000) / 35087 * 1e6) / 1e6  # stamps to the microsecond
    check = check_time_stamps(t, nominal_fps=35087)
    assert check.dropped == () and check.decimation == 1
    # single intervals are 28 or 29 us; the mean is off by at most 1 us over the span
    assert check.fps_time_stamps == pytest.approx(35087, rel=1e-6 / (999 / 35087))


def test_dropped_frames_from_gaps():
    kept = np.delete(np.arange(50), [10, 11, 30])
    check = check_time_stamps(kept / 1000, nominal_fps=1000)
    # index 10 holds frame 12 (two missing before it); index 28 holds frame 31 (one missing)
    assert check.dropped == ((10, 2), (28, 1))
    assert check.fps_time_stamps == pytest.approx(1000, rel=1e-9)
    assert any("3 dropped frame(s) in 2 gap(s)" in w for w in check.warnings)


def test_decimation_is_recognised():
    check = check_time_stamps(np.arange(40) * 10 / 90000, nominal_fps=90000)
    assert check.decimation == 10
    assert check.fps_time_stamps == pytest.approx(9000)
    assert "decimated by 10" in check.warnings[0]


def test_disagreeing_rate_is_reported():
    check = check_time_stamps(np.arange(40) / 1000, nominal_fps=1234)
    assert check.decimation is None
    assert "1000 fps" in check.warnings[0] and "1234" in check.warnings[0]


def test_stamps_going_backwards():
    t = np.array([0.0, 1.0, 2.0, 2.0, 1.5, 5.0, 6.0]) * 1e-3
    check = check_time_stamps(t)
    assert check.not_increasing == (3, 4)
    assert "do not increase" in check.warnings[0]
    assert check_time_stamps([1.0]).fps_time_stamps is None
    json.dumps(check.to_dict())


# ---------------------------------------------------------------------------------------
# Noise and duplicates
# ---------------------------------------------------------------------------------------
def _textured(rows=120, cols=160):
    yy, xx = np.mgrid[0:rows, 0:cols]
    smooth = 90 + 40 * np.sin(xx / 17.0) + 30 * np.cos(yy / 11.0)
    blocks = 40.0 * (((xx // 20) + (yy // 20)) % 2)  # machine parts: sharp edges
    return smooth + blocks


@pytest.mark.parametrize("sigma", [0.7, 2.0, 5.0])
def test_noise_estimate(sigma):
    rng = np.random.default_rng(1)
    flat = 100 + rng.normal(0, sigma, (120, 160))
    assert estimate_noise_sigma(flat) == pytest.approx(sigma, rel=0.1)
    textured = _textured() + rng.normal(0, sigma, (120, 160))
    assert estimate_noise_sigma(textured) == pytest.approx(sigma, rel=0.3)
    assert estimate_noise_sigma(np.zeros((2, 5))) == 0.0


def noisy_static_scene(n, sigma, rng, *, flicker=0.0):
    base = _textured()
    frames = []
    for k in range(n):
        f = base * (1 + flicker * np.sin(2 * np.pi * k / 12)) + rng.normal(0, sigma, base.shape)
        frames.append(np.clip(np.round(f), 0, 255).astype(np.uint8))
    return frames


def test_static_scene_has_no_duplicates():
    frames = noisy_static_scene(40, 2.0, np.random.default_rng(2))
    assert find_duplicates(frame_differences(frames)) == ()


def test_low_noise_scene_with_strong_flicker_has_no_duplicates():
    # 100 Hz lamp flicker filmed at 1200 fps: brightness swings +-15 %, noise sigma 0.8
    frames = noisy_static_scene(48, 0.8, np.random.default_rng(3), flicker=0.15)
    assert find_duplicates(frame_differences(frames)) == ()


def test_exported_duplicates_are_found():
    rng = np.random.default_rng(4)
    frames = noisy_static_scene(40, 2.0, rng)
    for k in (5, 17, 18, 33):  # 17 and 18 both repeat frame 16
        frames[k] = frames[k - 1].copy()
    near = frames[25 - 1].copy()  # a re-encoded copy: a few pixels off by one
    idx = rng.choice(near.size, near.size // 200, replace=False)
    near.flat[idx] = np.clip(near.flat[idx].astype(int) + 1, 0, 255)
    frames[25] = near
    diffs = frame_differences(frames)
    assert find_duplicates(diffs) == (5, 17, 18, 25, 33)
    assert diffs.identical.sum() == 4
    assert diffs.mean_abs_diff.shape == (39,) and diffs.noise_sigma.shape == (40,)


def test_flat_frames_are_not_duplicates():
    rng = np.random.default_rng(5)
    frames = [np.zeros((120, 160), np.uint8)] * 3 + noisy_static_scene(5, 2.0, rng)
    assert find_duplicates(frame_differences(frames)) == ()


def test_bit_identical_frames_are_duplicates_even_without_noise():
    base = np.clip(_textured(), 0, 255).astype(np.uint8)
    assert find_duplicates(frame_differences([base, base, base])) == (1, 2)


def test_mismatched_shapes():
    with pytest.raises(ValueError, match="shape"):
        frame_differences([np.zeros((4, 4)), np.zeros((4, 5))])


# ---------------------------------------------------------------------------------------
# Through real sources
# ---------------------------------------------------------------------------------------
def test_duplicates_in_an_exported_video(tmp_path):
    """MJPG export of a noisy static scene in which frames 8 and 21 repeat their predecessor."""
    frames = noisy_static_scene(30, 2.0, np.random.default_rng(6))
    frames[8], frames[21] = frames[7], frames[20]
    path = tmp_path / "export.avi"
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (160, 120), False)
    for f in frames:
        w.write(f)
    w.release()
    with open_source(path, fps=1200) as src:
        report = check_time_base(src)
    assert report.duplicates == (8, 21)
    assert report.drops_checked is False and report.dropped == ()
    assert any("container claims 30 fps" in w for w in report.warnings)
    assert any("2 frame(s) repeat" in w for w in report.warnings)
    json.dumps(report.to_dict())
    with open_source(path) as src:
        report = check_time_base(src, duplicates=False)
    assert report.duplicates is None and report.time_source == "container"
    assert any("no capture rate given" in w for w in report.warnings)


def test_cine_report(tmp_path):
    rng = np.random.default_rng(7)
    frames = np.array(noisy_static_scene(20, 2.0, rng))
    frames[11] = frames[10]
    kept = np.delete(np.arange(21), [6])  # frame 6 dropped by the camera
    path = write_cine(tmp_path / "c.cine", frames, fps=5000, timestamps_s=kept / 5000)
    with open_source(path, fps=6000) as src:
        report = check_time_base(src)
    d = report.to_dict()
    json.dumps(d)
    assert report.time_source == "time stamps"
    assert report.dropped == ((6, 1),) and d["dropped"] == [{"frame": 6, "missing": 1}]
    assert report.duplicates == (11,)
    assert report.fps_time_stamps == pytest.approx(5000, rel=1e-6)
    assert any("given capture rate 6000 fps differs" in w for w in report.warnings)
    assert any("5000 fps but the nominal rate is 6000" in w for w in report.warnings)


def test_image_folder_without_rate(tmp_path):
    folder = tmp_path / "imgs"
    folder.mkdir()
    for k, f in enumerate(noisy_static_scene(3, 2.0, np.random.default_rng(8))):
        cv2.imwrite(str(folder / f"{k}.png"), f)
    with open_source(folder) as src:
        report = check_time_base(src)
    assert report.fps is None and any("no frame rate is known" in w for w in report.warnings)
