"""The straw's attitude (vidtrack.world.attitude): its 3-D axis per frame and the rate it
turns at.

Truth the code did not make:

- closed forms: orthographic views' planes built here from known axes give the axes
  back; an axis turning about a fixed axis at ``w``, at ``a`` to it, turns at
  ``w sin a``; a rod's ends give its image angle;
- ``vidtrack synth`` footage (truth.json's per-frame ``axis_x, axis_y, axis_z`` and
  ``spin_rad_s``, ``spin_axis``) fitted by the real command line: the axis in world.csv
  and tracks.h5 within 2 degrees RMS of truth.json's, the turn rate within 1 % of it,
  for orthographic front/top views and for calibrated cameras at 60 degrees and 1 m
  (where k3 also comes back within 1 %), tracked by either engine (the flight tracker
  gives the rod's ends).
"""

import json
import math

import h5py
import numpy as np
import pandas as pd
import pytest

from tests.conftest import run_vidtrack
from vidtrack.run.tracks_file import read_tracks
from vidtrack.world.attitude import (ATTITUDE_COLUMNS, MAX_WINDOW_SPREAD, MIN_PLANE_ANGLE_DEG,
                                     TURN_HALF_WINDOW_ROWS, axis_from_planes, image_angle,
                                     turn_rate)

#: The issue's bound on the attitude: RMS angle to truth.json's axis (degrees).
ATTITUDE_RMS_DEG = 2.0
#: The median turn rate against truth's (relative). Measured: 0.13 % (orthographic, seed
#: 3, 320x150 px), 0.11 % (calibrated, 60 degrees, 1 m, seed 1).
SPIN_REL = 0.01
#: The issue's bound on k3 with calibrated cameras at 60 degrees and 1 m (relative);
#: measured +0.43 % (seed 1; -1.38 % without the rod correction).
K3_REL = 0.01
#: Most rows of a flight whose axis may go unmeasured (a rod end on to a view, or lying in
#: the plane of both views' sight lines); measured 24 % (orthographic), 11 % (calibrated).
UNMEASURED_SHARE = 0.35
#: Closed forms hold to rounding.
EXACT = 1e-9


def _unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _orthographic_normals(axis):
    """The front (sees X, Y; looks along Z) and top (X, Z; along Y) views' planes through
    a rod of the given axes: each holds the view's line of sight and the rod's image."""
    out = []
    for sight, seen in ((2, (0, 1)), (1, (0, 2))):
        line = np.zeros_like(axis)
        line[:, seen] = axis[:, seen]
        e = np.zeros(3)
        e[sight] = 1.0
        n = np.cross(e, line)
        with np.errstate(invalid="ignore"):
            n = n / np.linalg.norm(n, axis=1, keepdims=True)
        out.append(n)
    return np.stack(out, axis=1)


def _angle_deg(a, b):
    return np.degrees(np.arccos(np.clip(np.abs(np.einsum("ni,ni->n", a, b)), 0.0, 1.0)))


def test_two_orthographic_views_give_the_axis_back():
    rng = np.random.default_rng(7)
    axis = _unit(rng.normal(size=(200, 3)))
    got, angle = axis_from_planes(_orthographic_normals(axis))
    ok = angle >= MIN_PLANE_ANGLE_DEG
    assert ok.mean() > 0.8                               # most random axes are determined
    assert np.all(_angle_deg(got[ok], axis[ok]) < EXACT ** 0.5)   # acos near 1: sqrt
    np.testing.assert_allclose(np.abs(np.einsum("ni,ni->n", got[ok], axis[ok])), 1.0,
                               atol=EXACT)
    assert np.all(np.isnan(got[~ok]))


