"""fits.metrics against Chen 2018 Table 4, Liao 2021 Tables 2 and 3 (and the statements
the papers make about them), closed-form cases and invariances."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fits.errors import InputError
from fits.metrics import (coverage_uniformity_pct, mulching_uniformity, pickup_rate_pct,
                          recovery_rate_pct, summarize_trials, uncleanness_pct,
                          winding_mass_kg)

DATA = Path(__file__).resolve().parents[1] / "datasets" / "published"


def test_liao_table3_pickup_rate_from_the_printed_masses():
    t = pd.read_csv(DATA / "liao2021_table3_pickup.csv")
    picked = t["left_kg"] + t["right_kg"]
    np.testing.assert_allclose(picked, t["picked_kg"], atol=1e-9)
    rate = pickup_rate_pct(picked.to_numpy(), t["total_kg"].to_numpy())
    np.testing.assert_allclose(np.round(rate, 1), t["pickup_rate_pct"], atol=1e-9)
    # section 3.2.3: "3 个测试区内稻秆捡拾率均值为 92.8%, 且每个测试区 ... 均大于 90%"
    summary = summarize_trials(rate)
    assert round(summary.mean, 1) == 92.8 and summary.min > 90 and summary.n == 3


def test_chen_table4_averages_and_the_rate_definitions():
    t = pd.read_csv(DATA / "chen2018_table4_field_test.csv")
    # the printed averages (91.21 % and 6.08 %) are the means of the five sections
    assert round(summarize_trials(t["recovery_rate_pct"]).mean, 2) == 91.21
    assert round(summarize_trials(t["uncleanness_pct"]).mean, 2) == 6.08
    # eq. 23 relates recovered and unrecovered straw: a section whose recovered share
    # is S % of the straw met gives S back, whatever the amount of straw
    for s in t["recovery_rate_pct"]:
        for straw_kg in (2.73 * 10 * 0.5, 1.0, 123.4):
            got = recovery_rate_pct(s / 100 * straw_kg, (1 - s / 100) * straw_kg)
            assert got == pytest.approx(s, rel=1e-12)
    # eq. 24 is relative to the recovered straw, not to all the material collected
    assert uncleanness_pct(0.5, 10.0) == pytest.approx(5.0)
    assert recovery_rate_pct(10.0, 0.0) == 100.0 and recovery_rate_pct(0.0, 3.0) == 0.0


def test_liao_table2_coverage_uniformity():
    t = pd.read_csv(DATA / "liao2021_table2_coverage_uniformity.csv")
    trials = t[["trial1_pct", "trial2_pct", "trial3_pct"]].to_numpy()
    # every printed F_b comes back from four strip masses with that spread (eq. 21)
    for fb in trials.ravel():
        spread = 1 - fb / 100
        masses = np.array([1 - spread / 2, 1.0, 1.0, 1 + spread / 2])   # mean 1
        assert coverage_uniformity_pct(masses) == pytest.approx(fb, abs=1e-9)
    # section 3.2.2: best at 300 r/min, above 92 %; below 300 r/min each +30 r/min
    # raises it by 20-35 points and stays under 90 %
    means = np.array([summarize_trials(row).mean for row in trials])
    assert t["rpm"][int(np.argmax(means))] == 300 and means.max() > 92
    below = means[t["rpm"].to_numpy() <= 300]
    steps = np.diff(below)
    assert np.all((steps >= 20) & (steps <= 35)) and np.all(below[:-1] < 90)


def test_coverage_uniformity_closed_forms():
    assert coverage_uniformity_pct([0.5, 0.5, 0.5, 0.5]) == 100.0
    assert coverage_uniformity_pct([1.0, 2.0, 3.0, 2.0]) == pytest.approx(0.0)
    assert coverage_uniformity_pct([0.0, 0.0, 0.0, 4.0]) == pytest.approx(-300.0)
    batch = coverage_uniformity_pct(np.array([[1, 1, 1, 1], [1, 2, 3, 2]], float))
    np.testing.assert_allclose(batch, [100.0, 0.0], atol=1e-12)


def test_mulching_uniformity_is_the_squared_coefficient_of_variation():
    assert mulching_uniformity([0.3] * 10) == pytest.approx(0.0, abs=1e-15)
    assert mulching_uniformity([1.0, 3.0]) == pytest.approx(2 / (2 * 4))
    rng = np.random.default_rng(11)
    m = rng.uniform(0.1, 0.4, size=10)
    assert mulching_uniformity(m) == pytest.approx(np.var(m) / np.mean(m) ** 2, rel=1e-12)


@given(st.lists(st.floats(0.01, 10), min_size=2, max_size=12), st.floats(1e-3, 1e3))
@settings(max_examples=60, deadline=None)
def test_uniformity_measures_do_not_depend_on_the_mass_unit(masses, scale):
    m = np.array(masses)
    assert coverage_uniformity_pct(m * scale) == pytest.approx(coverage_uniformity_pct(m),
                                                               rel=1e-9, abs=1e-9)
    assert mulching_uniformity(m * scale) == pytest.approx(mulching_uniformity(m),
                                                           rel=1e-9, abs=1e-12)
    assert coverage_uniformity_pct(m) <= 100.0 + 1e-12
    assert mulching_uniformity(m) >= 0.0


def test_winding_mass():
    assert winding_mass_kg(13.0, 12.9) == pytest.approx(0.1)
    np.testing.assert_allclose(winding_mass_kg([9.0, 11.0], [8.9, 10.85]), [0.1, 0.15])
    with pytest.raises(InputError, match="more straw thrown out"):
        winding_mass_kg(1.0, 1.2)


@pytest.mark.parametrize("call, match", [
    (lambda: recovery_rate_pct(-1.0, 2.0), "recovered_kg must be >= 0"),
    (lambda: recovery_rate_pct(0.0, 0.0), "not defined"),
    (lambda: uncleanness_pct(0.1, 0.0), "recovered_kg must be > 0"),
    (lambda: pickup_rate_pct(1.0, float("nan")), "total_kg must be finite"),
    (lambda: coverage_uniformity_pct([1.0]), "at least 2"),
    (lambda: coverage_uniformity_pct([0.0, 0.0]), "no straw"),
    (lambda: mulching_uniformity([0.0, 0.0, 0.0]), "no straw"),
    (lambda: summarize_trials([]), "non-empty"),
])
def test_bad_input_is_refused(call, match):
    with pytest.raises(InputError, match=match):
        call()
