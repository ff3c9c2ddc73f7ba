"""fits.rsm against Chen et al. 2018 (Tables 1-3, eqs. 20-23), closed forms and
independent computations (brute-force leave-one-out, 60-digit natural-unit solves)."""

import math
from pathlib import Path

import mpmath
import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fits.rsm._terms import model_matrix, natural_expansion, second_order_terms
from fits.compare import compare, printed_unit, read_published
from fits.errors import InputError
from fits.rsm import AliasedTermWarning, Factor, code_factors, fit_rsm, read_table

DATA = Path(__file__).resolve().parents[1] / "datasets" / "published"
FACTORS = [Factor("A", "n_rpm", 550, 100), Factor("B", "blade_angle_deg", 0, 5),
           Factor("C", "speed_kmh", 7.2, 1.8)]
NAT_TO_CODED = {"n_rpm": "A", "blade_angle_deg": "B", "speed_kmh": "C"}


@pytest.fixture(scope="module")
def table2():
    return read_table(DATA / "chen2018_table2_ccd.csv")


@pytest.fixture(scope="module")
def fits(table2):
    return {r: fit_rsm(table2, r, FACTORS) for r in ("k1", "k2", "k3", "k4")}


def _natural_table(table2):
    """Table 2 rewritten in natural units (Table 1 coding), as a lab would keep it."""
    df = pd.DataFrame({f.name: f.decode(table2[f.letter].astype(float)) for f in FACTORS})
    for r in ("k1", "k2", "k3", "k4"):
        df[r] = table2[r].astype(float)
    return df


# ---------------------------------------------------------------- coding (Table 1)

def test_coding_reproduces_table1():
    t1 = pd.read_csv(DATA / "chen2018_table1_factor_codes.csv")
    for f in FACTORS:
        np.testing.assert_allclose(f.code(t1[f.name]), t1["code"], atol=1e-12)
        np.testing.assert_allclose(f.decode(t1["code"]), t1[f.name], atol=1e-12)


@given(st.floats(-1e4, 1e4), st.floats(-1e3, 1e3).filter(lambda s: abs(s) > 1e-3),
       st.floats(-1e4, 1e4))
@settings(max_examples=50, deadline=None)
def test_coding_round_trip(centre, step, x):
    f = Factor("A", "x", centre, step)
    assert f.decode(f.code(x)) == pytest.approx(x, rel=1e-12, abs=1e-9)


@pytest.mark.parametrize("text", ["A=n_rpm:550", "A:n_rpm:550:100", "A=n_rpm:x:100",
                                  "A=n_rpm:550:0", "A=n:rpm:550:100", "=n_rpm:550:100"])
def test_factor_parse_refuses_bad_text(text):
    with pytest.raises(InputError):
        Factor.parse(text)


def test_natural_and_coded_columns_agree_or_are_refused(table2):
    nat = _natural_table(table2)
    np.testing.assert_allclose(code_factors(nat, FACTORS), table2[["A", "B", "C"]].astype(float))
    both = nat.copy()
    both["A"] = table2["A"].astype(float)
    both.loc[3, "A"] = 2.0
    with pytest.raises(InputError, match="row 4, column 'A'"):
        code_factors(both, FACTORS)


# ---------------------------------------------------------------- elimination (eqs. 20-23)

def test_elimination_selects_the_terms_of_eqs_20_23(fits):
    eqs = pd.read_csv(DATA / "chen2018_equations_20_23_published.csv")
    for resp, group in eqs.groupby("response"):
        expected = set()
        for term in group["term"]:
            if term == "Intercept":
                continue
            if term.endswith("^2"):
                expected.add(NAT_TO_CODED[term[:-2]] + "^2")
            else:
                expected.add(":".join(NAT_TO_CODED[p] for p in term.split(":")))
        assert set(fits[resp].terms) == expected, resp