def test_an_axis_the_views_cannot_fix_is_nan():
    # in the Y-Z plane both views' planes are that plane (front: the image is along Y,
    # top: along Z); along Y the top view sees the rod end on (no line): one plane
    axis = _unit(np.array([[0.0, 0.6, 0.8], [0.0, 1.0, 0.0]]))
    normals = _orthographic_normals(axis)
    normals[1, 1] = np.nan
    got, angle = axis_from_planes(normals)
    assert np.isnan(got).all()
    assert angle[0] < MIN_PLANE_ANGLE_DEG and angle[1] == 0.0


@pytest.mark.parametrize("rate, tilt_deg, fps", [(16.46, 90.0, 1200.0), (40.0, 35.0, 500.0),
                                                 (120.0, 60.0, 250.0)])
def test_turn_rate_is_the_spin_times_the_sine_of_the_tilt(rate, tilt_deg, fps):
    # a rod at tilt_deg to a fixed spin axis turns at rate * sin(tilt); the sense of each
    # row is random (a rod's ends look alike), and a gap of a few rows is left unmeasured
    rng = np.random.default_rng(3)
    t = np.arange(120) / fps
    tilt = math.radians(tilt_deg)
    spin = _unit([0.2, 0.3, 1.0])
    e1 = _unit(np.cross(spin, [1.0, 0.0, 0.0]))
    e2 = np.cross(spin, e1)
    phase = rate * t
    axis = (math.cos(tilt) * spin + math.sin(tilt) * (np.cos(phase)[:, None] * e1
                                                      + np.sin(phase)[:, None] * e2))
    axis *= rng.choice([-1.0, 1.0], size=(len(t), 1))
    axis[50:53] = np.nan
    got = turn_rate(axis, t)
    assert np.isnan(got[50:53]).all()
    # every other row has a rate, but for the two beside the gap where the axis turns by
    # near a right angle across it (the fastest case)
    assert np.isfinite(np.delete(got, [49, 50, 51, 52, 53])).all()
    # the great-circle angle between the window's axes, 2 asin(sin(tilt) sin(d / 2)) for
    # a turn d about the spin axis, is sin(tilt) d at a right angle and at most d^2 / 24
    # (relative) short of it otherwise
    ratio = got[np.isfinite(got)] / (rate * math.sin(tilt))
    widest = rate * 2 * TURN_HALF_WINDOW_ROWS * MAX_WINDOW_SPREAD / fps
    if tilt_deg == 90.0:
        np.testing.assert_allclose(ratio, 1.0, rtol=EXACT)
    assert np.all(ratio <= 1.0 + EXACT) and np.all(ratio >= 1.0 - widest ** 2 / 24 - EXACT)


def test_a_rods_ends_give_its_image_angle():
    data = pd.DataFrame({"angle_rad": [0.3, 0.3, 0.3],
                         "end1_u_px": [10.0, 10.0, np.nan], "end1_v_px": [5.0, 5.0, np.nan],
                         "end2_u_px": [0.0, 10.0, np.nan], "end2_v_px": [0.0, 0.0, np.nan]})
    # (-10, -5) from end 1 to end 2: the line at atan(0.5); (0, -5): upright, pi/2
    np.testing.assert_allclose(image_angle(data), [math.atan(0.5), math.pi / 2, 0.3],
                               rtol=0, atol=EXACT)
    np.testing.assert_array_equal(image_angle(data[["angle_rad"]]), [0.3] * 3)


# ---------------------------------------------------------------------- end to end

def _truth_axis_at(truth, view, frames):
    pf = truth["views"][view]["per_frame"]
    return np.column_stack([pf["axis_x"], pf["axis_y"], pf["axis_z"]])[frames]


