"""``vidtrack bench stages``: one throw's fit stage and report stage against decoding.

The run (default: the sample run ``datasets/run42`` of a checkout) is copied and tracked
once (``fit_run``, no report); then, round by round, in turn:

- ``decode``: its videos read to the end with plain OpenCV in this process (as
  ``vidtrack bench fit`` decodes them);
- for each code under test (this checkout, and with ``baseline`` another checkout's
  root, e.g. ``git archive`` of an earlier commit unpacked), a fresh Python process
  (:mod:`vidtrack.bench._stage_probe`) that reads the tracks and times the fit stage and
  the report stage: their first calls (``cold``: the imports and loads they make
  themselves counted) and ``warmup`` + ``repeats`` more calls (``warm``; the first
  ``warmup`` of them not counted).

The first ``warmup`` rounds are not counted. CPU time is the process's own (user +
system; one BLAS thread, as the command line sets). The table gives, per code and stage,
the min and median CPU seconds of the counted cold calls and of the warm calls, and
each over decoding's CPU time (min over min); and each code's k1..k4 with their standard
errors and 95 % intervals, so that the codes' numbers are seen side by side.
``bench_stages.csv`` holds the rows.
"""

import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import pandas as pd

from vidtrack._atomic import atomic_path, write_text
from vidtrack.bench._timing import timed_each

__all__ = ["run_stages_bench", "sample_run"]

K_NAMES = ("k1", "k2", "k3", "k4")
STAGES = ("fit", "report")
#: The probe's file, run by its path so that any checkout can be the code under test.
PROBE = Path(__file__).with_name("_stage_probe.py")


def sample_run():
    """``datasets/run42`` beside the package (a checkout), or None."""
    path = Path(__file__).resolve().parents[2] / "datasets" / "run42"
    return path if (path / "scene.toml").is_file() else None


def _code_root(path):
    """The folder holding ``vidtrack/`` (a checkout's root) for PYTHONPATH."""
    root = Path(path).resolve()
    if not (root / "vidtrack" / "__init__.py").is_file():
        from vidtrack.errors import VidtrackError

        raise VidtrackError(f"--baseline {path}: no vidtrack/__init__.py there (expected "
                            "the root of a vidtrack checkout)")
    return root


def _probe(root, run, calls):
    """One fresh process timing the stages with the code at ``root``: its JSON."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(root)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))
    res = subprocess.run([sys.executable, str(PROBE), str(run), str(calls)],
                         capture_output=True, text=True, env=env, cwd=run)
    if res.returncode != 0:
        raise RuntimeError(f"the stage probe failed with the code at {root}:\n{res.stderr}")
    out = json.loads(res.stdout.strip().splitlines()[-1])
    if Path(out["vidtrack"]).resolve().parents[1] != root:
        raise RuntimeError(f"the probe loaded {out['vidtrack']}, not the code at {root}")
    return out


def _rows(name, probes, warmup, decode_cpu_min):
    rows = []
    for stage in STAGES:
        cold = [p["times"][stage][0][0] for p in probes]
        warm = [c for p in probes for c, _ in p["times"][stage][1 + warmup:]]
        row = {"code": name, "stage": stage}
        for kind, values in (("cold", cold), ("warm", warm)):
            row[f"{kind}_cpu_min_s"] = min(values) if values else float("nan")
            row[f"{kind}_cpu_median_s"] = (statistics.median(values) if values
                                           else float("nan"))
            row[f"{kind}_vs_decode"] = row[f"{kind}_cpu_min_s"] / decode_cpu_min
            row[f"{kind}_calls"] = len(values)
        rows.append(row)
    return rows


def _k_lines(name, coefficients):
    lines = []
    for k in K_NAMES:
        c = coefficients[k]
        lines.append(f"  {name:>10} {k}: " + ("not determined" if c is None else
                                             f"{c['value']!r} ± {c['stderr']:.6g} ± "
                                             f"{c['stderr_calibration']:.6g}, 95 % "
                                             f"[{c['ci95_total'][0]!r}, "
                                             f"{c['ci95_total'][1]!r}]"))
    return lines


def _largest_change(a, b):
    """The largest relative difference of k, its standard errors and intervals' ends."""
    worst = 0.0
    for k in K_NAMES:
        if a[k] is None or b[k] is None:
            continue
        pairs = [(a[k][q], b[k][q]) for q in ("value", "stderr", "stderr_calibration")]
        pairs += list(zip(a[k]["ci95"], b[k]["ci95"]))
        pairs += list(zip(a[k]["ci95_total"], b[k]["ci95_total"]))
        worst = max(worst, *(abs(x - y) / abs(y) for x, y in pairs if y))
    return worst


