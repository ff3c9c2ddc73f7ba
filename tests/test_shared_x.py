"""The views' scales measured on the shared X (vidtrack/world/shared_x.py), through the CLI.

A render's rulers are exact; reading the top view's ruler a little long makes its X
shorter by a known factor, length / (length + misread). The fit must measure that
factor on the shared X, say which view and how much, reconcile the scales and fit on,
with k inside its interval; a wrong fps (no reading error explains it) is still refused.
"""

import json
import re
import shutil

import pytest

from synth_runs import synth_run, truth

K = ("k1", "k2", "k3", "k4")

#: A render as wide as the rotor and flight allow against its ruler: the 0.5 m ruler
#: spans 128 px, the flight 452 px of X (vidtrack.synth places a ruler of 0.2 to 0.4 of
#: the frame's width). Read 0.6 px long the top view's X is 0.47 % short and the views
#: disagree by 0.98 px RMS (just under the cross-check's 1 px); read 1.0 px long, by
#: 1.6 px, and the views were refused.
WIDE = {"size_px": (640, 240), "top_size_px": (640, 160), "m_per_px": 0.0039,
        "flight_s": 0.4, "frames": None, "seed": 5}


@pytest.fixture(scope="module")
def wide(tmp_path_factory):
    """The :data:`WIDE` render fitted once (its rulers exact): the tests copy it with its
    outputs, so that views.h5 gives each view's tracks wherever the tracker would read
    the same (a ruler is read by the world track only)."""
    from conftest import run_vidtrack

    out = tmp_path_factory.mktemp("wide") / "run"
    shutil.copytree(synth_run("shared-x-wide", **WIDE), out)
    res = run_vidtrack("fit", out, "-q", "--no-report")
    assert res.returncode == 0, res.stderr
    return out


def _misread(run, tmp_path, name, du, key="to_px"):
    """A copy of ``run`` whose top ruler's ``key`` end is read ``du`` px further along u."""
    out = tmp_path / name
    shutil.copytree(run, out)
    text = (out / "scene.toml").read_text()
    at = text.index("[views.top.ruler]")
    m = re.compile(key + r" = \[([-0-9.e]+), ").search(text, at)
    (out / "scene.toml").write_text(text[:m.start(1)] + repr(float(m.group(1)) + du)
                                    + text[m.end(1):])
    return out


def _ruler_px(run, view):
    text = (run / "scene.toml").read_text()
    at = text.index(f"[views.{view}.ruler]")
    a = float(re.compile(r"from_px = \[([-0-9.e]+), ").search(text, at).group(1))
    b = float(re.compile(r"to_px = \[([-0-9.e]+), ").search(text, at).group(1))
    return abs(b - a)


@pytest.mark.parametrize("du", [0.6, 1.0])
def test_a_top_ruler_read_long_is_measured_reconciled_and_fitted(tmp_path, vidtrack_cli, du,
                                                                 wide):
    run = wide
    moved = _misread(run, tmp_path, "moved", du)
    r = vidtrack_cli("fit", str(moved), "--json", "--no-report")
    assert r.returncode == 0, r.stderr
    record = json.loads(r.stdout)
    assert record["stages_reused"] == ["views"]
    shared = record["world"]["shared_x"]
    # the truth: the top view's X times N / (N + du) against the front's exact scale
    n = _ruler_px(run, "top")
    expected = n / (n + du)
    assert shared["reference"] == "front" and shared["other"] == "top"
    assert shared["ratio"] == pytest.approx(expected, abs=max(5 * shared["ratio_se"], 1e-4))
    assert shared["reconciled"]
    # the scales moved towards each other, and the views agree on X again
    assert shared["factors"]["top"] > 1.0 > shared["factors"]["front"]
    assert record["world"]["x_rms_px"] < 0.2
    # the note names the view, the percentage and the ruler reading (on stderr and kept)
    pct = f"{100 * (1 - shared['ratio']):.2g} %"
    said = [x for x in record["notes"] if "shared X" in x]
    assert said and "top view" in said[0] and pct in said[0] and "px long" in said[0]
    assert "top view sees the shared X" in r.stderr and pct in r.stderr
    # k inside its interval (the calibration's part: that of the reconciled scales)
    true_k = truth(run)["truth"]["k"]
    for k in K:
        c = record["coefficients"][k]
        assert c["ci95_total"][0] <= true_k[k] <= c["ci95_total"][1], (k, c, true_k[k])
    assert record["calibration"]["reconciled"]
    rec = record["calibration"]["views"]
    for v in ("front", "top"):
        # what the shared X cannot tell: both scales wrong by the same factor, smaller
        # than either ruler's own uncertainty
        assert rec[v]["scale_rel_uncertainty_reconciled"] < rec[v]["scale_rel_uncertainty"]


