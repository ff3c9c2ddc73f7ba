"""A rehearsal end to end through the real command line: ``vidtrack design``, ``vidtrack
synth EXP --regression`` (and ``--k-table``), ``vidtrack report``, ``vidtrack score``.

The truth checked against is the test's own: the equations below evaluated at design.csv's
levels by hand, the renders' truth.json and the fits' fit.json read here, and the
regressions refitted here by least squares on design.csv's coded levels.
"""

import json

import numpy as np
import pandas as pd
import pytest

from vidtrack.scene_template import PLAN_MARK

K = ("k1", "k2", "k3", "k4")
#: Two factors, face-centred: 4 factorial, 4 axial, 1 centre point = 9 runs.
DESIGN = ("design", "--ccd", "A=n_rpm:550:100", "--ccd", "B=speed_kmh:7.2:1.8", "--alpha",
          "face", "--centre-points", "1", "--seed", "5")
#: Coded terms by letter, natural ones by name (k3's speed_kmh): the file under test.
EQUATIONS = """\
[k1]
Intercept = 2.2
A = 0.3
B = -0.15
"A:B" = -0.1
"A^2" = 0.12
[k2]
Intercept = 2.5
A = 0.25
B = 0.1
[k3]
Intercept = 3.88
speed_kmh = 0.1
[k4]
Intercept = 21.3
A = -1.5
B = 0.8
"""
K_SPREAD = 0.01
#: Small footage: the chain is what is rehearsed here, the tracker has tests of its own.
FOOTAGE = ("--size", "240x110", "--top-size", "240x80", "--flight-s", "0.2",
           "--straw-length-m", "0.25", "--straw-diameter-m", "0.025", "--noise", "1.0",
           "--exposure-samples", "2")


def k_by_hand(a, b, speed_kmh):
    """The equations above, written out: k1..k4 at coded a, b (and natural speed)."""
    return (2.2 + 0.3 * a - 0.15 * b - 0.1 * a * b + 0.12 * a * a, 2.5 + 0.25 * a + 0.1 * b,
            3.88 + 0.1 * speed_kmh, 21.3 - 1.5 * a + 0.8 * b)


def read_json(path):
    return json.loads(path.read_text(encoding="utf-8"))


def ols(sheet, y, terms):
    """Coded coefficients of ``terms`` (coded names) fitted by least squares here."""
    cols = [np.ones(len(sheet))]
    for term in terms:
        col = np.ones(len(sheet))
        for part in term.split(":"):
            name, _, power = part.partition("^")
            col = col * sheet[name].to_numpy(dtype=float) ** int(power or 1)
        cols.append(col)
    beta, *_ = np.linalg.lstsq(np.column_stack(cols), np.asarray(y, dtype=float), rcond=None)
    return dict(zip(["Intercept", *terms], beta))


@pytest.fixture
def experiment(tmp_path, vidtrack_cli):
    exp = tmp_path / "exp"
    res = vidtrack_cli(*DESIGN, exp)
    assert res.returncode == 0, res.stderr
    return exp


@pytest.mark.slow
def test_rehearsal_recovers_the_regression(experiment, tmp_path, vidtrack_cli):
    exp = experiment
    eq = tmp_path / "equations.toml"
    eq.write_text(EQUATIONS, encoding="utf-8")
    res = vidtrack_cli("synth", exp, "--regression", eq, "--k-spread", str(K_SPREAD),
                       *FOOTAGE)
    assert res.returncode == 0, res.stderr
    assert "vidtrack score" in res.stdout
    sheet = pd.read_csv(exp / "design.csv", dtype={"run": str})
    assert len(sheet) == 9

    true_k, deviations = [], []
    for row in sheet.itertuples():
        run = exp / "runs" / row.run
        truth = read_json(run / "truth.json")
        want = k_by_hand(row.A, row.B, row.speed_kmh)
        np.testing.assert_allclose(truth["spec"]["k"], want, rtol=1e-12)
        k = [truth["truth"]["k"][r] for r in K]
        deviations.append(np.array(k) / np.array(want) - 1.0)
        true_k.append(k)
        # the run's setting drives the render: the machine's speed is the factor's
        assert truth["truth"]["speed_kmh"] == pytest.approx(row.speed_kmh)
        scene = (run / "scene.toml").read_text(encoding="utf-8")
        assert not scene.startswith(PLAN_MARK)
        assert f"n_rpm = {row.n_rpm:g}" in scene and f"speed_kmh = {row.speed_kmh:g}" in scene
    deviations = np.array(deviations)
    assert np.all(deviations != 0) and np.all(np.abs(deviations) < 5 * K_SPREAD)
    assert len({tuple(d) for d in deviations}) == len(sheet)      # a seed of its own per run

    res = vidtrack_cli("report", exp, "--jobs", "2")
    assert res.returncode == 0, res.stderr
    res = vidtrack_cli("score", exp, "--json")
    assert res.returncode == 0, res.stderr
    score = json.loads(res.stdout)
    out = exp / "vidtrack"
    for name in ("score_throws.csv", "score_regression.csv", "score.json", "score.txt"):
        assert (out / name).is_file(), name
    assert read_json(out / "score.json") == score

    throws = pd.read_csv(out / "score_throws.csv", dtype={"run": str}).set_index("run")
    fitted_k, covered, own = [], {r: 0 for r in K}, {r: 0 for r in K}
    for row, truth in zip(sheet.itertuples(), true_k):
        fit = read_json(exp / "runs" / row.run / "vidtrack" / "fit.json")
        got = throws.loc[row.run]
        values = []
        for r, t in zip(K, truth):
            c = fit["coefficients"][r]
            assert c["determined"], (row.run, r)
            lo, hi = c["ci95"]
            values.append(c["value"])
            covered[r] += lo <= t <= hi
            assert got[f"{r}_true"] == pytest.approx(t, rel=1e-12)
            assert got[f"{r}_fit"] == pytest.approx(c["value"], rel=1e-12)
            assert got[f"{r}_error"] == pytest.approx(c["value"] - t, rel=1e-9, abs=1e-12)
            assert bool(got[f"{r}_covered"]) == (lo <= t <= hi)
            lo_fit, hi_fit = c["ci95_fit"]
            assert bool(got[f"{r}_covered_fit"]) == (lo_fit <= t <= hi_fit)
            own[r] += lo_fit <= t <= hi_fit
        fitted_k.append(values)
    for r in K:
        assert score["coverage"][r]["covered"] == covered[r]
        assert score["coverage"][r]["covered_fit"] == own[r]
        assert score["coverage"][r]["determined"] == len(sheet)

    regression = pd.read_csv(out / "score_regression.csv")
    true_k, fitted_k = np.array(true_k), np.array(fitted_k)
    for i, r in enumerate(K):
        rows = regression[regression["response"] == r].set_index("term")
        terms = [t for t in rows.index if t != "Intercept"]
        assert terms == score["regression"][r]["terms_true"]
        mine_true = ols(sheet, true_k[:, i], terms)
        mine_fit = ols(sheet, fitted_k[:, i], terms)
        for term in rows.index:
            assert rows.loc[term, "true_k"] == pytest.approx(mine_true[term], abs=1e-9)
            assert rows.loc[term, "fitted_k"] == pytest.approx(mine_fit[term], abs=1e-9)
        assert score["regression"][r]["max_abs_difference"] == pytest.approx(
            max(abs(mine_fit[t] - mine_true[t]) for t in rows.index), abs=1e-9)
    # the regression on the fitted k is the one vidtrack report wrote
    for fit in read_json(out / "anova.json"):
        assert score["regression"][fit["response"]]["terms_fitted"] == fit["terms"]
    # the chain recovers the equations: their largest terms are selected on the true k,
    # and the regression on the fitted k stays near the one on the true k
    assert {"A", "B", "A:B", "A^2"} <= set(score["regression"]["k1"]["terms_true"])
    assert {"A"} <= set(score["regression"]["k4"]["terms_true"])
    intercepts = regression[regression["term"] == "Intercept"].set_index("response")
    for r in K:
        assert score["regression"][r]["max_abs_difference"] < 0.03 * abs(
            intercepts.loc[r, "true_k"]), r


