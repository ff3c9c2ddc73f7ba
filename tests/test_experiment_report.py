"""The experiment's report (``vidtrack report``): the table of runs (Chen 2018 Table 2 with
links to each run's report and the frames flagged), numbers as the paper prints them,
coded levels as the design gives them, and effects plots whose titles fit.

The records are fit.json records written here by hand (a two-factor central composite
design whose k1 follows a known quadratic): the analysis under test did not make them.
"""

import re

import numpy as np
import pandas as pd
import pytest

from vidtrack.experiment import analyse, coefficient_table, run_table, write_outputs
from vidtrack.scene import load_experiment

# coded design: 4 factorial, 4 axial at +-1.5, 3 centre points
DESIGN = [(-1, -1), (1, -1), (-1, 1), (1, 1), (-1.5, 0), (1.5, 0), (0, -1.5), (0, 1.5),
          (0, 0), (0, 0), (0, 0)]


def make_experiment(root, factors=2):
    toml = ('schema = 1\ndesign = "ccd"\nresponses = ["k1", "k4"]\nruns = "runs/*"\n'
            '[factors.A]\nname = "speed_kmh"\ncentre = 7.2\nstep = 1.8\n')
    if factors >= 2:
        toml += '[factors.B]\nname = "blade_angle_deg"\ncentre = 0\nstep = 5\n'
    root.mkdir(parents=True, exist_ok=True)
    (root / "experiment.toml").write_text(toml)
    return load_experiment(root)


def record(i, a, b, rng):
    # speed 7.2 + 1.8 a: (5.4 - 7.2) / 1.8 is -0.9999999999999999 in floating point
    k1 = 2.2 + 0.5 * a - 0.2 * b - 0.2 * a * b + 0.15 * a * a + rng.normal(0, 0.02)
    k4 = 21.3 - 2.0 * a + rng.normal(0, 0.2)
    coef = {k: {"value": float(v), "stderr": 0.0123456, "ci95": None, "determined": True}
            for k, v in (("k1", k1), ("k4", k4))}
    return {"run": f"{i:02d}", "factors": {"speed_kmh": 7.2 + 1.8 * a,
                                           "blade_angle_deg": 5.0 * b},
            "coefficients": coef, "throws": 1,
            "views": {"front": {"frames": 372, "usable": 328 - i},
                      "top": {"frames": 372, "usable": 330}}}


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    root = tmp_path_factory.mktemp("exp") / "exp"
    exp = make_experiment(root)
    rng = np.random.default_rng(3)
    records = [record(i, a, b, rng) for i, (a, b) in enumerate(DESIGN, start=1)]
    run_dirs = [root / "runs" / r["run"] for r in records]
    for folder in run_dirs[:-1]:                 # the last run has no report of its own
        (folder / "vidtrack").mkdir(parents=True)
        (folder / "vidtrack" / "report.html").write_text("<html></html>")
    table = coefficient_table(exp, records)
    fits = analyse(exp, table)
    out = root / "vidtrack"
    out.mkdir()
    write_outputs(out, exp, table, fits, runs=run_table(exp, table, records, run_dirs, out))
    return root, records, fits


def test_coded_levels_are_the_designs(report):
    root, _, _ = report
    text = (root / "vidtrack" / "coefficients.csv").read_text()
    assert "0.9999999" not in text and "0000000" not in text
    table = pd.read_csv(root / "vidtrack" / "coefficients.csv")
    assert [tuple(r) for r in table[["A", "B"]].itertuples(index=False)] == DESIGN
    assert not np.signbit(table.loc[table.A == 0, "A"]).any()           # no -0.0
    # full precision stays in the CSV
    assert table.k1_stderr.iloc[0] == 0.0123456


def _runs_table(html):
    body = html[html.index("<h2>Runs</h2>"):]
    return body[:body.index("</table>")]


