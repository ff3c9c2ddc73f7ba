"""``vidtrack bench model``: the throw model's error against run time.

Three cases (typical: k like Chen 2018's, Cp = 0.115 s/m; stiff: k4 = 2000, Cp = 0.5 s/m;
extreme: Cp = 1e-9 s/m and a 100 s descent), each evaluated by

- the closed form of ``fits.throw`` (what vidtrack uses),
- Chen 2018 eqs. 12-18 evaluated as printed (``fits.throw.printed``),
- ``scipy.integrate.solve_ivp`` with RK45, DOP853, Radau, BDF and LSODA at rtol
  1e-3, 1e-6, 1e-9 and 1e-12 (atol = 1e-3 rtol, in metres; exact Jacobian for the
  implicit methods),

against truth from ``fits.throw.mp`` (the textbook solution at 50 significant digits).
One evaluation is the whole trajectory at the case's time points. ``max_rel_error`` is
the max error over the largest coordinate of the trajectory (the extreme case falls
about 1.2e5 m, where float64 rounding alone is 1e-11 m).

Timing (:func:`vidtrack.bench._timing.timed`): each method is called once uncounted, then
``repeats`` counted times and more while its counted calls take less than the time
budget (at most 25 calls; 5 for solve_ivp). ``median_time_s`` is the median wall time
of the counted calls, ``time_vs_closed_form`` its ratio to the closed form's;
``cpu_min_s``, ``cpu_median_s``, ``wall_min_s``, ``wall_median_s`` and ``calls`` the
rest, ``cpu_vs_closed_form`` the ratio of the CPU minima.
"""

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from fits.throw import position
from fits.throw.mp import position_mp
from fits.throw.ode import solve_throw
from fits.throw.printed import printed_position
from vidtrack.bench._timing import timed

ODE_METHODS = ("RK45", "DOP853", "Radau", "BDF", "LSODA")
RTOLS = (1e-3, 1e-6, 1e-9, 1e-12)
#: Most counted calls of a closed form and of a solve_ivp run.
MAX_CALLS, MAX_CALLS_ODE = 25, 5
TIMING_NOTE = ("(warm calls, a time budget each; wall s: median; CPU s: min and median; "
               "x closed form: median wall, and min CPU)")

@dataclass(frozen=True)
class ModelCase:
    """A throw to benchmark: initial state, k1..k4, Cp, machine speed, time points."""

    name: str
    state: tuple
    k: tuple
    cp_s_per_m: float
    v1_m_s: float
    t_end_s: float
    points: int
    note: str

    @property
    def t_s(self):
        return np.linspace(0.0, self.t_end_s, self.points)


CASES = (
    ModelCase("typical", (0.25, 0.15, 0.0, 7.0, 4.5, 2.0), (2.2, 2.5, 4.6, 21.3), 0.115, 2.0,
              0.5, 601, "k like Chen 2018, Cp = 0.115 s/m, 0.5 s at 1200 fps"),
    ModelCase("stiff", (0.25, 0.15, 0.0, 7.0, 4.5, 2.0), (2.2, 2.5, 4.6, 2000.0), 0.5, 2.0,
              0.5, 601, "k4 = 2000, Cp = 0.5 s/m"),
    ModelCase("extreme", (0.25, 0.15, 0.0, 7.0, 4.5, 2.0), (2.2, 2.5, 4.6, 21.3), 1e-9, 2.0,
              100.0, 1001, "Cp = 1e-9 s/m, a 100 s descent"),
)


def _row(case, method, rtol, timing, truth):
    xyz = timing.result
    err = np.abs(xyz - truth)
    max_err = float(np.max(err)) if np.all(np.isfinite(xyz)) else math.inf
    return {"case": case.name, "method": method, "rtol": rtol, "max_error_m": max_err,
            "max_rel_error": max_err / float(np.max(np.abs(truth))),
            "median_time_s": timing.wall_median_s, "points": case.points,
            **timing.columns()}