def test_k_table_render_and_refusals(experiment, tmp_path, vidtrack_cli):
    exp = experiment
    sheet = pd.read_csv(exp / "design.csv", dtype={"run": str})
    table = sheet[["run"]].assign(k1=2.0 + 0.1 * np.arange(len(sheet)), k2=2.5, k3=4.6,
                                  k4=21.3)
    table.to_csv(tmp_path / "k.csv", index=False)
    tiny = ("--views", "front", "--flight-s", "0.02", "--size", "96x64", "--exposure-samples",
            "1", "--release-frame", "2")
    res = vidtrack_cli("synth", exp, "--k-table", tmp_path / "k.csv", "--k-spread", "0",
                       *tiny)
    assert res.returncode == 0, res.stderr
    for row in table.itertuples():
        truth = read_json(exp / "runs" / row.run / "truth.json")
        assert [truth["truth"]["k"][r] for r in K] == [row.k1, row.k2, row.k3, row.k4]
    # rendered runs are never written over without --force; score needs the fits
    before = {p: p.stat().st_mtime_ns for p in exp.rglob("*") if p.is_file()}
    for args, hint in ((("synth", exp, "--k-table", tmp_path / "k.csv", *tiny), "--force"),
                       (("score", exp), "vidtrack report")):
        res = vidtrack_cli(*args)
        assert res.returncode == 2 and "Traceback" not in res.stderr
        assert len(res.stderr.strip().splitlines()) == 1, res.stderr
        assert hint in res.stderr
    assert {p: p.stat().st_mtime_ns for p in exp.rglob("*") if p.is_file()} == before
    res = vidtrack_cli("synth", exp, "--k-table", tmp_path / "k.csv", "--force", *tiny)
    assert res.returncode == 0, res.stderr


BAD_EQUATIONS = {
    "unknown factor": '[k1]\nIntercept = 2\nC = 1\n[k2]\nIntercept = 2\n[k3]\n'
                      'Intercept = 4\n[k4]\nIntercept = 20\n',
    "k <= 0": '[k1]\nIntercept = 0.1\nA = 1\n[k2]\nIntercept = 2\n[k3]\nIntercept = 4\n'
              '[k4]\nIntercept = 20\n',
    "no k4": '[k1]\nIntercept = 2\n[k2]\nIntercept = 2\n[k3]\nIntercept = 4\n',
}


@pytest.mark.parametrize("case", [*BAD_EQUATIONS, "both sources", "--k", "no source",
                                  "missing file"])
def test_bad_input_exit_2_and_nothing_written(experiment, tmp_path, vidtrack_cli, case):
    exp = experiment
    eq = tmp_path / "eq.toml"
    eq.write_text(BAD_EQUATIONS.get(case, EQUATIONS), encoding="utf-8")
    args = {"both sources": ("--regression", eq, "--k-table", eq),
            "--k": ("--regression", eq, "--k", "1,2,3,4"), "no source": (),
            "missing file": ("--regression", tmp_path / "none.toml")}.get(
                case, ("--regression", eq))
    before = {p: p.read_bytes() for p in exp.rglob("*") if p.is_file()}
    res = vidtrack_cli("synth", exp, *args)
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert {p: p.read_bytes() for p in exp.rglob("*") if p.is_file()} == before