def test_hierarchy_keeps_main_effects_of_an_interaction():
    # synthetic truth: y = 3 + 2 A B exactly on a 3^2 grid plus replicated centre
    a, b = np.meshgrid([-1.0, 0.0, 1.0], [-1.0, 0.0, 1.0])
    a, b = np.r_[a.ravel(), 0, 0, 0], np.r_[b.ravel(), 0, 0, 0]
    noise = np.array([0.01, -0.02, 0.015, 0.0, -0.01, 0.02, -0.015, 0.01, 0.0,
                      0.01, -0.01, 0.005])
    table = pd.DataFrame({"A": a, "B": b, "y": 3 + 2 * a * b + noise})
    fs = [Factor("A", "A"), Factor("B", "B")]
    kept = fit_rsm(table, "y", fs, hierarchy=True)
    dropped = fit_rsm(table, "y", fs, hierarchy=False)
    assert set(kept.terms) == {"A", "B", "A:B"}
    assert set(dropped.terms) == {"A:B"}
    assert dropped.coefficients_coded["A:B"] == pytest.approx(2.0, abs=0.02)


# ---------------------------------------------------------------- ANOVA (Table 3)

def test_table3_within_001_where_the_printed_value_is_self_consistent(fits):
    published = read_published(DATA / "chen2018_table3_anova_published.csv")
    comp = compare(list(fits.values()), published)
    # MODEL.md section 3: the two printed values that are not self-consistent
    flagged = {(r.response, r.source, r.quantity) for r in comp.flagged}
    assert flagged == {("k2", "regression", "f"), ("k2", "pure_error", "ss")}
    pub = pd.read_csv(DATA / "chen2018_table3_anova_published.csv")
    checked = 0
    for _, row in pub.iterrows():
        fit = fits[row.response]
        got = fit.anova[row.source]
        assert got.df == row.df
        for q in ("ss", "ms", "f"):
            if pd.isna(row[q]) or (row.response, row.source, q) in flagged:
                continue
            assert abs(getattr(got, q) - row[q]) <= 0.01, (row.response, row.source, q)
            checked += 1
    assert checked == 20 + 16 + 8 - 2        # 20 SS, 16 MS, 8 F, less the 2 quirks
    # the quirks themselves, from the printed numbers: F of k2 is 2.39 / 0.14 ...
    k2 = pub[pub.response == "k2"].set_index("source")
    assert round(k2.loc["regression", "ms"] / k2.loc["residual", "ms"], 2) == 17.07
    assert fits["k2"].anova["regression"].f == pytest.approx(17.27, abs=0.005)
    # ... and the printed pure error does not equal residual - lack of fit
    assert abs(k2.loc["residual", "ss"] - k2.loc["lack_of_fit", "ss"] - 1.96) > 0.03
    assert fits["k2"].anova["pure_error"].ss == pytest.approx(3.59 - 1.67, abs=0.01)


def test_pure_error_and_lack_of_fit_from_first_principles(table2, fits):
    coded = table2[["A", "B", "C"]].astype(float).to_numpy()
    centre = np.all(coded == 0, axis=1)
    assert centre.sum() == 18 and len(np.unique(coded, axis=0)) == 15
    for r, fit in fits.items():
        yc = table2.loc[centre, r].astype(float).to_numpy()
        ss_pe = float(np.sum((yc - yc.mean()) ** 2))
        assert fit.anova["pure_error"].ss == pytest.approx(ss_pe, rel=1e-12)
        assert fit.anova["pure_error"].df == 17
        p = len(fit.terms) + 1
        assert fit.anova["lack_of_fit"].df == 15 - p
        assert fit.anova["lack_of_fit"].ss == pytest.approx(
            fit.anova["residual"].ss - ss_pe, rel=1e-10)
        total = fit.anova["total"].ss
        assert fit.anova["regression"].ss + fit.anova["residual"].ss == pytest.approx(total)


