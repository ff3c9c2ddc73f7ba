"""fits.lsq against tracks with known truth (made by fits.throw and an independent ODE)."""

import numpy as np
import pandas as pd
import pytest
from correlated_noise import ou_series

from fits.errors import InputError
from fits.lsq import compare_models, fit_throw
from fits.throw import position
from fits.throw.ode import solve_throw

STATE = (0.25, 0.15, 0.0, 7.0, 4.5, 2.0)
K = (2.2, 2.5, 4.6, 21.3)
CP, V1, FPS = 0.115, 2.0, 1200


def track(t, xyz):
    return pd.DataFrame({"t_s": t, "x_m": xyz[:, 0], "y_m": xyz[:, 1], "z_m": xyz[:, 2]})


def noisy_track(seed, *, sigma=0.0015, t_end=0.4, state=STATE, k=K, cp=CP, model="quadratic"):
    t = np.arange(0, t_end, 1 / FPS)
    rng = np.random.default_rng(seed)
    xyz = position(t, state, k, cp, v1=V1, model=model)
    return track(t, xyz + rng.normal(0, sigma, xyz.shape))


def test_exact_track_from_the_ode_gives_exact_coefficients():
    t = np.arange(0, 0.4, 1 / FPS)
    xyz = solve_throw(t, STATE, K, CP, v1=V1)          # an independent solution
    fit = fit_throw(track(t, xyz), CP, v1=V1)
    for name, truth in zip(("k1", "k2", "k3", "k4"), K):
        c = fit.coefficients[name]
        assert c.determined and c.value == pytest.approx(truth, rel=1e-6)
    s = fit.initial_state
    assert s["vx0_m_s"] == pytest.approx(7.0, rel=1e-7)
    assert s["vz0_m_s"] == pytest.approx(2.0, rel=1e-6)


def test_noisy_track_within_published_accuracy():
    fit = fit_throw(noisy_track(3), CP, v1=V1)
    for name, truth, tol in zip(("k1", "k2", "k3", "k4"), K, (0.03, 0.03, 0.03, 0.05)):
        assert fit.coefficients[name].value == pytest.approx(truth, rel=tol)
    rms = fit.residual_rms_m
    assert all(0.001 < rms[a] < 0.002 for a in "xyz")        # the noise put in: 1.5 mm


@pytest.mark.slow
def test_intervals_cover_the_truth():
    """95 % intervals from the Jacobian cover the truth in >= 90 % of 40 seeded runs."""
    hits = np.zeros(4)
    for seed in range(40):
        fit = fit_throw(noisy_track(100 + seed), CP, v1=V1)
        for i, (name, truth) in enumerate(zip(("k1", "k2", "k3", "k4"), K)):
            lo, hi = fit.coefficients[name].ci95
            hits[i] += lo <= truth <= hi
    assert np.all(hits >= 36), f"coverage per k: {hits / 40}"


def test_bootstrap_errors_agree_with_jacobian_errors():
    data = noisy_track(5, t_end=0.3)
    jac = fit_throw(data, CP, v1=V1)
    boot = fit_throw(data, CP, v1=V1, bootstrap=60, rng=np.random.default_rng(0))
    for name in ("k1", "k3"):
        ratio = boot.coefficients[name].stderr / jac.coefficients[name].stderr
        assert 0.6 < ratio < 1.6


@pytest.mark.parametrize("t_end", [0.4, 0.15])          # with and without a descent
def test_the_fit_is_the_least_squares_minimum_whatever_the_start(t_end):
    """At the answer the residuals are orthogonal to every column of the Jacobian (by
    central differences of fits.throw.position, not the fit's own derivatives); a refit
    of a track with one point moved, from its neighbour's answer alone, is the refit
    from every start."""
    data = noisy_track(7, t_end=t_end)
    fit = fit_throw(data, CP, v1=V1, errors=False)
    t = data["t_s"].to_numpy()
    for axis, col in zip("xyz", range(3)):
        ax = fit.axes[axis]
        base = dict(zip(ax.names, ax.values))
        k_names = {"x": ("k3",), "y": ("k1", "k2"), "z": ("k4",)}[axis]

        def model(values):
            state = {**{n: fit.initial_state[f"{n}_m" if not n.startswith("v") else
                                             f"{n}_m_s"] for n in
                        ("x0", "y0", "z0", "vx0", "vy0", "vz0")}, **values}
            k = [values.get(n, base.get(n, base.get(k_names[0]))) for n in
                 ("k1", "k2", "k3", "k4")]
            return position(t, [state[n] for n in ("x0", "y0", "z0", "vx0", "vy0", "vz0")],
                            k, CP, v1=V1)[:, col]

        r = model(base) - data[f"{axis}_m"].to_numpy()
        for name, value in base.items():
            h = 1e-6 * max(abs(value), 1e-3)
            col_j = (model({**base, name: value + h}) - model({**base, name: value - h})) / (2 * h)
            cos = abs(col_j @ r) / (np.linalg.norm(col_j) * np.linalg.norm(r))
            assert cos < 1e-7, (axis, name, cos)
    moved = data.copy()
    moved.loc[40, ["x_m", "y_m", "z_m"]] += 0.002
    every = fit_throw(moved, CP, v1=V1, errors=False)
    near = fit_throw(moved, CP, v1=V1, errors=False, near=fit)
    for name in ("k1", "k2", "k3", "k4"):
        a, b = every.coefficients[name], near.coefficients[name]
        assert a.determined == b.determined
        if a.determined:
            assert b.value == pytest.approx(a.value, rel=1e-10)


