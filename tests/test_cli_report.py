"""``vidtrack report`` end to end on footage: a small experiment rendered by
``vidtrack synth`` (a two-factor central composite design, 11 runs whose k's follow a
known quadratic), fitted and analysed by the real CLI."""

import json

import numpy as np
import pandas as pd
import pytest

# coded design: 4 factorial, 4 axial at +-1.5, 3 centre points
DESIGN = [(-1, -1), (1, -1), (-1, 1), (1, 1), (-1.5, 0), (1.5, 0), (0, -1.5), (0, 1.5),
          (0, 0), (0, 0), (0, 0)]


def k_of(a, b):
    """The truth the experiment follows: strong A, B, A:B and A^2 terms in k1."""
    return (2.2 + 0.5 * a - 0.2 * b - 0.2 * a * b + 0.15 * a * a, 2.5 + 0.3 * a, 4.6 + 0.4 * b,
            21.3 - 2.0 * a)


@pytest.mark.slow
def test_report_fits_every_run_and_analyses_the_table(vidtrack_cli, tmp_path):
    exp = tmp_path / "exp"
    for i, (a, b) in enumerate(DESIGN, start=1):
        k = ",".join(f"{v:.6f}" for v in k_of(a, b))
        res = vidtrack_cli("synth", exp / "runs" / f"{i:02d}", "--size", "300x140",
                           "--top-size", "300x90", "--straw-length-m", "0.25",
                           "--straw-diameter-m", "0.025", "--flight-s", "0.25",
                           "--noise", "1.0", "--k", k, "--n-rpm", str(550 + 100 * a),
                           "--blade-angle-deg", str(5 * b), "--seed", str(i))
        assert res.returncode == 0, res.stderr
    (exp / "experiment.toml").write_text(
        'schema = 1\ndesign = "ccd"\nresponses = ["k1", "k2", "k3", "k4"]\nruns = "runs/*"\n'
        '[factors.A]\nname = "n_rpm"\ncentre = 550\nstep = 100\n'
        '[factors.B]\nname = "blade_angle_deg"\ncentre = 0\nstep = 5\n')
    res = vidtrack_cli("report", exp, "--jobs", "2")
    assert res.returncode == 0, res.stderr
    out = exp / "vidtrack"
    table = pd.read_csv(out / "coefficients.csv")
    assert len(table) == len(DESIGN)
    for row, (a, b) in zip(table.itertuples(), DESIGN):
        assert row.A == pytest.approx(a) and row.B == pytest.approx(b)
        truth = k_of(a, b)
        assert row.k1 == pytest.approx(truth[0], rel=0.03)
        assert row.k4 == pytest.approx(truth[3], rel=0.05)
    anova = {f["response"]: f for f in json.loads((out / "anova.json").read_text())}
    assert {"A", "B", "A:B", "A^2"} <= set(anova["k1"]["terms"])
    assert "A" in anova["k2"]["terms"] and "B" in anova["k3"]["terms"]
    assert "A" in anova["k4"]["terms"]
    coef = anova["k1"]["coefficients_coded"]
    assert coef["A"] == pytest.approx(0.5, abs=0.05)
    assert coef["A:B"] == pytest.approx(-0.2, abs=0.05)
    assert np.isfinite(anova["k1"]["anova"]["pure_error"]["ss"])
    assert (out / "report.html").read_text().count("<img") >= 4
    assert "k1" in res.stdout and "Regression" in res.stdout
