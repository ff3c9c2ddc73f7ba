"""``vidtrack bench fit``: k error against frames used and run time; the whole fit against
plain decoding.

1. Frame rate: one synthetic two-view run (``vidtrack synth``, known k) is tracked once;
   its world track is then subsampled to 1200, 600, 300 and 150 frames/s (every 1st,
   2nd, 4th, 8th frame) and fitted, several seeds of synthetic runs each, so the table
   shows how the error in k1..k4 grows as frames are dropped, beside the fit time.
2. Whole command: ``vidtrack fit RUN --force`` (frames, tracking, merge, fit, tracks.h5,
   fit.json, report.md and report.html) timed against decoding the same videos with
   plain OpenCV (``cv2.VideoCapture.read`` to the end, nothing else; one video after the
   other, and both at once in two threads, as the command tracks the two views at once),
   in the same run, on footage of the sample run's size (once per seed) and on full-size
   (1024 wide) footage (one run). The target is at most 2x; fixed costs (Python
   start-up, imports, the report's plots) dominate on small footage, decoding on
   full-size footage.

Timing (:mod:`vidtrack.bench._timing`): the fit of part 1 is called once uncounted, then
``repeats`` counted times; in part 2 decoding, decoding at once and the command are
called in turn, round by round, one warm-up round uncounted (``warmup``) and then
``repeats`` counted rounds. CPU time counts the process's threads and its child
processes (the command's processes together). ``bench_fit_command.csv``: the medians of
the counted calls (``decode_only_s``, ``decode_at_once_s``, ``vidtrack_fit_s`` and
``vidtrack_fit_cpu_s``; ``ratio`` = vidtrack_fit_s / decode_only_s, ``cpu_ratio`` =
vidtrack_fit_cpu_s / decode_only_s, ``ratio_to_decode_at_once``), the minima (columns
ending ``_min_s``), ``decode_only_cpu_s`` (median) and ``cpu_vs_decode_cpu`` (the
command's CPU over decoding's, minima), ``calls``.
"""

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from vidtrack._atomic import atomic_path
from vidtrack.bench._timing import timed, timed_each

FPS_STEPS = ((1200, 1), (600, 2), (300, 4), (150, 8))
K_NAMES = ("k1", "k2", "k3", "k4")

#: (name, front size, top size): the sample run's size, and full-size high-speed frames
SIZES = (("run42 size", (400, 184), (400, 112)), ("1024 wide", (1024, 768), (1024, 480)))


def _render(out, seed, size=SIZES[0]):
    from vidtrack.synth import SynthSpec, render_run

    # the sample run's settings (datasets/README.md), one seed each
    spec = SynthSpec(size_px=size[1], top_size_px=size[2], flight_s=0.3,
                     straw_length_m=0.25, straw_diameter_m=0.025, jpeg_quality=40,
                     read_noise_dn=1.0, seed=seed)
    render_run(out, spec, force=True)
    return out


def _command(run):
    """``vidtrack fit RUN --force --quiet`` in a child process."""
    res = subprocess.run([sys.executable, "-m", "vidtrack", "fit", str(run), "--force",
                          "--quiet"], capture_output=True, text=True)
    if res.returncode != 0:
        raise RuntimeError(f"vidtrack fit failed on a synthetic run: {res.stderr}")