def test_fit_statistics_against_independent_definitions(table2, fits):
    fit = fits["k1"]
    y = table2["k1"].astype(float).to_numpy()
    coded = table2[["A", "B", "C"]].astype(float).to_numpy()
    X = model_matrix(coded, [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (2, 0, 0)])
    # PRESS by brute force: refit without each run
    press = 0.0
    for i in range(len(y)):
        keep = np.arange(len(y)) != i
        b, *_ = np.linalg.lstsq(X[keep], y[keep], rcond=None)
        press += (y[i] - X[i] @ b) ** 2
    sst = np.sum((y - y.mean()) ** 2)
    assert fit.press == pytest.approx(press, rel=1e-10)
    assert fit.pred_r2 == pytest.approx(1 - press / sst, rel=1e-10)
    b, *_ = np.linalg.lstsq(X, y, rcond=None)
    yhat = X @ b
    sse = np.sum((y - yhat) ** 2)
    n, p = X.shape
    assert fit.r2 == pytest.approx(1 - sse / sst, rel=1e-12)
    assert fit.adj_r2 == pytest.approx(1 - (sse / (n - p)) / (sst / (n - 1)), rel=1e-12)
    # Design-Expert's adequate precision: range of predictions over sqrt(p MSE / n)
    assert fit.adeq_precision == pytest.approx(np.ptp(yhat) / math.sqrt(p * sse / (n - p) / n))
    assert fit.condition_number == pytest.approx(np.linalg.cond(X), rel=1e-10)


# ---------------------------------------------------------------- natural units (eqs. 20-23)

def test_natural_coefficients_equal_eqs_20_23_to_the_printed_digits(fits):
    eqs = pd.read_csv(DATA / "chen2018_equations_20_23_published.csv", dtype=str)
    for _, row in eqs.iterrows():
        got = fits[row.response].coefficients_natural[row.term]
        printed = float(row.coefficient)
        unit = printed_unit(row.coefficient)
        if (row.response, row.term) == ("k4", "n_rpm:speed_kmh"):
            # printed 5.402e-3 is the exact 5.40278e-3 truncated, not rounded
            assert math.trunc(got / unit) * unit == pytest.approx(printed, rel=1e-12)
            continue
        assert abs(got - printed) <= unit / 2 * (1 + 1e-9), (row.response, row.term, got)


def _natural_solve_60_digits(fit, table2, response):
    """Least squares in natural units at 60 digits: an independent reference."""
    names = list(fit.coefficients_natural)
    nat = _natural_table(table2)
    mpmath.mp.dps = 60
    rows = []
    for i in range(len(nat)):
        row = []
        for name in names:
            v = mpmath.mpf(1)
            if name != "Intercept":
                for part in name.split(":"):
                    base, _, power = part.partition("^")
                    v *= mpmath.mpf(float(nat.loc[i, base])) ** int(power or 1)
            row.append(v)
        rows.append(row)
    X = mpmath.matrix(rows)
    y = mpmath.matrix([mpmath.mpf(float(v)) for v in nat[response]])
    XtX = X.T * X
    b = mpmath.lu_solve(XtX, X.T * y)
    resid = y - X * b
    mse = sum(r * r for r in resid) / (len(nat) - len(names))
    cov = mse * mpmath.inverse(XtX)
    return names, np.array([float(v) for v in b]), np.array(
        [[float(cov[i, j]) for j in range(len(names))] for i in range(len(names))])


def test_coded_route_equals_a_careful_natural_solve(table2, fits):
    for r in ("k1", "k4"):
        fit = fits[r]
        # the natural-unit design matrix is ill-conditioned, the coded one is not
        assert fit.condition_number_natural > 1e4
        assert fit.condition_number < 3
        names, ref, ref_cov = _natural_solve_60_digits(fit, table2, r)
        ours = np.array([fit.coefficients_natural[n] for n in names])
        np.testing.assert_allclose(ours, ref, rtol=1e-10, atol=0)
        scale = np.sqrt(np.outer(np.diag(ref_cov), np.diag(ref_cov)))
        np.testing.assert_allclose(fit.covariance_natural / scale, ref_cov / scale,
                                   rtol=0, atol=1e-10)
    assert fits["k1"].condition_number_natural > 1e6