def test_front_view_only_leaves_k4_undetermined():
    data = noisy_track(1)
    data["z_m"] = np.nan
    fit = fit_throw(data, CP, v1=V1)
    assert not fit.coefficients["k4"].determined
    assert fit.coefficients["k4"].value is None
    assert "top view" in fit.coefficients["k4"].reason
    assert fit.coefficients["k3"].determined


def test_no_descent_in_view_leaves_k2_undetermined():
    data = noisy_track(2, t_end=0.15)              # the apex is at 0.19 s
    fit = fit_throw(data, CP, v1=V1)
    assert not fit.coefficients["k2"].determined
    assert "no descent" in fit.coefficients["k2"].reason
    assert fit.coefficients["k1"].value == pytest.approx(2.2, rel=0.03)


def test_thrown_downward_leaves_k1_undetermined():
    state = (0.25, 0.15, 0.0, 7.0, -2.0, 2.0)
    fit = fit_throw(noisy_track(4, state=state, sigma=0.0005), CP, v1=V1)
    assert not fit.coefficients["k1"].determined
    assert "no ascent" in fit.coefficients["k1"].reason
    assert fit.coefficients["k2"].value == pytest.approx(2.5, rel=0.05)


def test_drag_free_scene_fits_gravity_multipliers():
    k = (1.3, 0.9, 1.0, 1.0)
    data = noisy_track(6, cp=0.0, k=k, t_end=0.8, sigma=0.001)
    fit = fit_throw(data, 0.0, v1=V1)
    assert fit.coefficients["k1"].value == pytest.approx(1.3, rel=0.02)
    assert fit.coefficients["k2"].value == pytest.approx(0.9, rel=0.02)
    for name in ("k3", "k4"):
        assert not fit.coefficients[name].determined
        assert "Cp = 0" in fit.coefficients[name].reason


def test_information_criterion_prefers_the_true_model():
    data = noisy_track(7, sigma=0.0005, t_end=0.5)
    ranking = compare_models(data, CP, v1=V1)
    assert ranking[0][0] == "quadratic"
    lin = noisy_track(8, sigma=0.0005, t_end=0.5, model="linear", cp=0.3)
    assert compare_models(lin, 0.3, v1=V1)[0][0] == "linear"


def test_predict_reproduces_the_fit():
    data = noisy_track(9)
    fit = fit_throw(data, CP, v1=V1)
    resid = fit.predict(data.t_s) - data[["x_m", "y_m", "z_m"]].to_numpy()
    assert np.sqrt(np.mean(resid**2)) == pytest.approx(0.0015, rel=0.1)


@pytest.mark.parametrize("change, word", [
    (lambda d: d.drop(columns="y_m"), "y_m"),
    (lambda d: d.assign(x_m=np.nan, y_m=np.nan, z_m=np.nan), "no axis"),
])
def test_bad_tracks_are_refused(change, word):
    with pytest.raises(InputError, match=word):
        fit_throw(change(noisy_track(0)), CP, v1=V1)


def test_bad_cp_is_refused():
    with pytest.raises(InputError, match="cp"):
        fit_throw(noisy_track(0), -0.1, v1=V1)


def _persistent_errors(rng, n, *, white_m, slow_m, ell_frames):
    """White noise plus an exponentially correlated series."""
    return white_m * rng.standard_normal(n) + slow_m * ou_series(rng, n, ell_frames)


def test_intervals_cover_the_truth_under_errors_that_persist_over_frames():
    """Tracking errors persist over tens of frames (the sample run's residuals): the
    intervals must still cover the truth. Errors: 0.05 mm white plus 0.15 mm with a
    20-frame correlation time, per axis; 25 draws. (tests/test_errmodel.py shows the
    white-noise formula failing on such errors.)"""
    t = np.arange(0, 0.3, 1 / FPS)
    xyz = position(t, STATE, K, CP, v1=V1)
    rng = np.random.default_rng(11)
    hits = {k: 0 for k in ("k1", "k2", "k3", "k4")}
    draws = 25
    for _ in range(draws):
        err = np.column_stack([_persistent_errors(rng, t.size, white_m=5e-5, slow_m=1.5e-4,
                                                  ell_frames=20.0) for _ in range(3)])
        fit = fit_throw(track(t, xyz + err), CP, v1=V1)
        for i, name in enumerate(hits):
            lo, hi = fit.coefficients[name].ci95
            hits[name] += lo <= K[i] <= hi
        assert fit.axes["y"].error_model.correlated_fraction > 0.5
    for name, h in hits.items():
        assert h >= 21, (name, h)          # 95 % nominal; 21 of 25 or more


