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
   (1024 wide) footage (one run, timed ``FULL_SIZE_REPEATS`` times: the median). The
   CPU time of the command (its processes together) is reported beside its wall time.
   The target is at most 2x; fixed costs (Python start-up, imports, the report's plots)
   dominate on small footage, decoding on full-size footage.
"""

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from vidtrack._atomic import atomic_path

FPS_STEPS = ((1200, 1), (600, 2), (300, 4), (150, 8))
K_NAMES = ("k1", "k2", "k3", "k4")

#: Timings of the whole command on the full-size run (the median is reported).
FULL_SIZE_REPEATS = 7


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


def _time_command(run, size_name, seed):
    """``vidtrack fit RUN --force`` against plain decoding of the same videos."""
    from vidtrack.scene import load_scene

    scene = load_scene(run)
    paths = [scene.views[v].source for v in scene.view_names]
    decode_s, frames = _decode_only(paths)
    decode_par_s = _decode_at_once(paths)
    cpu0 = _children_cpu()
    t0 = time.perf_counter()
    res = subprocess.run([sys.executable, "-m", "vidtrack", "fit", str(run), "--force",
                          "--quiet"], capture_output=True, text=True)
    fit_s = time.perf_counter() - t0
    cpu_s = _children_cpu() - cpu0
    if res.returncode != 0:
        raise RuntimeError(f"vidtrack fit failed on a synthetic run: {res.stderr}")
    record = json.loads((run / "vidtrack" / "fit.json").read_text())
    total = record["timings_s"].get("total", np.nan)
    return {"footage": size_name, "seed": seed, "frames_decoded": frames,
            "decode_only_s": decode_s, "decode_at_once_s": decode_par_s,
            "vidtrack_fit_s": fit_s, "ratio": fit_s / decode_s,
            "vidtrack_fit_cpu_s": cpu_s, "cpu_ratio": cpu_s / decode_s,
            "ratio_to_decode_at_once": fit_s / decode_par_s,
            "in_process_total_s": total, "in_process_ratio": total / decode_s,
            "track_s": record["timings_s"].get("track"),
            "report_s": record["timings_s"].get("report")}


def _children_cpu():
    """CPU seconds (user + system) of the finished child processes and their own."""
    import resource

    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def _decode_only(paths):
    import cv2

    frames = 0
    t0 = time.perf_counter()
    for p in paths:
        cap = cv2.VideoCapture(str(p))
        while True:
            ok, _ = cap.read()
            if not ok:
                break
            frames += 1
        cap.release()
    return time.perf_counter() - t0, frames


def _decode_at_once(paths):
    """Wall time to decode the videos at the same time, one thread each (as the
    pipeline tracks two views): the fair floor on two cores."""
    import threading

    t0 = time.perf_counter()
    workers = [threading.Thread(target=_decode_only, args=([p],)) for p in paths]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    return time.perf_counter() - t0


def _rms(values):
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    return float(np.sqrt(np.mean(v**2))) if v.size else np.nan


def _subsample_rows(world, step):
    return world.iloc[::step].reset_index(drop=True)


def run_fit_bench(out_dir, *, quick=False, seeds=None):
    """Run both parts; write bench_fit.csv, bench_fit_command.csv and bench_fit.png.

    ``kN_coverage`` is the fraction of seeds whose 95 % interval covers the truth.
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
                t0 = time.perf_counter()
                fit = fit_throw(part, scene.cp_s_per_m, g=scene.physics.gravity_m_s2,
                                v1=scene.v1_m_s)
                elapsed = time.perf_counter() - t0
                row = {"seed": seed, "fps": fps, "points_y": fit.points["y"],
                       "fit_time_s": elapsed}
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
            command_rows.append(_time_command(run, SIZES[0][0], seed))
        # full-size footage: one run timed several times (decoding and the command in
        # turn), the median taken, as one timing on a shared machine is noisy
        big = _render(Path(tmp) / "big", 1, SIZES[1])
        for _ in range(2 if quick else FULL_SIZE_REPEATS):
            command_rows.append(_time_command(big, SIZES[1][0], 1))
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
              "decoding of the same videos\n"
            + command.to_string(index=False, float_format=lambda v: f"{v:.3g}")
            + "\n" + "\n".join(
                f"median ratio, {name} ({len(grp)} timings): {grp.ratio.median():.2f}x "
                f"(command, with Python start-up; range {grp.ratio.min():.2f}-"
                f"{grp.ratio.max():.2f}), {grp.in_process_ratio.median():.2f}x (in process); "
                f"{grp.ratio_to_decode_at_once.median():.2f}x decoding the views at once; "
                f"CPU {grp.cpu_ratio.median():.2f}x decoding's time"
                for name, grp in command.groupby("footage", sort=False)))
    from vidtrack._atomic import write_text

    write_text(out_dir / "bench_fit.txt", text + "\n")
    return text


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