def test_full_quadratic_natural_polynomial_is_recovered_exactly(table2):
    # synthetic truth in natural units, evaluated at Table 2's settings
    nat = _natural_table(table2)
    n, d, v = nat["n_rpm"], nat["blade_angle_deg"], nat["speed_kmh"]
    truth = {"Intercept": 1.5, "n_rpm": -3e-3, "blade_angle_deg": 0.04, "speed_kmh": 0.2,
             "n_rpm:blade_angle_deg": 2e-5, "n_rpm:speed_kmh": -1e-4,
             "blade_angle_deg:speed_kmh": 3e-3, "n_rpm^2": 4e-6, "blade_angle_deg^2": -2e-3,
             "speed_kmh^2": 1e-2}
    nat["y"] = (truth["Intercept"] + truth["n_rpm"] * n + truth["blade_angle_deg"] * d
                + truth["speed_kmh"] * v + truth["n_rpm:blade_angle_deg"] * n * d
                + truth["n_rpm:speed_kmh"] * n * v + truth["blade_angle_deg:speed_kmh"] * d * v
                + truth["n_rpm^2"] * n * n + truth["blade_angle_deg^2"] * d * d
                + truth["speed_kmh^2"] * v * v)
    nat.loc[14:, "y"] += np.linspace(-1e-3, 1e-3, len(nat) - 14)   # centre replicates
    fit = fit_rsm(nat, "y", FACTORS, eliminate=False)
    for name, value in truth.items():
        assert fit.coefficients_natural[name] == pytest.approx(value, rel=1e-3), name


@given(st.lists(st.floats(-50, 50), min_size=3, max_size=3),
       st.lists(st.floats(0.1, 20), min_size=3, max_size=3),
       st.lists(st.floats(-2, 2), min_size=10, max_size=10),
       st.lists(st.floats(-3, 3), min_size=3, max_size=3))
@settings(max_examples=40, deadline=None)
def test_natural_expansion_evaluates_like_the_coded_polynomial(centres, steps, beta, x):
    terms = [(0, 0, 0)] + second_order_terms(3)
    nat_terms, T = natural_expansion(terms, centres, steps)
    coded = np.array([x])
    z = np.array([[xi * s + c for xi, s, c in zip(x, steps, centres)]])
    y_coded = model_matrix(coded, terms[1:]) @ np.array(beta)
    y_nat = model_matrix(z, nat_terms[1:]) @ (T @ np.array(beta))
    scale = 1.0 + np.abs(model_matrix(coded, terms[1:])) @ np.abs(beta)
    assert abs(y_nat[0] - y_coded[0]) <= 1e-9 * scale[0] * (1 + max(map(abs, centres))) ** 2


def test_box_behnken_design_against_statsmodels():
    # a design the paper did not use: 3-factor Box-Behnken, 3 centre runs, natural columns
    import itertools

    import statsmodels.formula.api as smf
    from statsmodels.stats.anova import anova_lm

    pts = []
    for i, j in itertools.combinations(range(3), 2):
        for a, b in itertools.product((-1, 1), repeat=2):
            p = [0, 0, 0]
            p[i], p[j] = a, b
            pts.append(p)
    pts = np.array(pts + [[0, 0, 0]] * 3, dtype=float)
    rng = np.random.default_rng(2)
    x1, x2, x3 = pts.T
    y = 50 + 3 * x1 - 2 * x2 + 1.5 * x1 * x3 - 4 * x1 ** 2 + rng.normal(0, 0.5, len(pts))
    table = pd.DataFrame({"temp_c": 60 + 10 * x1, "time_min": 30 + 5 * x2,
                          "ph": 7 + 0.5 * x3, "yield_pct": y})
    fs = [Factor("A", "temp_c", 60, 10), Factor("B", "time_min", 30, 5), Factor("C", "ph", 7, 0.5)]
    fit = fit_rsm(table, "yield_pct", fs, eliminate=False)
    ref_df = pd.DataFrame({"A": x1, "B": x2, "C": x3, "y": y})
    ref = smf.ols("y ~ A + B + C + A:B + A:C + B:C + I(A**2) + I(B**2) + I(C**2)", ref_df).fit()
    assert fit.anova["regression"].f == pytest.approx(ref.fvalue, rel=1e-10)
    assert fit.anova["regression"].p == pytest.approx(ref.f_pvalue, rel=1e-8)
    assert fit.r2 == pytest.approx(ref.rsquared, rel=1e-12)
    table3 = anova_lm(ref, typ=3)
    for term, name in [("A", "A"), ("A:C", "A:C"), ("A^2", "I(A ** 2)"), ("C^2", "I(C ** 2)")]:
        t = next(t for t in fit.term_tests if t.term == term)
        assert t.ss == pytest.approx(table3.loc[name, "sum_sq"], rel=1e-9)
        assert t.p == pytest.approx(table3.loc[name, "PR(>F)"], rel=1e-7)
    assert fit.anova["pure_error"].df == 2 and fit.anova["lack_of_fit"].df == 3