def _time_command(run, size_name, seed, *, repeats=3, warmup=1):
    """``vidtrack fit RUN --force`` against plain decoding of the same videos, in turn."""
    from vidtrack.scene import load_scene

    scene = load_scene(run)
    paths = [scene.views[v].source for v in scene.view_names]
    t = timed_each({"decode": lambda: _decode_only(paths),
                    "at once": lambda: _decode_at_once(paths),
                    "command": lambda: _command(run)}, repeats=repeats, warmup=warmup)
    dec, par, cmd = t["decode"], t["at once"], t["command"]
    record = json.loads((run / "vidtrack" / "fit.json").read_text())
    total = record["timings_s"].get("total", np.nan)
    decode_s, fit_s = dec.wall_median_s, cmd.wall_median_s
    return {"footage": size_name, "seed": seed, "frames_decoded": dec.result,
            "decode_only_s": decode_s, "decode_at_once_s": par.wall_median_s,
            "vidtrack_fit_s": fit_s, "ratio": fit_s / decode_s,
            "vidtrack_fit_cpu_s": cmd.cpu_median_s, "cpu_ratio": cmd.cpu_median_s / decode_s,
            "ratio_to_decode_at_once": fit_s / par.wall_median_s,
            "in_process_total_s": total, "in_process_ratio": total / decode_s,
            "track_s": record["timings_s"].get("track"),
            "report_s": record["timings_s"].get("report"),
            "decode_only_min_s": dec.wall_min_s, "decode_at_once_min_s": par.wall_min_s,
            "vidtrack_fit_min_s": cmd.wall_min_s, "vidtrack_fit_cpu_min_s": cmd.cpu_min_s,
            "decode_only_cpu_s": dec.cpu_median_s, "decode_only_cpu_min_s": dec.cpu_min_s,
            "cpu_vs_decode_cpu": cmd.cpu_min_s / dec.cpu_min_s, "calls": cmd.calls}


def _decode_only(paths):
    """Frames read from the videos with plain OpenCV, one after the other."""
    import cv2

    frames = 0
    for p in paths:
        cap = cv2.VideoCapture(str(p))
        while True:
            ok, _ = cap.read()
            if not ok:
                break
            frames += 1
        cap.release()
    return frames


def _decode_at_once(paths):
    """The videos decoded at the same time, one thread each (as the pipeline tracks two
    views): the fair floor on two cores."""
    import threading

    workers = [threading.Thread(target=_decode_only, args=([p],)) for p in paths]
    for w in workers:
        w.start()
    for w in workers:
        w.join()


def _rms(values):
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    return float(np.sqrt(np.mean(v**2))) if v.size else np.nan


def _subsample_rows(world, step):
    return world.iloc[::step].reset_index(drop=True)


