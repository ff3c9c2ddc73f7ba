"""Run a named benchmark, write its CSV and PNG, and return the printable table."""

import importlib.util
from pathlib import Path

from vidtrack._atomic import atomic_path, write_text


def available():
    """Benchmarks this installation can run (``track`` appears once its module exists)."""
    names = ["model"]
    for name in ("track", "fit", "perspective", "stages"):
        if importlib.util.find_spec(f"vidtrack.bench.{name}") is not None:
            names.append(name)
    return names


def _write_csv(table, path):
    with atomic_path(path) as tmp:
        table.to_csv(tmp, index=False)


def bench_model(out_dir, *, quick=False, progress=None, repeats=3, warmup=1):
    """Throw models (and, when present, the blade slide): CSV, PNG and text."""
    from vidtrack.bench import model

    out_dir = Path(out_dir)
    table = model.run_model_bench(quick=quick, progress=progress, repeats=repeats,
                                  warmup=warmup)
    _write_csv(table, out_dir / "bench_model.csv")
    with atomic_path(out_dir / "bench_model.png") as tmp:
        model.plot_work_precision(table, tmp)
    text = ["Throw model: max error against 50-digit truth and time per trajectory "
            "evaluation", model.TIMING_NOTE, "", model.format_table(table)]
    if importlib.util.find_spec("vidtrack.bench.blade") is not None:
        from vidtrack.bench.blade import run_blade_bench

        blade = run_blade_bench(repeats=repeats, warmup=warmup)
        _write_csv(blade, out_dir / "bench_blade.csv")
        text += ["", "Blade slide (Chen 2018 eqs. 1-3): printed forms against the exact "
                 "solution", "(time_per_eval_s: wall, median; CPU and wall s of warm calls, "
                 "a time budget each)", "",
                 blade.drop(columns=["wall_median_s"]).to_string(index=False)]
    write_text(out_dir / "bench_model.txt", "\n".join(text) + "\n")
    return "\n".join(text)


def bench_track(out_dir, *, quick=False, progress=None, repeats=3, warmup=1):
    """The tracker against decode-only, trackpy and an OpenCV tracker."""
    from vidtrack.bench.track import format_track_bench, run_track_bench

    table = run_track_bench(out_dir, quick=quick, repeats=repeats, warmup=warmup)
    return format_track_bench(table)


def bench_track_real(out_dir, *, quick=False, progress=None, engines=None, clips=None,
                     shared=None, repeats=3, warmup=1):
    """The tracker scoreboard: real clips and synthetic scenes, each engine (CSV, text)."""
    from vidtrack.bench.real import format_scoreboard, run_scoreboard

    table = run_scoreboard(out_dir, shared=shared, engines=engines, clips=clips,
                           quick=quick, progress=progress, repeats=repeats, warmup=warmup)
    return format_scoreboard(table)


def bench_fit(out_dir, *, quick=False, progress=None, seeds=None, repeats=3, warmup=1,
              coverage=None):
    """k error against frames used and run time; whole fit against plain decoding. With
    ``coverage`` (a number of throws): the 95 % intervals' coverage instead."""
    if coverage:
        from vidtrack.bench.coverage import run_coverage_bench

        return run_coverage_bench(out_dir, throws=coverage, progress=progress)
    from vidtrack.bench.fit import run_fit_bench

    return run_fit_bench(out_dir, quick=quick,
                         seeds=tuple(range(1, seeds + 1)) if seeds else None,
                         repeats=repeats, warmup=warmup)


def bench_perspective(out_dir, *, quick=False, progress=None, seeds=None, repeats=3,
                      warmup=1):
    """Perspective cameras: calibrated against the orthographic reading, k error and time."""
    from vidtrack.bench.perspective import run_perspective_bench

    return run_perspective_bench(out_dir, quick=quick, progress=progress,
                                 seeds=tuple(range(1, seeds + 1)) if seeds else None,
                                 repeats=repeats, warmup=warmup)


def bench_stages(out_dir, *, quick=False, progress=None, run=None, baseline=None, repeats=3,
                 warmup=1):
    """One throw's fit and report stages (cold and warm CPU) against decoding its footage."""
    from vidtrack.bench.stages import run_stages_bench

    return run_stages_bench(out_dir, run=run, baseline=baseline, repeats=repeats,
                            warmup=warmup, progress=progress)


RUNNERS = {"model": bench_model, "track": bench_track, "fit": bench_fit,
           "perspective": bench_perspective, "stages": bench_stages}