# ---------------------------------------------------------------- canonical analysis

def test_canonical_analysis_finds_a_known_maximum(table2):
    nat = _natural_table(table2)
    coded = table2[["A", "B", "C"]].astype(float).to_numpy()
    a, b, c = coded.T
    nat["y"] = 10 - (a - 0.5) ** 2 - 2 * (b + 0.25) ** 2 - 0.5 * (c - 1) ** 2
    nat.loc[20:, "y"] += np.linspace(-1e-4, 1e-4, len(nat) - 20)
    fit = fit_rsm(nat, "y", FACTORS, eliminate=False)
    can = fit.canonical
    assert can.available and can.nature == "maximum" and can.within_design
    np.testing.assert_allclose(sorted(can.eigenvalues), [-2, -1, -0.5], atol=1e-3)
    assert can.stationary_point_natural["n_rpm"] == pytest.approx(600, abs=0.5)
    assert can.stationary_point_natural["blade_angle_deg"] == pytest.approx(-1.25, abs=0.01)
    assert can.stationary_point_natural["speed_kmh"] == pytest.approx(9.0, abs=0.01)
    assert can.response_at_stationary == pytest.approx(10, abs=1e-3)


def test_canonical_analysis_says_why_not_for_a_ridge(fits):
    can = fits["k1"].canonical          # A^2 and A:B only: C has no curvature
    assert not can.available and "singular" in can.reason
    assert min(abs(v) for v in can.eigenvalues) < 1e-12


# ---------------------------------------------------------------- bad and odd designs

def test_aliased_term_is_dropped_with_a_warning_or_refused():
    # 2^3 factorial plus 4 centre points: A^2, B^2 and C^2 are one and the same column
    pts = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)]
                   + [[0, 0, 0]] * 4, dtype=float)
    rng = np.random.default_rng(7)
    y = 5 + pts[:, 0] - 0.5 * pts[:, 1] + 0.3 * pts[:, 0] * pts[:, 2] \
        + rng.normal(0, 0.05, len(pts))
    table = pd.DataFrame({"A": pts[:, 0], "B": pts[:, 1], "C": pts[:, 2], "y": y})
    fs = [Factor("A", "A"), Factor("B", "B"), Factor("C", "C")]
    with pytest.warns(AliasedTermWarning, match="B\\^2, C\\^2"):
        fit = fit_rsm(table, "y", fs, eliminate=False)
    assert "B^2" not in fit.terms and "A^2" in fit.terms
    assert fit.aliased_terms == ("B^2", "C^2")
    assert np.all(np.isfinite(list(fit.coefficients_coded.values())))
    with pytest.raises(InputError, match="cannot be estimated"):
        fit_rsm(table, "y", fs, eliminate=False, on_aliased="error")


def test_fewer_runs_than_terms_is_refused(table2):
    with pytest.raises(InputError, match="fewer runs than terms"):
        fit_rsm(table2.iloc[[0, 1, 2, 4, 9, 10]], "k1", FACTORS)


def test_no_replicates_leaves_lack_of_fit_out(table2):
    fit = fit_rsm(table2.iloc[:15], "k1", FACTORS, eliminate=False)
    assert fit.anova["lack_of_fit"] is None and fit.anova["pure_error"] is None
    assert any("no pure error" in n for n in fit.notes)
    assert fit.to_dict()["anova"]["lack_of_fit"] is None


@pytest.mark.parametrize("change, match", [
    (lambda t: t.drop(columns=["B"]), "no column for factor B 'blade_angle_deg'"),
    (lambda t: t.assign(k1=t["k1"].where(t.index != 6, "2,5")), "row 7.*'k1'.*'2,5'"),
    (lambda t: t.assign(k1=t["k1"].where(t.index != 2, None)), "row 3.*'k1'.*empty"),
    (lambda t: t.assign(k1="2.0"), "constant"),
    (lambda t: t.assign(A="0", B="0", C="0"), "do not vary"),
])
def test_bad_tables_give_one_clear_message(table2, change, match):
    with pytest.raises(InputError, match=match):
        fit_rsm(change(table2.copy()), "k1", FACTORS)


