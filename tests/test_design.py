"""fits.design: run sheets against the published designs (Chen 2018 Table 2, Hou 2019
Table 3), the arrays against properties known in closed form, the run order against its
seed."""

import itertools
from collections import Counter

import numpy as np
import pandas as pd
import pytest

from conftest import REPO
from fits.design import (ARRAYS, LevelFactor, ccd_alpha, central_composite,
                         default_columns, orthogonal_array, orthogonal_design)
from fits.errors import InputError
from fits.rsm import Factor

PUBLISHED = REPO / "datasets" / "published"
CHEN = [Factor("A", "n_rpm", 550, 100), Factor("B", "blade_angle_deg", 0, 5),
        Factor("C", "speed_kmh", 7.2, 1.8)]
HOU = [LevelFactor("A", "rho0_mm", (150, 200, 250)), LevelFactor("B", "tau0_deg", (20, 30, 40)),
       LevelFactor("C", "vm_kmh", (3.6, 5.4, 7.2)),
       LevelFactor("D", "omega_rad_s", (42.0, 52.5, 63.0))]


def _rows(frame, columns):
    """The rows of ``columns`` as a multiset (values to 9 digits)."""
    return Counter(tuple(round(float(v), 9) for v in row)
                   for row in frame[columns].itertuples(index=False))


def test_chen2018_table2_is_reproduced():
    """Chen 2018's three-factor, five-level CCD: the published settings as a multiset, in
    coded units (Table 2) and in natural units (Table 1's codes)."""
    table2 = pd.read_csv(PUBLISHED / "chen2018_table2_ccd.csv")
    codes = pd.read_csv(PUBLISHED / "chen2018_table1_factor_codes.csv").set_index("code")
    # the paper's design, read off its table: the axial distance and the centre runs
    alpha = float(table2["A"].abs().max())
    centre = int((table2[["A", "B", "C"]] == 0).all(axis=1).sum())
    assert (alpha, centre) == (2.0, 18)

    d = central_composite(CHEN, alpha=alpha, centre_points=centre, rng=1)
    assert len(d.table) == len(table2) == 32
    assert _rows(d.table, ["A", "B", "C"]) == _rows(table2, ["A", "B", "C"])
    natural = pd.DataFrame({f.name: codes.loc[table2[f.letter].astype(int), f.name].to_numpy()
                            for f in CHEN})
    names = [f.name for f in CHEN]
    assert _rows(d.table, names) == _rows(natural, names)
    # its standard order is the table's (factorial in Yates' order, axial, centre)
    assert np.array_equal(d.table[["A", "B", "C"]].to_numpy(),
                          table2[["A", "B", "C"]].to_numpy())
    # Chen's "quadratic regression orthogonal" CCD: the orthogonal alpha of 18 centre runs
    assert ccd_alpha(3, "orthogonal", centre_points=18) == pytest.approx(2.0, abs=1e-12)


def test_hou2019_table3_is_reproduced():
    table3 = pd.read_csv(PUBLISHED / "hou2019_table3_l27.csv")
    d = orthogonal_design(HOU, "L27", rng=7)
    assert d.columns == {"A": 1, "B": 2, "C": 5, "D": 9}
    names = [f.name for f in HOU]
    assert _rows(d.table, names) == _rows(table3, names)
    # row for row too, in the array's standard order
    assert np.allclose(d.table[names].to_numpy(), table3[names].to_numpy())
    # the columns given explicitly give the same
    explicit = [LevelFactor(f.letter, f.name, f.levels, c) for f, c in zip(HOU, (1, 2, 5, 9))]
    assert d.table.equals(orthogonal_design(explicit, "L27", rng=7).table)


