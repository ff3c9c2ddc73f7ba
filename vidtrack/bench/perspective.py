"""``vidtrack bench perspective``: k error and run time of perspective cameras, read as
calibrated cameras or with the orthographic approximation.

Synthetic runs (``vidtrack synth``, known k; noise and MJPG compression on, as by
default) filmed by pinhole cameras, several seeds each:

- **cameras at an angle** (``--cameras perspective``): 60, 90 and 120 degrees apart,
  1, 2 and 3 m from the middle of the flight, cam1 with a lens (``LENS``), cam2 a DLT
  counted from the bottom-left: read as calibrated cameras (the scene synth writes);
- **the square rig** (``--cameras square``, the front and top cameras square to the
  axes) 1.5 m and 3 m from the planes Z = 0 and Y = 0, the same footage read three ways:
  ``orthographic`` (a scale at the plane, no ``camera_distance_m``: perspective not
  corrected), ``orthographic + camera_distance`` (the scene synth writes) and
  ``calibrated`` (the cameras' projection matrices from truth.json in a ``[world]``
  scene). The orthographic readings are fitted with ``accept_disagreement`` (the
  uncorrected one fails the cross-checks, as it should: the table shows what it would
  give).

Every reading is a whole ``vidtrack fit`` of the run in process (tracking, merge or
triangulation, fit; no report), timed beside decoding the run's videos (iterating their
frames, as the tracker reads them), in turn, round by round: one warm-up round uncounted,
then ``repeats`` counted rounds (:mod:`vidtrack.bench._timing`; CPU time counts the
process's threads and its child processes, which track the second view). Columns of
``bench_perspective.csv`` on time: ``fit_s`` (wall, median), ``fit_cpu_min_s``,
``fit_cpu_median_s``, ``fit_wall_min_s``, ``fit_wall_median_s``, ``fit_calls``,
``decode_cpu_s`` (min) and ``x_decode`` (decode_cpu_s / fit_cpu_min_s).

The straw is 0.12 m x 0.02 m: a longer straw slanted in depth shows its silhouette's
centroid off its projected centre (up to f L^2 / (8 depth^2) px), which the calibrated
reading corrects for (``vidtrack.world.rod_centroid``; docs/synth.md).
Benchmarks are not tests: nothing here asserts a time.
"""

import json
import tempfile
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd

from vidtrack._atomic import atomic_path, write_text
from vidtrack.bench._timing import timed, timed_each

K_NAMES = ("k1", "k2", "k3", "k4")
LENS = (-0.12, 0.03, 0.0005, -0.0003, 0.0)
#: (rig, cameras, angle between the cameras in degrees, distance in m)
RIGS = (("60 deg, 1.0 m", "perspective", 60.0, 1.0),
        ("90 deg, 2.0 m", "perspective", 90.0, 2.0),
        ("120 deg, 3.0 m", "perspective", 120.0, 3.0),
        ("square, 1.5 m", "square", 90.0, 1.5),
        ("square, 3.0 m", "square", 90.0, 3.0))
#: "calibrated, rod as drawn": the rod correction with the silhouette of one width, as
#: synth draws the straw (the pipeline's default, "perspective", is a real rod's: its
#: near end imaged wider, a third more correction than synth's footage needs).
ROD_AS_DRAWN = "calibrated, rod as drawn"
READINGS = {"perspective": ("calibrated", ROD_AS_DRAWN),
            "square": ("orthographic", "orthographic + camera_distance", "calibrated")}
#: Frame sizes: perspective views frame the flight with the rotor in a 4:3 image; the
#: square rig's as the sample run's (datasets/run42).
SIZES = {"perspective": ((400, 300), None), "square": ((400, 184), (400, 112))}


def _spec(cameras, angle, distance, seed):
    from vidtrack.synth import SynthSpec

    size, top = SIZES[cameras]
    extra = {"distortion": LENS} if cameras == "perspective" else {}
    return SynthSpec(cameras=cameras, camera_angle_deg=angle, camera_distance_m=distance,
                     size_px=size, top_size_px=top, flight_s=0.3, straw_length_m=0.12,
                     straw_diameter_m=0.02, seed=seed, **extra)


def _scene_data(run):
    return tomllib.loads((run / "scene.toml").read_text(encoding="utf-8"))