def test_unknown_response_and_bad_alpha(table2):
    with pytest.raises(InputError, match="no response column 'k9'"):
        fit_rsm(table2, "k9", FACTORS)
    with pytest.raises(InputError, match="alpha"):
        fit_rsm(table2, "k1", FACTORS, alpha=1.5)


def test_json_has_the_spec_fields_and_the_added_ones(fits):
    d = fits["k1"].to_dict()
    for key in ("response", "design", "alpha", "terms", "coefficients_coded",
                "coefficients_natural", "anova", "r2", "adj_r2", "pred_r2",
                "adeq_precision", "condition_number", "factors", "design_range_natural",
                "covariance_natural", "residual_ms"):
        assert key in d
    assert set(d["anova"]) == {"regression", "residual", "lack_of_fit", "pure_error", "total"}
    assert d["terms"] == ["A", "B", "C", "A:B", "A^2"]
    assert list(d["coefficients_natural"]) == ["Intercept", "n_rpm", "blade_angle_deg",
                                               "speed_kmh", "n_rpm:blade_angle_deg",
                                               "n_rpm^2"]
    assert d["factors"]["A"] == {"name": "n_rpm", "centre": 550.0, "step": 100.0}
    assert d["design_range_natural"]["n_rpm"] == [350.0, 750.0]
    assert d["design_range_natural"]["speed_kmh"] == pytest.approx([3.6, 10.8])
    cov = np.array(d["covariance_natural"]["matrix"])
    assert cov.shape == (6, 6) and np.allclose(cov, cov.T)
    assert d["residual_ms"] == d["anova"]["residual"]["ms"]
    assert set(d["anova"]["total"]) == {"ss", "df"}


# ---------------------------------------------------------------- fits.compare details

def test_printed_digits_and_the_last_digit_stories():
    from fits.compare import _last_digit_story

    assert printed_unit("8.44") == pytest.approx(0.01)
    assert printed_unit("1.508e-5") == pytest.approx(1e-8)
    assert printed_unit("87380.3") == pytest.approx(0.1)
    assert printed_unit("26") == 1.0
    assert _last_digit_story(0.0054027778, "5.402e-3").startswith("truncated")
    assert _last_digit_story(4.814519e-3, "4.82e-3").startswith("double rounding")
    assert _last_digit_story(1.2345, "1.25").startswith("one unit off")


def test_compare_reads_coded_coefficient_tables(table2, fits, tmp_path):
    path = tmp_path / "coded.csv"
    path.write_text("response,term,coefficient\nk3,Intercept,4.78\nk3,A,0.64\nk3,A:B,-0.34\n"
                    "k3,B,-0.30\n")
    comp = compare([fits["k3"]], read_published(path))
    status = {r.source: r.status for r in comp.rows}
    assert status == {"Intercept": "match", "A": "last digit", "A:B": "match",
                      "B": "differs"}


# ---------------------------------------------------------------- in a notebook

CHEN_ARGS = [str(DATA / "chen2018_table2_ccd.csv"), "--factor", "A=n_rpm:550:100",
             "--factor", "B=blade_angle_deg:0:5", "--factor", "C=speed_kmh:7.2:1.8"]


def test_summary_is_what_vidtrack_anova_prints(fits, vidtrack_cli):
    res = vidtrack_cli("anova", *CHEN_ARGS, "--response", "k1")
    assert res.returncode == 0, res.stderr
    assert res.stdout == fits["k1"].summary() + "\n"
    # Table 3: F 22.04 of the model and 0.59 (p 0.7861) of the lack of fit
    lines = fits["k1"].summary().splitlines()
    reg = next(line for line in lines if line.startswith("Regression"))
    lof = next(line for line in lines if line.strip().startswith("Lack of fit"))
    assert reg.split()[-2:] == ["22.04", "<0.0001"]
    assert lof.split()[-2:] == ["0.59", "0.7861"]


