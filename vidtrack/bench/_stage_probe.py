"""One throw's fit stage and report stage, timed in a fresh process (``vidtrack bench
stages`` runs this file by its path, with the code under test first on ``PYTHONPATH``).

It reads a run folder's tracks (``vidtrack/tracks.h5``, not timed), then times the
stages that follow the tracks in :func:`vidtrack.run.pipeline.fit_throw_folder`, the
same calls in the same order:

- the fit stage: the views' cross-checks, :func:`fits.lsq.fit_throw`, the views' scales
  carried into k (:func:`vidtrack.run.scale_error.scale_error`), the perspective's
  effect (:func:`vidtrack.run.perspective.perspective_effect`) and fit.json's record;
- the report stage: report.html (the fitted curves, the residuals in pixels, the tracks
  plot, the trajectory over a full frame of each view, the contact sheet of crops of
  the footage) and report.md (a checkout before the residuals in pixels: without them
  and the trajectory).

Each stage's first call is ``cold`` (what it imports and loads for itself counted),
then ``warm`` counted calls follow. Before the clock starts the process has loaded what
the command has loaded when its fit stage begins: the pipeline, and the modules it
imports during tracking for the later stages (``vidtrack.run._workers.LATER_STAGES``);
matplotlib is not among them (the report stage loads it). Only names that every
version since 0.2 has are used, so that an older checkout can be timed beside this one
in the same run. Prints
one JSON object: CPU and wall seconds per call, and the fit's k1..k4 with their
standard errors (the fit's and the scales') and 95 % intervals (the fit's, the total).

Usage: ``python _stage_probe.py RUN WARM_CALLS``.
"""

import os
import sys

# as the command line does (vidtrack.cli): one BLAS thread, set before numpy loads
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS",
             "OPENCV_FOR_THREADS_NUM"):
    os.environ.setdefault(_var, "1")

import json  # noqa: E402
import resource  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

K_NAMES = ("k1", "k2", "k3", "k4")


def _cpu():
    own = resource.getrusage(resource.RUSAGE_SELF)
    return own.ru_utime + own.ru_stime


def _timed(fn):
    c0, w0 = _cpu(), time.perf_counter()
    out = fn()
    return out, _cpu() - c0, time.perf_counter() - w0


def _stages(run):
    """(fit stage, report stage) of the run's throw as functions of no argument."""
    import importlib

    import numpy as np

    from vidtrack.run import _workers
    from vidtrack.run.tracks_file import read_tracks
    from vidtrack.scene import load_scene

    for name in ("vidtrack.run.pipeline",) + tuple(getattr(_workers, "LATER_STAGES", ())):
        importlib.import_module(name)         # loaded by the command before its fit stage

    scene = load_scene(run)
    kept = read_tracks(Path(run) / "vidtrack" / "tracks.h5")
    tracks, world = kept.tracks, kept.world
    cp = scene.cp_s_per_m

    def fit_stage():
        from fits.lsq import fit_throw
        from vidtrack.run.fit_record import throw_record
        from vidtrack.run.perspective import perspective_effect
        from vidtrack.run.pipeline import _cross_check
        from vidtrack.run.scale_error import scale_error

        findings = _cross_check(scene, tracks, world)
        fit = fit_throw(world.data, cp, g=scene.physics.gravity_m_s2, v1=scene.v1_m_s,
                        model="quadratic", bootstrap=0, rng=np.random.default_rng(0))
        scale_part = scale_error(scene, tracks, fit, cp=cp, model="quadratic", world=world)
        fit = fit.with_calibration(scale_part.parts())
        effect = perspective_effect(scene, tracks, world, fit, cp=cp, model="quadratic")
        notes = list(scale_part.notes) + list(effect.notes if effect else ())
        extra = {"views": {n: tr.to_dict() for n, tr in tracks.items()},
                 "world": world.to_dict(), "stages_reused": ["tracks"],
                 "checks": [f.to_dict() for f in findings], "notes": notes,
                 "calibration": scale_part.to_dict()}
        return fit, throw_record(scene, fit, timings_s={"fit": 0.0}, extra=extra)

    def report_stage(fit, record):
        from vidtrack.report.run_page import render_html, render_markdown
        from vidtrack.report.view_path import view_paths

        views = {n: tr.data for n, tr in tracks.items()}
        paths = view_paths(scene, record, world.data, positions=fit.predict,
                           frame_shapes={n: tr.frame_shape for n, tr in tracks.items()})
        try:
            from vidtrack.report.trajectory import footage_html, pixel_residuals
        except ImportError:                      # a checkout before the pixel residuals
            from vidtrack.report.contact_sheet import contact_sheet_html

            sheet = contact_sheet_html(scene, scene.folder, views, paths)
            html = render_html(record, fit=fit, world=world.data, views=views,
                               contact_sheet=sheet)
            return {"report.md": render_markdown(record), "report.html": html}
        px = pixel_residuals(views, paths)
        sheet = footage_html(scene, scene.folder, views, paths)
        html = render_html(record, fit=fit, world=world.data, views=views,
                           contact_sheet=sheet, px_residuals=px)
        return {"report.md": render_markdown(record, px_residuals=px), "report.html": html}

    return fit_stage, report_stage


def _coefficients(fit):
    out = {}
    for k in K_NAMES:
        c = fit.coefficients[k]
        out[k] = ({"value": c.value, "stderr": c.stderr, "ci95": list(c.ci95),
                   "stderr_calibration": c.stderr_calibration,
                   "ci95_total": list(c.ci95_total)} if c.determined else None)
    return out


def main(run, warm_calls):
    fit_stage, report_stage = _stages(run)
    times = {"fit": [], "report": []}
    for _ in range(1 + warm_calls):           # the first call of each is the cold one
        (fit, record), cpu, wall = _timed(fit_stage)
        times["fit"].append((cpu, wall))
        pages, cpu, wall = _timed(lambda: report_stage(fit, record))
        times["report"].append((cpu, wall))
    print(json.dumps({"times": times, "coefficients": _coefficients(fit),
                      "report_bytes": sum(len(p) for p in pages.values()),
                      "vidtrack": sys.modules["vidtrack"].__file__}))


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]))