def _absolute_sources(data, run):
    for view in data["views"].values():
        view["source"] = str((run / view["source"]).resolve())
    return data


def _reading_scene(run, reading, truth):
    """The scene of one reading of a square rig's footage (sources by absolute path)."""
    data = _absolute_sources(_scene_data(run), run)
    if reading == "orthographic":
        for view in data["views"].values():
            view.pop("camera_distance_m", None)
    elif reading == "calibrated":
        data["world"] = {"up": [0.0, 1.0, 0.0], "forward": [1.0, 0.0, 0.0]}
        for name, view in data["views"].items():
            cam = truth["views"][name]["camera"]
            keep = {k: view[k] for k in ("source", "fps", "sync_frame") if k in view}
            data["views"][name] = {**keep, "projection": cam["P"]}
    return data


def _fit(folder, rod="default", *, repeats=1, warmup=0):
    """A whole fit of a run folder in process, timed (:func:`_fit_once`): ``(record,
    Timing)``."""
    t = timed(lambda: _fit_once(folder, rod), repeats=repeats, warmup=warmup)
    return t.result, t


def _fit_once(folder, rod="default"):
    """One whole fit of a run folder in process: its record. The warnings of accepted
    disagreements are not logged (the table counts them). ``rod``: the rod correction
    for this fit (``triangulate_views(rod=...)``: a taper or None) instead of the
    default."""
    import functools
    import logging

    import vidtrack.world.calibrated as calibrated
    from vidtrack.run.pipeline import FitOptions, fit_run

    log = logging.getLogger("vidtrack.run")
    level = log.level
    log.setLevel(logging.ERROR)
    triangulate = calibrated.triangulate_views
    if rod != "default":
        calibrated.triangulate_views = functools.partial(triangulate, rod=rod)
    try:
        return fit_run(folder, FitOptions(force=True, report=False, accept_disagreement=True))
    finally:
        calibrated.triangulate_views = triangulate
        log.setLevel(level)


def _decode(run, truth):
    """Iterate every frame of the run's videos doing nothing: the number of frames."""
    from vidtrack.footage import open_source

    n = 0
    for about in truth["views"].values():
        with open_source(run / about["source"], fps=about["fps"]) as src:
            for _ in src:
                n += 1
    return n


def _row(rig, cameras, angle, distance, reading, seed, record, timing, decode, truth_k):
    row = {"rig": rig, "cameras": cameras, "angle_deg": angle, "distance_m": distance,
           "reading": reading, "seed": seed}
    for k in K_NAMES:
        c = record["coefficients"][k]
        row[f"{k}_error_pct"] = (100.0 * (c["value"] / truth_k[k] - 1.0)
                                 if c.get("determined", True) and c["value"] is not None
                                 else np.nan)
    world = record.get("world") or {}
    row["x_rms_px"] = world.get("x_rms_px")
    row["reprojection_px"] = world.get("median_reprojection_px")
    row["findings"] = ",".join(sorted({c["check"] for c in record.get("checks") or []}))
    rod = world.get("rod_correction") or {}
    row["rod_median_px"], row["rod_max_px"] = rod.get("median_px"), rod.get("max_px")
    row["fit_s"] = timing.wall_median_s
    row.update(timing.columns("fit_"))
    row["decode_cpu_s"] = decode.cpu_min_s
    row["x_decode"] = decode.cpu_min_s / timing.cpu_min_s
    return row