# ---------------------------------------------------------------- in a notebook

def test_repr_is_one_short_line_with_the_key_numbers():
    fit = fit_throw(noisy_track(3), CP, v1=V1)
    text = repr(fit)                # was 4,096 characters with every axis's arrays
    assert len(text) < 300 and "\n" not in text and "array" not in text, text
    k1 = fit.coefficients["k1"]
    assert text.startswith("ThrowFit(model='quadratic', k1=")
    assert f"k1={k1.value:#.4g}±{k1.stderr:.2g}" in text and "480/480/480" in text
    for axis in fit.axes.values():
        assert len(repr(axis)) < 300 and "array" not in repr(axis)


def test_summary_has_the_coefficients_their_intervals_and_why_not():
    data = noisy_track(1)
    data["z_m"] = np.nan
    fit = fit_throw(data, CP, v1=V1)
    text = fit.summary()
    assert "quadratic drag" in text and "Cp = 0.115 s/m" in text and "v1 = 2 m/s" in text
    assert "Points: x 480, y 480, z 0" in text
    for k in ("k1", "k2", "k3"):
        c = fit.coefficients[k]
        row = next(line for line in text.splitlines() if line.startswith(k + " "))
        assert f"{c.value:.5g}" in row and f"{c.stderr:.3g}" in row
        assert f"{c.ci95[0]:.5g} .. {c.ci95[1]:.5g}" in row
    k4 = next(line for line in text.splitlines() if line.startswith("k4 "))
    assert "not determined" in k4 and "no top view" in k4
    for a in "xy":
        assert f"{1000 * fit.residual_rms_m[a]:.3g}" in text
    assert "(not fitted)" in text and "k4=n.d." in repr(fit)
    html = fit._repr_html_()
    assert html.count("<table>") == 2 and "no top view" in html and "<b>Throw fit" in html


def test_tables_hold_the_fit_in_full_precision():
    data = noisy_track(1)
    data["z_m"] = np.nan
    fit = fit_throw(data, CP, v1=V1)
    table = fit.coef_table
    assert list(table.index) == ["k1", "k2", "k3", "k4"]
    assert list(table.columns) == ["value", "stderr", "ci95_low", "ci95_high", "determined",
                                   "axis", "reason"]
    for k in ("k1", "k2", "k3"):
        c = fit.coefficients[k]
        assert table.loc[k, "value"] == c.value == fit.params[k]
        assert table.loc[k, "stderr"] == c.stderr == fit.bse[k]
        assert (table.loc[k, "ci95_low"], table.loc[k, "ci95_high"]) == c.ci95
        assert tuple(fit.conf_int().loc[k]) == c.ci95
    assert np.isnan(fit.params["k4"]) and not table.loc["k4", "determined"]
    assert table.loc["k4", "reason"] == fit.coefficients["k4"].reason
    # another level from the t quantile: the stored 95 % interval is value ± t se
    c = fit.coefficients["k1"]
    half95 = c.ci95[1] - c.value
    half99 = fit.conf_int(0.01).loc["k1", "upper"] - c.value
    dof = fit.axes["y"].dof
    from scipy import stats
    assert half99 / half95 == pytest.approx(stats.t.ppf(0.995, dof) / stats.t.ppf(0.975, dof))
    axes = fit.axes_table
    assert axes.loc["x", "residual_rms_m"] == fit.residual_rms_m["x"]
    assert axes.loc["y", "points"] == 480 and np.isnan(axes.loc["z", "residual_rms_m"])


def test_conf_int_of_a_bootstrap_keeps_to_its_95_percent():
    fit = fit_throw(noisy_track(5, t_end=0.3), CP, v1=V1, bootstrap=20,
                    rng=np.random.default_rng(0))
    assert tuple(fit.conf_int().loc["k3"]) == fit.coefficients["k3"].ci95
    assert "bootstrap" in fit.summary()
    with pytest.raises(InputError, match="bootstrap"):
        fit.conf_int(0.1)


def test_what_is_not_determined_is_logged(caplog):
    data = noisy_track(1)
    data["z_m"] = np.nan
    with caplog.at_level("DEBUG", logger="fits"):
        fit_throw(data, CP, v1=V1)
    records = [r for r in caplog.records if r.name == "fits.lsq"]
    assert any(r.levelname == "INFO" and "k4 not determined: no top view" in r.getMessage()
               for r in records)
    assert any(r.levelname == "DEBUG" and r.getMessage().startswith("y: 480 points")
               for r in records)
