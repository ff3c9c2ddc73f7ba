"""vidtrack.predict: the paper's worked example, the shipped eqs. 20-23, the delta method
against statsmodels, the trajectory against solve_ivp, the band against Monte Carlo, and
the device placement's constraints."""

import copy
import json
import math
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import solve_ivp

from fits.blade import BladeSetting, release
from fits.errors import InputError
from vidtrack.errors import VidtrackError
from vidtrack.predict import (ExtrapolationWarning, InletGeometry, build_published_regression,
                              evaluate_term, load_regression, place_device, predict,
                              predict_coefficients, throw_trajectory)
from vidtrack.predict.regression import _regression_from

G = 9.80665


# ---------------------------------------------------------------- the regression

def test_worked_example_of_section_4():
    """Chen 2018, section 4: delta1 = -10 deg, n = 450 r/min, v1 = 6 km/h gives
    k1..k4 = 1.59, 2.13, 4.00, 21.84 from eqs. 20-23 (to the printed digits)."""
    pred = predict_coefficients(load_regression(), n_rpm=450, blade_angle_deg=-10,
                                speed_kmh=6)
    assert [round(v, 2) for v in pred.k] == [1.59, 2.13, 4.00, 21.84]
    assert not pred.extrapolation
    assert pred.coded == pytest.approx({"n_rpm": -1.0, "blade_angle_deg": -2.0,
                                        "speed_kmh": (6 - 7.2) / 1.8})
    # no covariance is published: no stderr, no interval
    assert all(c.stderr is None and c.ci95 is None for c in pred.coefficients.values())
    # Table 3's residual MS gives the run-to-run scatter
    assert pred.coefficients["k1"].residual_sd == pytest.approx(math.sqrt(0.077))


def test_shipped_regression_is_the_published_tables():
    # the project's copies of the transcribed tables (datasets/README.md: provenance)
    data = Path(__file__).resolve().parents[1] / "datasets" / "published"
    built = build_published_regression(data / "chen2018_equations_20_23_published.csv",
                                       data / "chen2018_table3_anova_published.csv",
                                       data / "chen2018_table1_factor_codes.csv")
    from importlib import resources
    shipped = json.loads((resources.files("vidtrack") / "data" / "chen2018_eqs_20_23.json")
                         .read_text(encoding="utf-8"))
    assert shipped == json.loads(json.dumps(built))
    eq = pd.read_csv(data / "chen2018_equations_20_23_published.csv")
    for obj in shipped:
        rows = eq[eq["response"] == obj["response"]]
        assert obj["coefficients_natural"] == dict(zip(rows["term"], rows["coefficient"]))
        assert obj["covariance_natural"] is None
        assert "not published" in obj["provenance"]["covariance"]


def test_term_evaluator():
    v = {"n_rpm": 450.0, "blade_angle_deg": -10.0, "speed_kmh": 6.0}
    assert evaluate_term("Intercept", v) == 1.0
    assert evaluate_term("n_rpm^2", v) == 450.0 ** 2
    assert evaluate_term("n_rpm:blade_angle_deg", v) == -4500.0
    assert evaluate_term("n_rpm:blade_angle_deg:speed_kmh", v) == -27000.0
    assert evaluate_term("blade_angle_deg^2:speed_kmh", v) == 600.0
    with pytest.raises(InputError, match="unknown factor 'rpm'"):
        evaluate_term("rpm", v)
    with pytest.raises(InputError, match="power"):
        evaluate_term("n_rpm^x", v)


def test_extrapolation_warns():
    reg = load_regression()
    with pytest.warns(ExtrapolationWarning, match=r"n_rpm = 900 .*\[350, 750\].*\+3\.5"):
        pred = predict_coefficients(reg, n_rpm=900, blade_angle_deg=0, speed_kmh=7.2)
    assert pred.extrapolation and len(pred.warnings) == 1
    # the edges of the design (the axial points) are not extrapolations
    pred = predict_coefficients(reg, n_rpm=750, blade_angle_deg=10, speed_kmh=3.6)
    assert not pred.extrapolation
    # coded |x| > 2 is used when the file has the coding but no design range
    data = json.loads(json.dumps(_shipped()))
    for obj in data:
        del obj["design_range_natural"]
    with pytest.warns(ExtrapolationWarning, match="speed_kmh = 11 .*coded"):
        predict_coefficients(_regression_from(data, "x.json"), n_rpm=550,
                             blade_angle_deg=0, speed_kmh=11)