def run_fit_bench(out_dir, *, quick=False, seeds=None, repeats=3, warmup=1):
    """Run both parts; write bench_fit.csv, bench_fit_command.csv and bench_fit.png.

    ``kN_coverage`` is the fraction of seeds whose 95 % interval covers the truth;
    ``repeats`` and ``warmup``: the counted and uncounted calls of each timing.
    """
    from fits.lsq import fit_throw
    from vidtrack.run.pipeline import FitOptions, fit_run
    from vidtrack.scene import load_scene
    from vidtrack.run.tracks_file import read_tracks

    out_dir = Path(out_dir)
    seeds = seeds or ((1, 2) if quick else tuple(range(1, 11)))
    from vidtrack.errors import INPUT_ERRORS

    rows, command_rows, failures = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in seeds:
            run = _render(Path(tmp) / f"run{seed}", seed)
            truth = json.loads((run / "truth.json").read_text())["truth"]["k"]
            try:
                fit_run(run, FitOptions(force=True, report=False))
            except INPUT_ERRORS as exc:          # a failure is a result: count and name it
                failures.append(f"seed {seed}: {type(exc).__name__}: {exc}")
                continue
            scene = load_scene(run)
            world = read_tracks(run / "vidtrack" / "tracks.h5").world.data
            for fps, step in FPS_STEPS:
                part = _subsample_rows(world, step)
                t = timed(lambda part=part: fit_throw(part, scene.cp_s_per_m,
                                                      g=scene.physics.gravity_m_s2,
                                                      v1=scene.v1_m_s),
                          repeats=repeats, warmup=warmup)
                fit = t.result
                row = {"seed": seed, "fps": fps, "points_y": fit.points["y"],
                       "fit_time_s": t.wall_median_s, **t.columns("fit_")}
                for k in K_NAMES:
                    c = fit.coefficients[k]
                    row[f"{k}_error_pct"] = (100 * (c.value - truth[k]) / truth[k]
                                             if c.determined else np.nan)
                    row[f"{k}_stderr_pct"] = (100 * c.stderr / truth[k]
                                              if c.determined else np.nan)
                    row[f"{k}_covered"] = (float(c.ci95[0] <= truth[k] <= c.ci95[1])
                                           if c.determined else np.nan)
                rows.append(row)
            # the whole command against plain decoding, in one run
            command_rows.append(_time_command(run, SIZES[0][0], seed, repeats=repeats,
                                              warmup=warmup))
        big = _render(Path(tmp) / "big", 1, SIZES[1])
        command_rows.append(_time_command(big, SIZES[1][0], 1, repeats=repeats,
                                          warmup=warmup))
    table = pd.DataFrame(rows)
    command = pd.DataFrame(command_rows)
    summary = (table.groupby("fps", sort=False)
               .agg(**{f"{k}_rms_error_pct": (f"{k}_error_pct", _rms) for k in K_NAMES},
                    **{f"{k}_stderr_pct": (f"{k}_stderr_pct", "median") for k in K_NAMES},
                    **{f"{k}_coverage": (f"{k}_covered", "mean") for k in K_NAMES},
                    fit_time_s=("fit_time_s", "median"), points_y=("points_y", "median"))
               .reset_index())
    with atomic_path(out_dir / "bench_fit.csv") as t:
        table.to_csv(t, index=False)
    with atomic_path(out_dir / "bench_fit_command.csv") as t:
        command.to_csv(t, index=False)
    with atomic_path(out_dir / "bench_fit.png") as t:
        _plot(summary, t)
    text = (f"{len(seeds) - len(failures)} of {len(seeds)} seeded runs fitted"
            + "".join(f"\n  failed: {f}" for f in failures)
            + "\n\nk error against frame rate (RMS over seeds, % of truth) and fit time\n"
            + summary.to_string(index=False, float_format=lambda v: f"{v:.3g}")
            + "\n\nvidtrack fit (whole command, report included) against plain OpenCV "
              "decoding of the same videos, in turn, round by round\n"
              f"({_calls(command)} warm calls each; times in s; wall: median, min; CPU: the "
              "processes together, median, min)\n"
            + command[COMMAND_SHOWN].to_string(index=False,
                                               float_format=lambda v: f"{v:.3g}")
            + "\n" + "\n".join(
                f"{name} ({len(grp)} run(s)): {grp.ratio.median():.2f}x decoding's wall time "
                f"(command, with Python start-up; range {grp.ratio.min():.2f}-"
                f"{grp.ratio.max():.2f}), {grp.in_process_ratio.median():.2f}x (in process); "
                f"{grp.ratio_to_decode_at_once.median():.2f}x decoding the views at once; "
                f"CPU {grp.cpu_vs_decode_cpu.median():.2f}x decoding's CPU"
                for name, grp in command.groupby("footage", sort=False)))
    from vidtrack._atomic import write_text

    write_text(out_dir / "bench_fit.txt", text + "\n")
    return text


#: The columns of the command's table printed (the CSV has them all).
COMMAND_SHOWN = ["footage", "seed", "frames_decoded", "decode_only_s", "decode_only_min_s",
                 "decode_at_once_s", "vidtrack_fit_s", "vidtrack_fit_min_s", "ratio",
                 "decode_only_cpu_min_s", "vidtrack_fit_cpu_s", "vidtrack_fit_cpu_min_s",
                 "cpu_vs_decode_cpu", "in_process_ratio"]


def _calls(command):
    return int(command["calls"].max()) if len(command) else 0


def _plot(summary, path):
    from vidtrack.report._html import figure

    fig = figure(10, 4)
    a, b = fig.subplots(1, 2)
    for k in K_NAMES:
        a.semilogy(summary.fps, summary[f"{k}_rms_error_pct"], "o-", label=k)
        b.loglog(summary.fit_time_s, summary[f"{k}_rms_error_pct"], "o-", label=k)
    a.set_xlabel("frames per second used")
    a.set_ylabel("RMS error of k (% of truth)")
    b.set_xlabel("fit time (s)")
    b.set_ylabel("RMS error of k (% of truth)")
    for ax in (a, b):
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Fit: error against frames used and run time")
    fig.tight_layout()
    fig.savefig(path, format="png", dpi=100)