@pytest.mark.parametrize("name", sorted(ARRAYS))
def test_arrays_are_orthogonal_of_strength_two(name):
    """Every pair of columns holds each pair of levels equally often (the definition), the
    first row is all level 1 and the size is p^m by (p^m - 1) / (p - 1)."""
    p, m = ARRAYS[name]
    a = orthogonal_array(name)
    n = p ** m
    assert a.shape == (n, (n - 1) // (p - 1))
    assert set(np.unique(a)) == set(range(1, p + 1))
    assert (a[0] == 1).all()
    for i, j in itertools.combinations(range(a.shape[1]), 2):
        counts = Counter(zip(a[:, i], a[:, j]))
        assert len(counts) == p * p and set(counts.values()) == {n // (p * p)}, (i, j)


def test_l27_interaction_columns_are_taguchis():
    """Taguchi's L27 linear graph: columns 1, 2, 5 basic; 3 and 4 carry the interaction of
    1 and 2, 6 and 7 that of 1 and 5, 8 and 11 that of 2 and 5: each such column is a
    function of the two (the pair fixes its level) and of no single one."""
    a = orthogonal_array("L27")

    def determined(cols, target):
        seen = {}
        for row in a:
            key = tuple(row[c - 1] for c in cols)
            if seen.setdefault(key, row[target - 1]) != row[target - 1]:
                return False
        return True

    for pair, cols in (((1, 2), (3, 4)), ((1, 5), (6, 7)), ((2, 5), (8, 11))):
        for c in cols:
            assert determined(pair, c) and not determined(pair[:1], c), (pair, c)
    # the rows run through the basic columns' levels in order (1 slowest, 5 fastest)
    digits = list(itertools.product((1, 2, 3), repeat=3))
    assert [tuple(r) for r in a[:, [0, 1, 4]]] == digits


def test_default_columns():
    assert default_columns("L27", 4) == [1, 2, 5, 9]
    assert default_columns("L8", 4) == [1, 2, 4, 7]
    assert default_columns("L9", 4) == [1, 2, 3, 4]
    assert default_columns("L16", 5) == [1, 2, 4, 8, 15]
    with pytest.raises(InputError, match="L9 has 4 columns, got 5"):
        default_columns("L9", 5)


def test_alpha_rules():
    assert ccd_alpha(3, "rotatable", centre_points=6) == pytest.approx(8 ** 0.25)
    assert ccd_alpha(2, "rotatable", centre_points=5) == pytest.approx(2 ** 0.5)
    assert ccd_alpha(3, "face", centre_points=6) == 1.0
    assert ccd_alpha(3, 1.5, centre_points=6) == 1.5
    for bad in (0, -1.0, float("nan"), float("inf"), "star"):
        with pytest.raises(InputError, match="alpha"):
            ccd_alpha(3, bad, centre_points=6)


def test_orthogonal_alpha_makes_the_square_columns_orthogonal():
    """The property that defines it: centred square columns orthogonal to each other."""
    for k, nc in ((2, 5), (3, 6), (3, 18), (4, 7)):
        factors = [Factor(chr(65 + i), f"x{i}", 0, 1) for i in range(k)]
        d = central_composite(factors, alpha="orthogonal", centre_points=nc, rng=0)
        sq = d.table[[f.letter for f in factors]].to_numpy() ** 2
        sq -= sq.mean(axis=0)
        gram = sq.T @ sq
        assert np.allclose(gram - np.diag(np.diag(gram)), 0, atol=1e-9), (k, nc)


def test_ccd_counts_and_natural_levels():
    d = central_composite(CHEN, centre_points=6, rng=0)        # rotatable
    t = d.table
    assert len(t) == 8 + 6 + 6
    assert Counter(t["point"]) == {"factorial": 8, "axial": 6, "centre": 6}
    assert t["A"].abs().max() == pytest.approx(8 ** 0.25)
    # natural = centre + coded * step, without float noise
    assert np.allclose(t["n_rpm"], 550 + 100 * t["A"])
    assert set(t.loc[t["point"] == "factorial", "speed_kmh"]) == {5.4, 9.0}
    assert repr(float(central_composite(CHEN, alpha=2, centre_points=0, rng=0)
                      .table["speed_kmh"].max())) == "10.8"


def test_run_order_is_a_permutation_reproducible_from_its_seed():
    a = central_composite(CHEN, alpha=2, centre_points=18, rng=42)
    b = central_composite(CHEN, alpha=2, centre_points=18, rng=42)
    c = central_composite(CHEN, alpha=2, centre_points=18, rng=43)
    assert sorted(a.table["run_order"]) == list(range(1, 33))
    assert a.table.equals(b.table) and a.seed == 42
    assert not np.array_equal(a.table["run_order"], c.table["run_order"])
    sheet = a.run_sheet()
    assert list(sheet["run_order"]) == list(range(1, 33))
    o1, o2 = (orthogonal_design(HOU, "L27", rng=s).table["run_order"] for s in (5, 5))
    assert np.array_equal(o1, o2)
    # a Generator is taken as it is (the caller's stream)
    g = central_composite(CHEN, rng=np.random.default_rng(42))
    assert g.seed is None and sorted(g.table["run_order"]) == list(range(1, 21))


@pytest.mark.parametrize("factors, match", [
    ([CHEN[0]], "needs 2 to 10 factors, got 1"),
    ([CHEN[0], Factor("B", "n_rpm", 0, 5)], "two factors have the name 'n_rpm'"),
    ([CHEN[0], Factor("A", "speed_kmh", 0, 5)], "two factors have the letter 'A'"),
    ([CHEN[0], Factor("B", "speed_kmh", 7.2, -1.8)], "step must be > 0"),
    ([CHEN[0], Factor("B", "A", 7.2, 1.8)], "names two columns"),
])
def test_bad_ccd_factors(factors, match):
    with pytest.raises(InputError, match=match):
        central_composite(factors, rng=0)


def test_zero_step_is_refused():
    with pytest.raises(InputError, match="step must not be 0"):
        Factor.parse("A=n_rpm:550:0")


@pytest.mark.parametrize("factors, array, match", [
    ([LevelFactor("A", "rho0_mm", (150, 200))], "L27", "3 levels per column, got 2"),
    ([LevelFactor("A", "rho0_mm", (150, 200, 250), 14)], "L27", "columns 1 to 13, got 14"),
    ([LevelFactor("A", "a", (1, 2, 3), 2), LevelFactor("B", "b", (1, 2, 3), 2)], "L27",
     "two factors are on column 2"),
    ([LevelFactor("A", "a", (1, 2, 3))], "L12", "not one this builds"),
    ([], "L27", "at least one factor"),
])
def test_bad_orthogonal_factors(factors, array, match):
    with pytest.raises(InputError, match=match):
        orthogonal_design(factors, array, rng=0)


def test_level_factor_parse():
    assert LevelFactor.parse("D=omega_rad_s:42,52.5,63@9") == LevelFactor(
        "D", "omega_rad_s", (42.0, 52.5, 63.0), 9)
    assert LevelFactor.parse("rho0_mm:150,200,250", letter="A").column is None
    for bad, match in (("rho0_mm", "expected"), ("rho0_mm:a,b,c", "must be numbers"),
                       ("rho0_mm:1,2,3@x", "after '@'"), ("rho0_mm:1,1,3", "must differ")):
        with pytest.raises(InputError, match=match):
            LevelFactor.parse(bad, letter="A")