def _shipped():
    from importlib import resources
    return json.loads((resources.files("vidtrack") / "data" / "chen2018_eqs_20_23.json")
                      .read_text(encoding="utf-8"))


def _table2_regression():
    """Refit Table 2 with the published terms (statsmodels OLS, natural units) and write
    it in the format of ``vidtrack anova --json``, with the coefficient covariance."""
    import statsmodels.api as sm

    from tests.conftest import REPO
    t2 = pd.read_csv(REPO / "datasets" / "published" / "chen2018_table2_ccd.csv")
    nat = pd.DataFrame({"n_rpm": 550 + 100 * t2["A"], "blade_angle_deg": 5.0 * t2["B"],
                        "speed_kmh": 7.2 + 1.8 * t2["C"]})
    out, fits = [], {}
    for obj in _shipped():
        terms = list(obj["coefficients_natural"])
        X = np.array([[evaluate_term(t, row) for t in terms]
                      for row in nat.to_dict("records")])
        res = sm.OLS(t2[obj["response"]].to_numpy(), X).fit()
        fits[obj["response"]] = (res, terms)
        out.append({**obj, "coefficients_natural": dict(zip(terms, res.params.tolist())),
                    "covariance_natural": {"terms": terms,
                                           "matrix": res.cov_params().tolist()},
                    "residual_ms": float(res.mse_resid),
                    "anova": {"residual": {"df": int(res.df_resid)}}})
    return out, fits


def test_delta_method_matches_statsmodels_prediction_se():
    data, fits = _table2_regression()
    reg = _regression_from(data, "table2.json")
    setting = {"n_rpm": 450.0, "blade_angle_deg": -10.0, "speed_kmh": 6.0}
    pred = predict_coefficients(reg, **setting)
    for r, (res, terms) in fits.items():
        x = np.array([[evaluate_term(t, setting) for t in terms]])
        sf = res.get_prediction(x).summary_frame(alpha=0.05)
        c = pred.coefficients[r]
        assert c.value == pytest.approx(float(sf["mean"].iloc[0]), rel=1e-9)
        assert c.stderr == pytest.approx(float(sf["mean_se"].iloc[0]), rel=1e-6)
        assert c.ci95[0] == pytest.approx(float(sf["mean_ci_lower"].iloc[0]), rel=1e-6)
        assert c.ci95[1] == pytest.approx(float(sf["mean_ci_upper"].iloc[0]), rel=1e-6)


def test_bad_regression_files(tmp_path):
    with pytest.raises(VidtrackError, match="expected a JSON list"):
        _regression_from({"response": "k1"}, "r.json")
    data = _shipped()[:3]
    with pytest.raises(VidtrackError, match="no regression for k4"):
        _regression_from(data, "r.json")
    data = copy.deepcopy(_shipped())
    data[0]["covariance_natural"] = {"terms": ["Intercept"], "matrix": [[1.0]]}
    with pytest.raises(VidtrackError, match=r"item 0 \(k1\): covariance_natural.terms"):
        _regression_from(data, "r.json")
    data = copy.deepcopy(_shipped())
    data[1]["coefficients_natural"]["rpm^2"] = 1.0
    with pytest.raises(VidtrackError, match="unknown factor 'rpm'"):
        _regression_from(data, "r.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json", encoding="utf-8")
    with pytest.raises(VidtrackError, match="bad.json: not valid JSON"):
        load_regression(bad)
    with pytest.raises(VidtrackError, match="cannot read"):
        load_regression(tmp_path / "missing.json")


# ---------------------------------------------------------------- the throw