def test_the_views_of_run42_agree_and_keep_their_scales_as_read(tmp_path, vidtrack_cli):
    """run42's rulers are exact, so the views' true relative scale is 1. What the tracks
    show of it is bounded by the render: each view's coverage centroid may sit up to
    1 / (8 w) px off the straw's centre (truth.json's conventions, w the straw's width),
    and a disagreement e of the views' X with |e| <= B fits a slope of at most
    B mean|x - mean x| / var(x) over the flight's X (7.8e-4 here). With the flight
    tracker's tracks the ratio is 0.99996 +- 0.00003 (1.4 standard errors of 1; the
    first estimate, on a clock found with the scales as given, 0.99994, 2.1): no
    difference the points can tell, so nothing moved and nothing said. Whether a
    difference this small is seen is not what the render promises (the standard error
    counts the tracks' noise, not the centroids' bias): were one seen, the scales move
    and it is said, by a share within the render's bound, far below what a ruler can
    read (its stated 0.8 %), and k stays within the issue's tolerance of the truth."""
    from pathlib import Path

    import numpy as np

    from conftest import assert_k_within

    run = tmp_path / "run42"
    shutil.copytree(Path(__file__).parents[1] / "datasets" / "run42", run,
                    ignore=shutil.ignore_patterns("vidtrack"))
    r = vidtrack_cli("fit", str(run), "--json", "--no-report")
    assert r.returncode == 0, r.stderr
    record = json.loads(r.stdout)
    shared = record["world"]["shared_x"]
    tr = truth(run)
    bias_m = sum(tr["views"][v]["m_per_px"] / (16.0 * tr["views"][v]["straw_radius_px"])
                 for v in ("front", "top"))
    pf = tr["views"]["front"]["per_frame"]
    x = np.asarray(pf["x_m"], float)[np.asarray(pf["phase"]) == "flight"]
    slope_bound = bias_m * np.mean(np.abs(x - x.mean())) / np.var(x)
    assert abs(shared["ratio"] - 1.0) < slope_bound
    # the rule: the scales move when, and only when, the data show a difference, and
    # then it is said
    seen = abs(shared["ratio"] - 1.0) > 1.96 * shared["ratio_se"]
    moved = shared["factors"] != {"front": 1.0, "top": 1.0}
    assert moved == seen and ("shared X" in r.stderr) == seen
    for v, f in shared["factors"].items():
        assert abs(f - 1.0) < slope_bound < shared["rel_uncertainty"][v]
    assert_k_within(record, tr["truth"]["k"])


def test_a_wrong_fps_in_one_view_is_still_refused(tmp_path, vidtrack_cli, wide):
    out = tmp_path / "fps"
    shutil.copytree(wide, out)          # the top view tracked again (the tracker reads fps)
    text = (out / "scene.toml").read_text()
    at = text.index("[views.top]")
    m = re.compile(r"fps = ([0-9.]+)").search(text, at)
    (out / "scene.toml").write_text(text[:m.start(1)] + "1000" + text[m.end(1):])
    r = vidtrack_cli("fit", str(out), "--no-report")
    assert r.returncode == 2, (r.returncode, r.stdout, r.stderr)
    assert "disagree" in r.stderr
    assert "nothing was reconciled" in r.stderr