def test_anova_table_is_the_fits_anova_rows(fits):
    for fit in fits.values():
        table = fit.anova_table
        assert list(table.columns) == ["ss", "df", "ms", "f", "p"]
        assert list(table.index) == ["Regression", "Residual", "Lack of fit", "Pure error",
                                     "Total"]
        for key, label in (("regression", "Regression"), ("residual", "Residual"),
                           ("lack_of_fit", "Lack of fit"), ("pure_error", "Pure error"),
                           ("total", "Total")):
            row = fit.anova[key]
            for q in ("ss", "df", "ms", "f", "p"):
                want = getattr(row, q)
                got = table.loc[label, q]
                assert (np.isnan(got) if want is None else got == want), (key, q)
    assert fits["k1"].anova_table.loc["Regression", "f"] == pytest.approx(22.04, abs=0.005)


def test_anova_table_leaves_out_what_the_design_cannot_give(table2):
    once = table2.drop_duplicates(subset=["A", "B", "C"])
    fit = fit_rsm(once, "k1", FACTORS)
    assert list(fit.anova_table.index) == ["Regression", "Residual", "Total"]


def test_coefficient_tables_coded_and_natural(fits):
    fit = fits["k1"]
    coded = fit.coef_table
    assert list(coded.index) == ["Intercept", "A", "B", "C", "A:B", "A^2"]
    assert list(coded.columns) == ["coefficient", "stderr", "ci95_low", "ci95_high", "ss",
                                   "f", "p"]
    for t in fit.term_tests:
        assert coded.loc[t.term, "coefficient"] == t.coefficient == fit.params[t.term]
        assert coded.loc[t.term, "p"] == t.p == fit.pvalues[t.term]
        assert coded.loc[t.term, "ss"] == t.ss and coded.loc[t.term, "f"] == t.f
    assert np.isnan(coded.loc["Intercept", "p"])
    assert fit.bse.to_dict() == fit.stderr_coded
    # the interval is b ± t(0.975, 26) se, as statsmodels gives it
    from scipy import stats
    t26 = stats.t.ppf(0.975, fit.anova["residual"].df)
    assert coded.loc["A", "ci95_high"] == pytest.approx(0.635 + t26 * fit.stderr_coded["A"])
    natural = fit.coef_table_natural
    assert list(natural.index) == list(fit.coefficients_natural)
    assert natural["coefficient"].to_dict() == fit.coefficients_natural
    # eq. 20: 1.508e-5 n^2
    assert natural.loc["n_rpm^2", "coefficient"] == pytest.approx(1.508e-5, abs=5e-9)
    se = np.sqrt(np.diag(fit.covariance_natural))
    assert natural["stderr"].to_numpy() == pytest.approx(se)
    assert fit.conf_int(natural=True)["upper"].to_numpy() == pytest.approx(
        natural["ci95_high"].to_numpy())


def test_reprs_are_short_and_html_is_escaped(fits):
    fit = fits["k1"]
    text = repr(fit)                # was 7,820 characters (every array of the fit)
    assert text == "RsmFit(response='k1', terms=5, r2=0.8091, adj_r2=0.7724, n=32)"
    assert len(repr(fit.canonical)) < 300
    published = read_published(DATA / "chen2018_table3_anova_published.csv")
    comp = compare(list(fits.values()), published)
    assert repr(comp) == ("Comparison(source='chen2018_table3_anova_published.csv', "
                          "rows=64, flagged=2, notes=0)")
    assert len(comp.to_frame()) == 64 and comp.summary() == comp._report().text()
    html = fit._repr_html_()
    assert "&lt;0.0001" in html and "<0.0001" not in html
    assert html.count("<table>") == 2 and "22.04" in html and "0.7861" in html


def test_elimination_is_logged(table2, caplog):
    with caplog.at_level("DEBUG", logger="fits"):
        fit_rsm(table2, "k1", FACTORS)
    msgs = [r.getMessage() for r in caplog.records if r.name == "fits.rsm.fit"]
    assert msgs[0] == "eliminated A:C (p = 0.8092 > alpha 0.05)"
    assert len([m for m in msgs if m.startswith("eliminated")]) == 4