def _check_attitude(run, truth):
    """world.csv and tracks.h5 hold the attitude, within the issue's bounds of truth."""
    out = run / "vidtrack"
    csv = pd.read_csv(out / "world.csv")
    assert list(csv.columns[:4]) == ["t_s", "x_m", "y_m", "z_m"]
    assert list(csv.columns[-4:]) == list(ATTITUDE_COLUMNS)
    with h5py.File(out / "tracks.h5", "r") as h:
        for c in ATTITUDE_COLUMNS:
            assert h["world"][c].attrs["units"] in ("1", "rad/s")
            assert h["world"][c].attrs["meaning"]
            np.testing.assert_array_equal(h["world"][c][()], csv[c].to_numpy(), strict=False)
    world = read_tracks(out / "tracks.h5").world
    data = world.data
    frames = data["frame"].to_numpy()
    axis = data[list(ATTITUDE_COLUMNS[:3])].to_numpy()
    ok = np.all(np.isfinite(axis), axis=1) & (frames >= 0)
    assert ok.mean() >= 1.0 - UNMEASURED_SHARE
    np.testing.assert_allclose(np.linalg.norm(axis[ok], axis=1), 1.0, atol=EXACT)
    true_axis = _truth_axis_at(truth, world.reference, frames[ok])
    err = _angle_deg(axis[ok], true_axis)
    assert math.sqrt(np.mean(err ** 2)) < ATTITUDE_RMS_DEG, np.sqrt(np.mean(err ** 2))
    spin = truth["truth"]
    about = _unit(spin["spin_axis"])
    true_rate = spin["spin_rad_s"] * np.sqrt(1.0 - (true_axis @ about) ** 2)
    rate = data["spin_rad_s"].to_numpy()[ok]
    assert np.nanmedian(rate) == pytest.approx(np.median(true_rate), rel=SPIN_REL)
    record = json.loads((out / "fit.json").read_text())
    att = record["world"]["attitude"]
    assert att["rows_measured"] == int(np.all(np.isfinite(axis), axis=1).sum())
    assert att["spin_rad_s_median"] == pytest.approx(np.median(true_rate), rel=SPIN_REL)
    assert "Attitude" in (out / "report.html").read_text()
    return record


def test_orthographic_views_give_the_straws_attitude(tmp_path):
    run = tmp_path / "ortho"
    made = run_vidtrack("synth", run, "--size", "320x150", "--seed", "3", "-q")
    assert made.returncode == 0, made.stderr
    fit = run_vidtrack("fit", run, "-q")
    assert fit.returncode == 0, fit.stderr
    _check_attitude(run, json.loads((run / "truth.json").read_text()))


def test_calibrated_cameras_at_60_degrees_give_attitude_and_k3(tmp_path):
    # the rig the straw's perspective biased most (vidtrack bench perspective's first)
    run = tmp_path / "sixty"
    made = run_vidtrack("synth", run, "--cameras", "perspective", "--camera-angle-deg", "60",
                        "--camera-distance-m", "1", "--size", "400x300", "--flight-s", "0.3",
                        "--straw-length-m", "0.12", "--straw-diameter-m", "0.02",
                        "--distortion=-0.12,0.03,0.0005,-0.0003,0", "--seed", "1", "-q")
    assert made.returncode == 0, made.stderr
    fit = run_vidtrack("fit", run, "-q")
    assert fit.returncode == 0, fit.stderr
    truth = json.loads((run / "truth.json").read_text())
    record = _check_attitude(run, truth)
    k3 = record["coefficients"]["k3"]["value"]
    assert k3 == pytest.approx(truth["truth"]["k"]["k3"], rel=K3_REL)
    # the flight tracker gives the rod's two ends: the image lines are theirs
    scene = run / "scene.toml"
    scene.write_text(scene.read_text() + '\n[track]\nengine = "flight"\n')
    fit = run_vidtrack("fit", run, "-q", "--force")
    assert fit.returncode == 0, fit.stderr
    assert "end1_u_px" in read_tracks(run / "vidtrack" / "tracks.h5").tracks["cam1"].data
    record = _check_attitude(run, truth)
    k3 = record["coefficients"]["k3"]["value"]
    assert k3 == pytest.approx(truth["truth"]["k"]["k3"], rel=K3_REL)
