"""``vidtrack bench model``: the real CLI writes a table, CSV and plot whose numbers hold."""

import numpy as np
import pandas as pd

from vidtrack.bench.model import CASES, ODE_METHODS


def test_bench_model_quick_run(vidtrack_cli, tmp_path):
    out = vidtrack_cli("bench", "model", "--quick", "--out", tmp_path / "b", "--repeats", "1",
                       "--warmup", "0")
    assert out.returncode == 0, out.stderr
    table = pd.read_csv(tmp_path / "b" / "bench_model.csv")
    assert set(table.case) == {c.name for c in CASES}
    methods = set(table.method)
    assert {"closed form (vidtrack)", "printed eqs. 12-18"} <= methods
    assert {f"solve_ivp {m}" for m in ODE_METHODS} <= methods
    closed = table[table.method == "closed form (vidtrack)"].set_index("case")
    # the closed form is exact to rounding in every case (against 50-digit truth)
    scale = {"typical": 2.0, "stiff": 2.0, "extreme": 2e5}
    for case, row in closed.iterrows():
        assert row.max_error_m < 1e-14 * scale[case]
    printed = table[table.method == "printed eqs. 12-18"].set_index("case")
    assert printed.loc["extreme", "max_error_m"] > 1e-3     # cancellation at Cp = 1e-9
    png = (tmp_path / "b" / "bench_model.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert "closed form (vidtrack)" in out.stdout
    assert np.all(table.median_time_s > 0)
    assert np.all(table.calls >= 1) and np.all(table.cpu_min_s >= 0)