def run_case(case, *, methods=ODE_METHODS, rtols=RTOLS, budget_s=0.3, repeats=3, warmup=1):
    """Benchmark one case; returns a DataFrame (one row per method and tolerance)."""
    t = case.t_s
    truth = position_mp(t, case.state, case.k, case.cp_s_per_m, v1=case.v1_m_s)
    rows = []

    def timing(fn, max_repeats=MAX_CALLS):
        return timed(fn, repeats=repeats, warmup=warmup, budget_s=budget_s,
                     max_repeats=max_repeats)
    rows.append(_row(case, "closed form (vidtrack)", np.nan,
                     timing(lambda: position(t, case.state, case.k, case.cp_s_per_m,
                                             v1=case.v1_m_s)), truth))
    # the printed form subtracts vz0 t for z (the paper's vz0 = v1): our cases have vz0 = v1
    with np.errstate(all="ignore"):
        rows.append(_row(case, "printed eqs. 12-18", np.nan,
                         timing(lambda: printed_position(t, case.state, case.k,
                                                         case.cp_s_per_m)), truth))
    for method in methods:
        for rtol in rtols:
            def solve(method=method, rtol=rtol):
                return solve_throw(t, case.state, case.k, case.cp_s_per_m, v1=case.v1_m_s,
                                   method=method, rtol=rtol, atol=rtol * 1e-3)
            rows.append(_row(case, f"solve_ivp {method}", rtol,
                             timing(solve, MAX_CALLS_ODE), truth))
    return pd.DataFrame(rows)


def run_model_bench(*, cases=CASES, quick=False, progress=None, repeats=3, warmup=1):
    """Every case; ``quick`` keeps only rtol 1e-3 and 1e-9 and a smaller time budget
    (for tests and smoke runs). ``repeats`` and ``warmup``: :func:`run_case`'s."""
    rtols = (1e-3, 1e-9) if quick else RTOLS
    frames = []
    for case in cases:
        frames.append(run_case(case, rtols=rtols, budget_s=0.05 if quick else 0.3,
                               repeats=repeats, warmup=warmup))
        if progress is not None:
            progress(case.name)
    table = pd.concat(frames, ignore_index=True)
    closed = table[table.method == "closed form (vidtrack)"].set_index("case")
    table["time_vs_closed_form"] = (table["median_time_s"]
                                    / table["case"].map(closed["median_time_s"]))
    table["cpu_vs_closed_form"] = table["cpu_min_s"] / table["case"].map(closed["cpu_min_s"])
    return table


def plot_work_precision(table, path):
    """Work-precision plot (error against time per evaluation), one panel per case."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = list(dict.fromkeys(table["case"]))
    fig, axes = plt.subplots(1, len(cases), figsize=(5.2 * len(cases), 4.6), squeeze=False)
    for ax, name in zip(axes[0], cases):
        part = table[table.case == name]
        finite = part.max_error_m[np.isfinite(part.max_error_m)]
        ceiling = max(finite.max() * 30, 1.0) if len(finite) else 1.0
        floor = 1e-17
        for method, grp in part.groupby("method", sort=False):
            err = grp.max_error_m.to_numpy()
            shown = np.where(np.isfinite(err), np.maximum(err, floor), ceiling)
            style = {"marker": "*", "markersize": 14, "linestyle": "none"} \
                if not method.startswith("solve_ivp") else {"marker": "o"}
            ax.loglog(grp.median_time_s, shown, label=method, **style)
            if not np.all(np.isfinite(err)):
                ax.annotate("inf/nan", (grp.median_time_s.iloc[0], ceiling), fontsize=8)
        ax.set_title(name)
        ax.set_xlabel("median time per trajectory evaluation (s)")
        ax.set_ylabel("max error against 50-digit truth (m)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][-1].legend(fontsize=7, loc="upper right")
    fig.suptitle("Throw model: error against run time (lower left is better)")
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def format_table(table):
    """The benchmark as aligned text (errors and times with 2 significant digits)."""
    shown = table.copy()
    shown["rtol"] = shown["rtol"].map(lambda v: "" if np.isnan(v) else f"{v:.0e}")
    shown["max_error_m"] = shown["max_error_m"].map(lambda v: f"{v:.2g}")
    shown["max_rel_error"] = shown["max_rel_error"].map(lambda v: f"{v:.2g}")
    shown["median_time_s"] = shown["median_time_s"].map(lambda v: f"{v:.2g}")
    shown["time_vs_closed_form"] = shown["time_vs_closed_form"].map(lambda v: f"{v:.3g}x")
    for col in ("cpu_min_s", "cpu_median_s"):
        shown[col] = shown[col].map(lambda v: f"{v:.2g}")
    shown["cpu_vs_closed_form"] = shown["cpu_vs_closed_form"].map(lambda v: f"{v:.3g}x")
    return shown[["case", "method", "rtol", "max_error_m", "max_rel_error",
                  "median_time_s", "time_vs_closed_form", "cpu_min_s", "cpu_median_s",
                  "cpu_vs_closed_form", "calls"]].to_string(index=False)