def run_perspective_bench(out_dir, *, quick=False, seeds=None, progress=None, repeats=3,
                          warmup=1):
    """Render and fit every rig and reading; write bench_perspective.csv and .txt.

    Returns the printable table: per rig and reading, the mean error of k1..k4 (% of
    truth) over the seeds with its standard deviation, the median fit time and its CPU
    time against decoding's. ``repeats`` and ``warmup``: the counted and uncounted calls
    of each fit and of decoding.
    """
    from vidtrack.scene import write_scene
    from vidtrack.synth import render_run

    out_dir = Path(out_dir)
    seeds = seeds or ((1,) if quick else (1, 2, 3))
    rows, failures, renders = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for rig, cameras, angle, distance in RIGS:
            for seed in seeds:
                run = Path(tmp) / f"{cameras}-{angle:g}-{distance:g}-{seed}"
                render = timed(lambda run=run: render_run(run, _spec(cameras, angle,
                                                                     distance, seed)),
                               repeats=1, warmup=0)
                renders.append(render.wall_min_s)
                truth = json.loads((run / "truth.json").read_text())
                folders = {}
                for reading in READINGS[cameras]:
                    folder = run
                    if cameras == "square":
                        folder = Path(tmp) / f"{run.name}-{reading.split()[0]}" \
                            f"{'-d' if 'camera_distance' in reading else ''}"
                        folder.mkdir()
                        write_scene(folder, _reading_scene(run, reading, truth))
                    folders[reading] = folder
                runs = {"": lambda run=run, truth=truth: _decode(run, truth)}
                runs.update({reading: _guarded(folder, "uniform" if reading == ROD_AS_DRAWN
                                               else "default")
                             for reading, folder in folders.items()})
                times = timed_each(runs, repeats=repeats, warmup=warmup)
                decode = times.pop("")
                for reading, timing in times.items():
                    record = timing.result
                    if isinstance(record, Exception):      # a failure is a result: name it
                        failures.append(f"{rig}, {reading}, seed {seed}: "
                                        f"{type(record).__name__}: {record}")
                        continue
                    rows.append(_row(rig, cameras, angle, distance, reading, seed, record,
                                     timing, decode, truth["truth"]["k"]))
                if progress is not None:
                    progress(f"{rig} seed {seed}")
    table = pd.DataFrame(rows)
    with atomic_path(out_dir / "bench_perspective.csv") as t:
        table.to_csv(t, index=False)
    text = _summary_text(table, seeds, failures, renders)
    write_text(out_dir / "bench_perspective.txt", text + "\n")
    return text


def _guarded(folder, rod):
    """:func:`_fit_once` of ``folder`` as a function of no argument that returns the
    input error it raises instead of raising it."""
    from vidtrack.errors import INPUT_ERRORS

    def fit():
        try:
            return _fit_once(folder, rod)
        except INPUT_ERRORS as exc:
            return exc
    return fit


def _summary_text(table, seeds, failures, renders):
    lines = [f"Perspective cameras: k error (% of truth, mean +- sd over {len(seeds)} "
             "seed(s)) and the whole fit's time (tracking included; fit_s: wall, median of the "
             "counted calls; cpu_s: CPU, min, child processes included; x decode: decoding "
             "the run's CPU time over the fit's, minima, measured in turn in the same run); "
             "noise and MJPG compression on"]
    lines += [f"  failed: {f}" for f in failures]
    if not len(table):
        return "\n".join(lines)
    out = []
    for (rig, reading), grp in table.groupby(["rig", "reading"], sort=False):
        row = {"rig": rig, "reading": reading}
        for k in K_NAMES:
            e = grp[f"{k}_error_pct"].to_numpy(dtype=float)
            sd = float(np.std(e, ddof=1)) if len(e) > 1 else 0.0
            row[k] = f"{np.mean(e):+.2f} +- {sd:.2f}"
        x = grp["x_rms_px"].dropna()
        r = grp["reprojection_px"].dropna()
        row["x_rms_px"] = f"{x.median():.2f}" if len(x) else "-"
        row["reproj_px"] = f"{r.median():.2f}" if len(r) else "-"
        rod = grp["rod_max_px"].dropna()
        row["rod_px"] = (f"{grp['rod_median_px'].median():.2f}/{rod.max():.2f}" if len(rod)
                         else "-")
        found = sorted({f for s in grp["findings"] for f in s.split(",") if f})
        row["cross-checks"] = ",".join(found) or "pass"
        row["fit_s"] = f"{grp['fit_s'].median():.2f}"
        row["cpu_s"] = f"{grp['fit_cpu_min_s'].median():.2f}"
        row["x_decode"] = f"{grp['x_decode'].median():.3f}"
        out.append(row)
    lines += ["", pd.DataFrame(out).to_string(index=False),
              "", f"rendering: median {np.median(renders):.1f} s per run "
                  f"({len(renders)} runs)",
              "rod_px: the rod correction's median / max over the views and rows (px); "
              f"'{ROD_AS_DRAWN}': corrected for a silhouette of one width, as synth draws it",
              "cross-checks: what 'vidtrack fit' would refuse without --accept-disagreement "
              "(x_disagreement: the views' X differ by more than a pixel; speed_ratio: their "
              "speeds along X differ by more than 5 %)"]
    return "\n".join(lines)
