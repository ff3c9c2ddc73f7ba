"""``vidtrack anova`` as a user runs it: the real command line in a subprocess."""

import base64
import json
import re
import shutil
from pathlib import Path

import pytest

DATA = Path(__file__).resolve().parents[1] / "datasets" / "published"
CHEN = DATA / "chen2018_table2_ccd.csv"
HOU = DATA / "hou2019_table3_l27.csv"
FACTORS = ["--factor", "A=n_rpm:550:100", "--factor", "B=blade_angle_deg:0:5",
           "--factor", "C=speed_kmh:7.2:1.8"]


def test_ccd_json_is_a_list_with_the_spec_fields(vidtrack_cli):
    res = vidtrack_cli("anova", CHEN, "--response", "k1", "--response", "k4", *FACTORS,
                       "--json")
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)
    assert [o["response"] for o in out] == ["k1", "k4"]
    k1, k4 = out
    assert k1["design"] == "ccd" and k1["alpha"] == 0.05
    assert k1["terms"] == ["A", "B", "C", "A:B", "A^2"]
    assert k4["terms"] == ["A", "B", "C", "A:C"]
    assert set(k1["anova"]) == {"regression", "residual", "lack_of_fit", "pure_error", "total"}
    # full precision, not the rounded table: Chen 2018 eq. 20 prints 1.508e-5
    assert k1["coefficients_natural"]["n_rpm^2"] != 1.508e-05
    assert k1["coefficients_natural"]["n_rpm^2"] == pytest.approx(1.508e-05, abs=5e-9)
    assert k1["anova"]["regression"]["f"] == pytest.approx(22.04, abs=0.005)
    assert k1["factors"]["C"] == {"name": "speed_kmh", "centre": 7.2, "step": 1.8}
    assert k1["design_range_natural"]["blade_angle_deg"] == [-10.0, 10.0]
    cov = k4["covariance_natural"]
    assert cov["terms"] == list(k4["coefficients_natural"])
    assert len(cov["matrix"]) == len(cov["terms"]) == 5
    for key in ("pred_r2", "adeq_precision", "condition_number", "residual_ms"):
        assert isinstance(k1[key], float)


def test_compare_flags_and_explains_the_quirks_of_table3(vidtrack_cli):
    res = vidtrack_cli("anova", CHEN, "--response", "k1,k2,k3,k4", *FACTORS,
                       "--compare", DATA / "chen2018_table3_anova_published.csv",
                       "--compare", DATA / "chen2018_equations_20_23_published.csv")
    assert res.returncode == 0, res.stderr
    text = res.stdout
    assert "printed F = 2.39 / 0.14 = 17.07, the ratio of the rounded mean squares" in text
    assert "residual - lack_of_fit = 3.59 - 1.67 = 1.92, not the printed 1.96" in text
    assert "truncated, not rounded: exact 0.005402778" in text
    assert re.search(r"Compared with .*table3.*: 16 numbers, 0 flagged", text)   # k1


def test_orthogonal_json_compare_reports_the_power_column(vidtrack_cli):
    res = vidtrack_cli("anova", HOU, "--design", "orthogonal",
                       "--response", "winding,power_kw",
                       "--categorical", "rho0_mm,tau0_deg", "--categorical", "vm_kmh,omega_rad_s",
                       "--interaction", "winding=tau0_deg:vm_kmh",
                       "--compare", DATA / "hou2019_table4_anova_published.csv", "--json")
    assert res.returncode == 0, res.stderr
    winding, power = json.loads(res.stdout)
    assert list(winding["anova"])[:5] == ["rho0_mm", "tau0_deg", "vm_kmh", "omega_rad_s",
                                          "tau0_deg:vm_kmh"]
    assert "tau0_deg:vm_kmh" not in power["anova"]
    assert winding["anova"]["model"]["df"] == 12 and power["anova"]["error"]["df"] == 18
    assert all(r["status"] == "match" for r in winding["comparison"])
    total = [r for r in power["comparison"] if r["source"] == "total" and r["quantity"] == "ss"]
    assert total[0]["status"] == "differs" and total[0]["published"] == 41.19
    assert total[0]["computed"] == pytest.approx(41.46, abs=0.005)
    assert "not computed from the printed data" in total[0]["note"]
    assert power["range_analysis"]["vm_kmh"]["rank"] == 1