def run_stages_bench(out_dir, *, run=None, baseline=None, repeats=3, warmup=1,
                     progress=None):
    """Time one throw's fit and report stages beside decoding; write bench_stages.csv
    and bench_stages.txt into ``out_dir`` and return the printable text.

    ``run``: a run folder with one throw (default :func:`sample_run`); ``baseline``: the
    root of another checkout timed in the same rounds.
    """
    from vidtrack.bench.fit import _decode_only
    from vidtrack.errors import VidtrackError
    from vidtrack.run.pipeline import FitOptions, fit_run
    from vidtrack.scene import load_scene

    run = Path(run) if run is not None else sample_run()
    if run is None:
        raise VidtrackError("vidtrack bench stages: no run given and no datasets/run42 "
                            "beside the package; give one with --run RUN")
    if not (run / "scene.toml").is_file() or (run / "throws").is_dir():
        raise VidtrackError(f"--run {run}: expected a run folder of one throw (scene.toml "
                            "and its footage, no throws/)")
    codes = {"this": _code_root(Path(__file__).resolve().parents[2])}
    if baseline is not None:
        codes["baseline"] = _code_root(baseline)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        copy = Path(tmp) / run.name
        shutil.copytree(run, copy, ignore=shutil.ignore_patterns("vidtrack"))
        fit_run(copy, FitOptions(force=True, report=False))      # the tracks, once
        scene = load_scene(copy)
        paths = [scene.views[v].source for v in scene.view_names]
        calls = warmup + repeats
        seen = {name: [] for name in codes}       # every probe's answer, in order
        fns = {"decode": lambda: _decode_only(paths)}
        fns.update({name: (lambda name=name, root=root:
                           seen[name].append(_probe(root, copy, calls)))
                    for name, root in codes.items()})
        timing = timed_each(fns, repeats=repeats, warmup=warmup)
        if progress:
            progress("stages")
    probes = {name: seen[name][warmup:] for name in codes}     # the counted rounds
    decode = timing["decode"]
    rows = []
    for name in codes:
        rows += _rows(name, probes[name], warmup, decode.cpu_min_s)
    table = pd.DataFrame(rows)
    with atomic_path(out_dir / "bench_stages.csv") as tmp:
        table.to_csv(tmp, index=False)
    text = [f"One throw of {run} (fit stage and report stage, CPU s, one BLAS thread) "
            f"against decoding its footage ({decode.result} frames: CPU min "
            f"{decode.cpu_min_s:.3f} s, median {decode.cpu_median_s:.3f} s); "
            f"{repeats} counted rounds after {warmup} uncounted, in turn; cold: each "
            "stage's first call in a fresh process, warm: the calls after it", "",
            table.to_string(index=False, float_format=lambda v: f"{v:.3f}"), "",
            "k1..k4 (value ± the fit's stderr ± the scales', 95 % interval of both, as "
            "fit.json's ci95):"]
    for name in codes:
        text += _k_lines(name, probes[name][-1]["coefficients"])
    if baseline is not None:
        worst = _largest_change(probes["this"][-1]["coefficients"],
                                probes["baseline"][-1]["coefficients"])
        text.append(f"largest relative difference (k, stderr, interval ends), this against "
                    f"baseline: {worst:.2g}")
    text = "\n".join(text)
    write_text(out_dir / "bench_stages.txt", text + "\n")
    return text