def _ode_landing(state, k, cp, v1, ground):
    """Landing by solve_ivp on the ODEs of MODEL.md section 1 (independent of fits.throw)."""
    k1, k2, k3, k4 = k

    def rhs(t, s):
        x, y, z, vx, vy, vz = s
        ay = -k1 * G * (1 + cp**2 * vy**2) if vy > 0 else -k2 * G * (1 - cp**2 * vy**2)
        return [vx, vy, vz - v1, -k3 * G * cp**2 * vx * abs(vx), ay,
                -k4 * G * cp**2 * vz * abs(vz)]

    def hit(t, s):
        return s[1] - ground
    hit.terminal, hit.direction = True, -1
    sol = solve_ivp(rhs, (0, 20), list(state), method="DOP853", rtol=1e-11, atol=1e-13,
                    events=hit)
    return sol.t_events[0][0], sol.y_events[0][0]


def test_prediction_lands_where_the_ode_does():
    p = predict(450, -10, 6)
    assert p.trajectory.end == "ground"
    t_ref, s_ref = _ode_landing(p.release.state(), p.coefficients.k, 0.115, 6 / 3.6, -0.20)
    assert p.trajectory.t_end_s == pytest.approx(t_ref, rel=1e-7)
    np.testing.assert_allclose(p.trajectory.end_point_m, s_ref[:3], rtol=0, atol=1e-6)
    y = p.trajectory.xyz_m[:, 1]
    assert np.all(y[:-1] > -0.2)                              # the first crossing
    assert p.trajectory.xyz_m[0] == pytest.approx(p.release.state()[:3])
    d = json.loads(json.dumps(p.to_dict()))
    assert set(d) >= {"coefficients", "release", "trajectory"}
    assert d["trajectory"]["band95"] is None
    assert any("no coefficient covariance" in n for n in d["notes"])


def test_release_is_the_blade_models():
    p = predict(600, 5, 8, radius_m=0.3, start_m=0.12, friction=0.4, phase_deg=-45)
    r = release(BladeSetting(600, 5, radius_m=0.3, start_m=0.12, friction=0.4,
                             phase_deg=-45), speed_kmh=8)
    assert p.release.state() == pytest.approx(r.state(), rel=1e-12)
    assert p.trajectory.shaft_height_m == pytest.approx(0.25)        # R - 50 mm
    assert p.release.vz0_m_s == pytest.approx(8 / 3.6)


def test_linearised_band_matches_monte_carlo():
    r = release(BladeSetting(550, 0), speed_kmh=7.2)
    k = (2.2, 2.9, 4.7, 21.5)
    sd = np.array([0.05, 0.07, 0.12, 0.5])           # a few % of k: the linear regime
    tr = throw_trajectory(r.state(), k, 0.115, v1_m_s=2.0, shaft_height_m=0.2,
                          k_variance=tuple(sd**2), points=41)
    rng = np.random.default_rng(7)
    lands = []
    for ks in rng.normal(k, sd, size=(300, 4)):
        lands.append(throw_trajectory(r.state(), ks, 0.115, v1_m_s=2.0,
                                      shaft_height_m=0.2, points=2).end_point_m)
    lands = np.array(lands)
    assert tr.end_sd_m["x_m"] == pytest.approx(lands[:, 0].std(ddof=1), rel=0.15)
    assert tr.end_sd_m["z_m"] == pytest.approx(lands[:, 2].std(ddof=1), rel=0.15)
    band = tr.to_dict()["band95"]
    assert np.all(np.array(band["y_m_high"]) >= np.array(band["y_m_low"]))


def test_covariance_regression_gives_a_band():
    data, _ = _table2_regression()
    p = predict(450, -10, 6, regression=_regression_from(data, "table2.json"))
    assert p.has_covariance
    d = p.to_dict()
    assert d["trajectory"]["band95"] is not None
    assert d["trajectory"]["end_sd_m"]["x_m"] > 0
    assert all(d["coefficients"][r]["stderr"] > 0 for r in ("k1", "k2", "k3", "k4"))


def test_setting_that_is_not_thrown_is_refused():
    # l1 = 0.02 m with mu = 0.5, R = 0.25: asin(l1/(mu R)) = 9.2 deg < 10 deg: eq. 7 fails
    with pytest.raises(InputError, match="eq. 7 fails"):
        predict(450, -10, 6, start_m=0.02)
    with pytest.raises(InputError, match="below the ground plane"):
        predict(450, -10, 6, phase_deg=-60, shaft_height_m=0.05)   # y0 = -0.11 m


