"""``vidtrack predict`` as a real subprocess: JSON keys, the worked example, warnings,
the plot, bad input, and a regression written by ``vidtrack anova --json``."""

import json

import pytest

from tests.conftest import REPO

SETTING = ("--n-rpm", "450", "--blade-angle-deg", "-10", "--speed-kmh", "6")


def test_json_has_the_spec_keys_and_the_worked_example(vidtrack_cli):
    res = vidtrack_cli("predict", *SETTING, "--json", "--device")
    assert res.returncode == 0, res.stderr
    d = json.loads(res.stdout)
    assert {"coefficients", "release", "trajectory"} <= set(d)
    assert [round(d["coefficients"][k]["value"], 2) for k in ("k1", "k2", "k3", "k4")] \
        == [1.59, 2.13, 4.00, 21.84]
    r = d["release"]
    assert r["thrown"] and {"x0_m", "y0_m", "vx0_m_s", "vy0_m_s", "vz0_m_s"} <= set(r)
    assert r["vz0_m_s"] == pytest.approx(6 / 3.6)
    t = d["trajectory"]
    assert len(t["t_s"]) == len(t["x_m"]) == 101
    assert t["end"] == "inlet" and d["device"]["h1_m"] > 0
    assert d["trajectory"]["band95"] is None and d["regression"]["covariance"] is False
    assert res.stderr == ""


def test_summary_and_plot(vidtrack_cli, tmp_path):
    png = tmp_path / "out" / "throw.png"
    res = vidtrack_cli("predict", *SETTING, "--plot", png)
    assert res.returncode == 0, res.stderr
    assert "k4 = 21.84" in res.stdout and "reaches the ground" in res.stdout
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in png.parent.iterdir()] == ["throw.png"]   # no temp file left


def test_extrapolation_is_predicted_with_a_warning(vidtrack_cli):
    res = vidtrack_cli("predict", "--n-rpm", "900", "--blade-angle-deg", "0",
                       "--speed-kmh", "7.2", "--json")
    assert res.returncode == 0, res.stderr
    assert "warning: n_rpm = 900" in res.stderr and "extrapolation" in res.stderr
    d = json.loads(res.stdout)
    assert d["extrapolation"] is True and d["warnings"]


def test_setting_that_is_not_thrown_exits_2_naming_the_condition(vidtrack_cli, tmp_path):
    png = tmp_path / "p.png"
    res = vidtrack_cli("predict", *SETTING, "--start-m", "0.02", "--plot", png)
    assert res.returncode == 2
    assert "eq. 7 fails" in res.stderr and "not thrown" in res.stderr
    assert "Traceback" not in res.stderr and res.stdout == ""
    assert not png.exists()
    res = vidtrack_cli("predict", "--n-rpm", "60", "--blade-angle-deg", "0",
                       "--speed-kmh", "7.2")
    assert res.returncode == 2 and "eq. 6 fails" in res.stderr


def test_bad_regression_file_exits_2(vidtrack_cli, tmp_path):
    bad = tmp_path / "r.json"
    bad.write_text('[{"response": "k1", "coefficients_natural": {"Intercept": 1}}]')
    res = vidtrack_cli("predict", *SETTING, "--regression", bad)
    assert res.returncode == 2
    assert "r.json" in res.stderr and "no regression for k2, k3, k4" in res.stderr
    res = vidtrack_cli("predict", "--n-rpm", "abc", "--blade-angle-deg", "0",
                       "--speed-kmh", "7")
    assert res.returncode == 2 and "--n-rpm must be a number" in res.stderr


def test_regression_from_vidtrack_anova_gives_a_band(vidtrack_cli, tmp_path):
    table = REPO / "datasets" / "published" / "chen2018_table2_ccd.csv"
    res = vidtrack_cli("anova", table, "--response", "k1", "--response", "k2",
                       "--response", "k3", "--response", "k4",
                       "--factor", "A=n_rpm:550:100", "--factor", "B=blade_angle_deg:0:5",
                       "--factor", "C=speed_kmh:7.2:1.8", "--json")
    assert res.returncode == 0, res.stderr
    reg = tmp_path / "anova.json"
    reg.write_text(res.stdout)
    res = vidtrack_cli("predict", *SETTING, "--regression", reg, "--json")
    assert res.returncode == 0, res.stderr
    d = json.loads(res.stdout)
    assert d["regression"]["covariance"] is True
    k1 = d["coefficients"]["k1"]
    assert k1["stderr"] > 0 and k1["ci95"][0] < k1["value"] < k1["ci95"][1]
    band = d["trajectory"]["band95"]
    assert band is not None and len(band["y_m_low"]) == 101
    assert d["trajectory"]["end_sd_m"]["x_m"] > 0