def test_report_is_one_html_file_with_embedded_images(vidtrack_cli, tmp_path):
    out = tmp_path / "out" / "anova.html"
    res = vidtrack_cli("anova", CHEN, "--response", "k4", *FACTORS,
                       "--compare", DATA / "chen2018_table3_anova_published.csv",
                       "--report", out, "--quiet")
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in out.parent.iterdir()) == ["anova.html"]
    html = out.read_text(encoding="utf-8")
    images = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', html)
    # one-factor effects, contour + surface of A:C (significant), residual diagnostics
    assert len(images) == 3
    for img in images:
        assert base64.b64decode(img)[:8] == b"\x89PNG\r\n\x1a\n"
    assert "Lack of fit" in html and "Pure error" in html and "n_rpm:speed_kmh" in html
    assert "<img" in html and 'src="http' not in html
    res = vidtrack_cli("anova", HOU, "--design", "orthogonal", "--response", "winding",
                       "--categorical", "rho0_mm,tau0_deg,vm_kmh,omega_rad_s",
                       "--interaction", "tau0_deg:vm_kmh", "--report", out, "--quiet")
    assert res.returncode == 0, res.stderr
    html = out.read_text(encoding="utf-8")
    assert len(re.findall(r"data:image/png;base64,", html)) == 3   # levels, interaction, residuals
    assert "Range analysis" in html


def test_default_factors_are_the_coded_columns(vidtrack_cli):
    res = vidtrack_cli("anova", CHEN, "--response", "k3", "--json")
    assert res.returncode == 0, res.stderr
    (k3,) = json.loads(res.stdout)
    assert k3["factors"]["A"] == {"name": "A", "centre": 0.0, "step": 1.0}
    assert k3["coefficients_natural"] == k3["coefficients_coded"]
    assert "--factor" in vidtrack_cli("anova", "--help").stdout


def test_no_replicates_leaves_the_lack_of_fit_out_and_says_so(vidtrack_cli, tmp_path):
    table = tmp_path / "norep.csv"
    table.write_text("".join(CHEN.read_text().splitlines(keepends=True)[:16]))
    res = vidtrack_cli("anova", table, "--response", "k1", "--json")
    assert res.returncode == 0, res.stderr
    (k1,) = json.loads(res.stdout)
    assert k1["anova"]["lack_of_fit"] is None and k1["anova"]["pure_error"] is None
    assert any("no pure error" in n for n in k1["notes"])
    text = vidtrack_cli("anova", table, "--response", "k1").stdout
    assert "Lack of fit" not in text and "no pure error" in text


def _bad_tables(tmp):
    lines = CHEN.read_text().splitlines()
    nonnum = tmp / "nonnumeric.csv"
    nonnum.write_text("\n".join(lines[:5] + [lines[5].replace("1.51", "1.5l")] + lines[6:]))
    missing = tmp / "missing.csv"
    missing.write_text("\n".join(",".join(c for i, c in enumerate(row.split(",")) if i != 2)
                                 for row in lines))
    few = tmp / "few.csv"
    few.write_text("\n".join(lines[:7]))
    return {"nonnumeric": nonnum, "missing": missing, "few": few}


@pytest.mark.parametrize("case, args, match", [
    ("nonnumeric", ["--response", "k1"], r"row 5 \(line 6\), column 'k1': '1\.5l' is not a number"),
    ("missing", ["--response", "k1"], r"no column for factor B"),
    ("few", ["--response", "k1"], r"fewer runs than terms: 6 runs"),
    ("chen", ["--response", "k5"], r"unknown response 'k5'"),
    ("chen", ["--response", "k1", "--factor", "A=n_rpm:550"], r"LETTER=NAME:CENTRE:STEP"),
    ("chen", ["--response", "k1", "--compare", CHEN], r"expected columns response, source"),
])
def test_bad_input_gives_one_line_and_exit_2(vidtrack_cli, tmp_path, case, args, match):
    tables = _bad_tables(tmp_path)
    table = CHEN if case == "chen" else tables[case]
    report = tmp_path / "never.html"
    before = sorted(p.name for p in tmp_path.iterdir())
    res = vidtrack_cli("anova", table, *args, "--report", report)
    assert res.returncode == 2
    assert res.stdout == ""
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("vidtrack anova: error: "), res.stderr
    assert re.search(match, lines[0]), lines[0]
    assert "Traceback" not in res.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_inputs_are_not_modified(vidtrack_cli, tmp_path):
    table = tmp_path / "t.csv"
    shutil.copy(CHEN, table)
    before = table.read_bytes()
    res = vidtrack_cli("anova", table, "--response", "k2", "--full", "--report",
                       tmp_path / "r.html", "--quiet")
    assert res.returncode == 0, res.stderr
    assert table.read_bytes() == before
    assert "full model" in res.stdout