def test_runs_table_links_each_run_and_counts_flags(report):
    root, records, _ = report
    html = (root / "vidtrack" / "report.html").read_text()
    runs = _runs_table(html)
    heads = re.findall(r"<th[^>]*>([^<]*)</th>", runs)
    assert heads == ["Run", "A", "B", "speed_kmh", "blade_angle_deg", "k1", "k4", "Throws",
                     "Flagged / tracked frames"]
    rows = re.findall(r"<tr>(.*?)</tr>", runs)[1:]
    assert len(rows) == len(DESIGN)
    for rec, row in zip(records, rows):
        cells = re.findall(r"<td[^>]*>(.*?)</td>", row)
        name = rec["run"]
        if name != "11":
            href = f"../runs/{name}/vidtrack/report.html"
            assert cells[0] == f'<a href="{href}">{name}</a>'
            assert (root / "vidtrack" / href).resolve().is_file()          # it resolves
        else:
            assert cells[0] == name                                   # no report: no link
        i = int(name)
        assert cells[-1] == f"front {372 - 328 + i}/372, top 42/372"
        # three significant figures, as Chen 2018 prints its tables
        k1 = rec["coefficients"]["k1"]["value"]
        assert cells[5] == f"{k1:.3g}"
        assert cells[3] == f"{rec['factors']['speed_kmh']:.3g}"


def test_numbers_printed_to_three_figures(report):
    root, _, fits = report
    html = (root / "vidtrack" / "report.html").read_text()
    tables = re.sub(r"<img[^>]*>", "", html[html.index("<h2>k1"):])
    cells = re.findall(r"<td>(-?[0-9][0-9.e+-]*)</td>", tables)
    assert len(cells) > 30
    natural = {f"{v:.4g}" for f in fits for v in f.coefficients_natural.values()}
    f_ratios = {f"{r.f:.2f}" for f in fits for r in [*f.anova.values(), *f.term_tests]
                if r.f is not None}
    p_values = {f"{r.p:.4f}" for f in fits for r in [*f.anova.values(), *f.term_tests]
                if r.p is not None}
    for c in cells:
        if c in natural or c in f_ratios or c in p_values:
            continue       # eqs. 20-23 print four figures, F two decimals, p four
        mantissa = c.split("e")[0].lstrip("-").replace(".", "").lstrip("0")
        assert len(mantissa) <= 3 or "." not in c, c
    # the F ratio with two decimals, the p-value with four
    reg = fits[0].anova["regression"]
    assert f"<td>{reg.f:.2f}</td>" in tables


@pytest.mark.parametrize("factors", [1, 2, 3])
def test_effects_title_inside_the_figure(tmp_path, factors):
    from vidtrack.report.anova_page import _rsm_main_effects_figure

    from fits.rsm import Factor, fit_rsm

    rng = np.random.default_rng(1)
    names = ["n_rpm", "blade_angle_deg", "speed_kmh"][:factors]
    letters = "ABC"[:factors]
    levels = [-1.5, -1, 0, 0, 1, 1.5]
    grid = np.array(np.meshgrid(*[levels] * factors)).reshape(factors, -1).T
    data = pd.DataFrame(grid, columns=list(letters))
    data["k1"] = 2 + grid @ np.arange(1, factors + 1) * 0.3 + rng.normal(0, 0.05, len(grid))
    fit = fit_rsm(data, "k1", [Factor(x, n, 0.0, 1.0) for x, n in zip(letters, names)])
    fig = _rsm_main_effects_figure(fit)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    box = fig._suptitle.get_window_extent(renderer)       # matplotlib keeps it there
    width, height = fig.bbox.width, fig.bbox.height
    assert 0 <= box.x0 and box.x1 <= width and 0 <= box.y0 and box.y1 <= height, (
        factors, box, (width, height))
    for ax in fig.axes:                      # and the panels stay below the title
        assert ax.get_window_extent(renderer).y1 <= box.y0 + 1