def test_nonpositive_k_is_refused():
    data = copy.deepcopy(_shipped())
    data[1]["coefficients_natural"]["Intercept"] = -10.0
    with pytest.raises(InputError, match="k2 = -"):
        predict(450, -10, 6, regression=_regression_from(data, "r.json"))


def test_inlet_plane_ends_the_throw():
    p = predict(450, -10, 6, inlet_x_m=1.0)
    assert p.trajectory.end == "inlet"
    assert p.trajectory.end_point_m[0] == pytest.approx(1.0, abs=1e-9)
    with pytest.raises(InputError, match="lands at x"):
        predict(450, -10, 6, inlet_x_m=50.0)


# ---------------------------------------------------------------- the device

def test_device_placement_meets_its_constraints():
    r = release(BladeSetting(450, -10), speed_kmh=6)
    k = (1.59, 2.13, 4.00, 21.84)
    geo = InletGeometry(offset_m=0.2, low_m=-0.05, high_m=0.05, bottom_m=0.6,
                        blade_clearance_m=0.05, ground_clearance_m=0.05)
    d = place_device(r.state(), k, 0.115, geo, radius_m=0.25, shaft_height_m=0.2,
                     v1_m_s=6 / 3.6)
    assert d.h1_m == pytest.approx(d.inlet_x_m + 0.2)
    assert d.inlet_x_m >= 0.25 + 0.05 - 1e-12
    lo, hi = d.inlet_y_m
    assert lo <= d.stream_y_m[0] <= d.stream_y_m[1] <= hi
    assert d.h2_m - 0.6 >= -0.2 + 0.05 - 1e-9                   # housing clears the ground
    # here the ground binds: the smallest plane is where the stream reaches the
    # opening's lowest admissible edge, -0.2 + 0.05 + 0.6 - 0.05 = 0.40 m
    from fits.throw import position
    y_at = position(np.array([d.t_inlet_s]), r.state(), k, 0.115, v1=6 / 3.6)[0, 1]
    assert y_at == pytest.approx(0.40, abs=1e-9)
    assert d.binding.startswith("ground")
    with pytest.raises(InputError, match="no place for the device"):
        place_device(r.state(), k, 0.115, InletGeometry(blade_clearance_m=10.0),
                     radius_m=0.25, shaft_height_m=0.2, v1_m_s=6 / 3.6)
    with pytest.raises(InputError, match="never rises high enough"):
        place_device(r.state(), k, 0.115, InletGeometry(bottom_m=5.0), radius_m=0.25,
                     shaft_height_m=0.2, v1_m_s=6 / 3.6)


def test_device_in_predict_ends_the_throw_at_the_inlet():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        p = predict(450, -10, 6, device=InletGeometry())
    assert p.trajectory.end == "inlet"
    assert p.trajectory.end_point_m[0] == pytest.approx(p.device.inlet_x_m, abs=1e-9)
    assert p.to_dict()["device"]["h1_m"] == pytest.approx(p.device.h1_m)
    with pytest.raises(InputError, match="low_m"):
        InletGeometry(low_m=0.1, high_m=0.0)


def test_reprs_are_short():
    """The results print as one line each (the trajectory's arrays were 7,673 characters,
    the whole prediction 10,943)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExtrapolationWarning)
        pred = predict(450, -10, 6, device=InletGeometry())
    regression = load_regression()
    objects = (pred, pred.coefficients, pred.trajectory, pred.release, regression,
               regression.models["k1"], pred.coefficients.coefficients["k1"])
    for obj in objects:
        text = repr(obj)
        assert len(text) < 300 and "\n" not in text and "array" not in text, text
    assert repr(pred.coefficients).endswith("k1=1.585, k2=2.132, k3=4.000, k4=21.84)")
    assert repr(pred).startswith("Prediction(n_rpm=450, blade_angle_deg=-10, speed_kmh=6: ")
