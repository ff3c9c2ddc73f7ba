"""k1..k4 per run for a rehearsal: equations (TOML, CSV, anova JSON, the shipped Chen 2018
eqs. 20-23) and k tables, evaluated at each run's setting against closed forms."""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from vidtrack.errors import VidtrackError
from vidtrack.rehearsal import k_of_runs, read_equations, read_k_table, run_settings
from vidtrack.scene import load_experiment
from vidtrack.scene_template import plan_scene_text

ROOT = Path(__file__).resolve().parents[1]
CHEN_CSV = ROOT / "datasets" / "published" / "chen2018_equations_20_23_published.csv"
SETTINGS = [{"n_rpm": 450.0, "blade_angle_deg": -5.0}, {"n_rpm": 650.0, "blade_angle_deg": 5.0},
            {"n_rpm": 550.0, "blade_angle_deg": 0.0}]


def chen_by_hand(n, d, v):
    """Chen 2018 eqs. 20-23 as printed, typed in here."""
    return (2.712 - 1.024e-2 * n + 0.196 * d + 0.0792 * v - 4.25e-4 * n * d + 1.508e-5 * n * n,
            5.058 - 0.02 * n + 0.235 * d + 0.205 * v - 5.475e-4 * n * d + 2.336e-5 * n * n,
            0.308 + 6.338e-3 * n + 0.302 * d + 0.137 * v - 6.75e-4 * n * d,
            33.636 - 0.031 * n - 0.12 * d - 2.272 * v + 5.402e-3 * n * v)


@pytest.fixture
def experiment(tmp_path):
    exp = tmp_path / "exp"
    (exp / "runs").mkdir(parents=True)
    (exp / "experiment.toml").write_text(
        'schema = 1\ndesign = "ccd"\nresponses = ["k1", "k2", "k3", "k4"]\n'
        'runs = "runs/*"\n[factors.A]\nname = "n_rpm"\ncentre = 550\nstep = 100\n'
        '[factors.B]\nname = "blade_angle_deg"\ncentre = 0\nstep = 5\n')
    for i, factors in enumerate(SETTINGS, start=1):
        run = exp / "runs" / f"{i:02d}"
        run.mkdir()
        (run / "scene.toml").write_text(plan_scene_text(factors, folder=run))
    return load_experiment(exp)


@pytest.mark.parametrize("source", ["chen2018", str(CHEN_CSV)])
def test_chen_equations_at_each_run(experiment, source):
    settings = run_settings(experiment)
    assert [s.factors for s in settings] == SETTINGS
    ks = k_of_runs(experiment, read_equations(source), settings, fixed={"speed_kmh": 5.4})
    for k, s in zip(ks, SETTINGS):
        np.testing.assert_allclose(k, chen_by_hand(s["n_rpm"], s["blade_angle_deg"], 5.4),
                                   rtol=1e-12)


def test_coded_terms_are_the_natural_ones_recoded(experiment, tmp_path):
    coded = tmp_path / "coded.toml"
    coded.write_text('[k1]\nIntercept = 2\nA = 0.5\n"A:B" = 0.1\n"A^2" = 0.2\n'
                     '[k2]\nIntercept = 2.5\nB = -0.3\n[k3]\nIntercept = 4.6\n'
                     '[k4]\nIntercept = 21\nblade_angle_deg = 0.2\n')
    ks = k_of_runs(experiment, read_equations(coded), run_settings(experiment))
    for k, s in zip(ks, SETTINGS):
        a, b = (s["n_rpm"] - 550) / 100, s["blade_angle_deg"] / 5
        np.testing.assert_allclose(k, (2 + 0.5 * a + 0.1 * a * b + 0.2 * a * a, 2.5 - 0.3 * b,
                                       4.6, 21 + 0.2 * s["blade_angle_deg"]), rtol=1e-12)


def test_anova_json_gives_what_its_fit_predicts(experiment, tmp_path):
    from fits.rsm import Factor, fit_rsm

    rng = np.random.default_rng(3)
    a, b = np.meshgrid([-1, 0, 1], [-1, 0, 1])
    table = pd.DataFrame({"n_rpm": 550 + 100 * a.ravel(), "blade_angle_deg": 5 * b.ravel()})
    factors = [Factor("A", "n_rpm", 550, 100), Factor("B", "blade_angle_deg", 0, 5)]
    fits = []
    for i, r in enumerate(("k1", "k2", "k3", "k4")):
        table[r] = (2 + i) + 0.4 * a.ravel() - 0.2 * b.ravel() + rng.normal(0, 0.01, 9)
        fits.append(fit_rsm(table, r, factors))
    path = tmp_path / "anova.json"
    path.write_text(json.dumps([f.to_dict() for f in fits]))
    ks = k_of_runs(experiment, read_equations(path), run_settings(experiment))
    for k, s in zip(ks, SETTINGS):
        want = [float(f.predict({n: np.array([v]) for n, v in s.items()})[0]) for f in fits]
        np.testing.assert_allclose(k, want, rtol=1e-9)


def test_k_table_keeps_run_names_as_text(experiment, tmp_path):
    path = tmp_path / "k.csv"
    path.write_text("run,k1,k2,k3,k4,note\n01,2.1,2.5,4.6,21\n02,2.2,2.6,4.7,22,x\n"
                    "03,2.3,2.7,4.8,23,\n")
    ks = k_of_runs(experiment, read_k_table(path), run_settings(experiment))
    assert ks == [(2.1, 2.5, 4.6, 21.0), (2.2, 2.6, 4.7, 22.0), (2.3, 2.7, 4.8, 23.0)]


@pytest.mark.parametrize("text, match", [
    ("run,k1,k2,k3\n01,1,2,3\n", "no column 'k4'"),
    ("run,k1,k2,k3,k4\n01,1,2,3,4\n01,1,2,3,4\n", "given twice"),
    ("run,k1,k2,k3,k4\n01,1,2,x,4\n", "line 2: k3"),
])
def test_bad_k_tables_are_refused(tmp_path, text, match):
    path = tmp_path / "k.csv"
    path.write_text(text)
    with pytest.raises(VidtrackError, match=match):
        read_k_table(path)


@pytest.mark.parametrize("name, text, match", [
    ("e.toml", "[k1]\nIntercept = 2\n", "no equation for k2, k3, k4"),
    ("e.toml", "[k1]\nIntercept = 'x'\n", "k1.Intercept: expected a finite number"),
    ("e.csv", "response,term\nk1,A\n", "no column 'coefficient'"),
    ("e.json", "{}", "expected a list"),
    ("e.txt", "", "expected equations as .toml, .csv or .json"),
])
def test_bad_equations_are_refused(tmp_path, name, text, match):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(VidtrackError, match=match):
        read_equations(path)
