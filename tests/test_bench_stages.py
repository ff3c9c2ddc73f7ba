"""``vidtrack bench stages`` as a user runs it: the real command line on the sample run.

No timing is checked (speed is measured by the benchmark, not asserted): the table has
its rows, and the fit the stages timed is the sample run's, within the tolerances of its
known truth, with each k inside its own 95 % interval.
"""

import json
from pathlib import Path

import pandas as pd
import pytest

from conftest import K_TOLERANCES

ROOT = Path(__file__).resolve().parents[1]
RUN42 = ROOT / "datasets" / "run42"


def _listing(folder):
    return sorted((str(p.relative_to(folder)), p.stat().st_mtime_ns) for p in folder.rglob("*"))


def test_stages_of_the_sample_run_beside_a_baseline(vidtrack_cli, tmp_path):
    out = tmp_path / "bench"
    before = _listing(RUN42)
    # this checkout as its own baseline: the comparison's plumbing, both codes timed
    res = vidtrack_cli("bench", "stages", "--repeats", "1", "--warmup", "0", "--out", out,
                       "--baseline", ROOT)
    assert res.returncode == 0, res.stderr
    table = pd.read_csv(out / "bench_stages.csv")
    assert sorted(zip(table.code, table.stage)) == [("baseline", "fit"), ("baseline", "report"),
                                                    ("this", "fit"), ("this", "report")]
    assert (table.cold_calls == 1).all() and (table.warm_calls == 1).all()
    assert (table.cold_cpu_min_s > 0).all() and (table.warm_cpu_min_s > 0).all()
    truth = json.loads((RUN42 / "truth.json").read_text())["truth"]["k"]
    text = (out / "bench_stages.txt").read_text()
    for k, tol in K_TOLERANCES:
        line = next(ln for ln in text.splitlines() if ln.strip().startswith(f"this {k}:"))
        value = float(line.split(":", 1)[1].split("±")[0])
        low, high = (float(v) for v in line.rsplit("[", 1)[1].rstrip("]").split(","))
        assert value == pytest.approx(truth[k], rel=tol), k
        assert low < value < high
    assert "this against baseline: 0" in text
    assert _listing(RUN42) == before                  # the run is copied, never written


def test_stages_options_go_with_stages_only(vidtrack_cli, tmp_path):
    res = vidtrack_cli("bench", "model", "--baseline", tmp_path, "--out", tmp_path)
    assert res.returncode == 2 and "--run and --baseline go with" in res.stderr
    res = vidtrack_cli("bench", "stages", "--baseline", tmp_path, "--out", tmp_path)
    assert res.returncode == 2 and "no vidtrack/__init__.py there" in res.stderr
    res = vidtrack_cli("bench", "stages", "--run", tmp_path, "--out", tmp_path)
    assert res.returncode == 2 and "expected a run folder of one throw" in res.stderr
