"""``vidtrack fit``: footage -> tracks -> world track -> k1..k4, for one or many runs."""

import argparse
import contextlib

#: The --profile path is checked against the runs and the fit profiled here (the
#: command line's main leaves it to this command): before or after the command alike.
PROFILES_ITSELF = True

HELP = "fit k1..k4 to a run's footage (frames, tracks, 3-D track, least squares)"
DESCRIPTION = """\
For each run folder (scene.toml plus footage; docs/reference.md): read the frames,
track the straw in every view, merge the views into the world track, fit the throw
model axis by axis, and write <run>/vidtrack/tracks.h5, fit.json, report.md and
report.html. Only the stages the scene needs run; a stage whose inputs and settings are
unchanged is reused (--force reruns). A run with throws/ is fitted per throw and its
fit.json holds the mean over the throws. What the scene cannot determine (k4 without a
top view, k2 without a descent) is reported as not determined, with the reason.

RUN may be a run folder, an experiment folder (experiment.toml: its runs) or a folder
whose sub-folders are runs. Every run is checked (scene, footage, frame ranges, output
folders) before the first is tracked.

The views are cross-checked after tracking: their disagreement on the X both see, their
speeds along it (a wrong fps), the same footage named for two views, implausible
accelerations (docs/fit-outputs.md, "Cross-checks"). Inputs that disagree stop the run
(exit 2) unless --accept-disagreement, which fits anyway and prints the warning.

Examples:
  vidtrack fit datasets/run42/
  vidtrack fit exp2016/runs/ --jobs 2
  vidtrack fit run42/ --json --model linear
  vidtrack fit run42/ --accept-disagreement
  vidtrack fit run42/ --force --profile fit.prof     (then: python -m pstats fit.prof)
"""


def add_arguments(parser):
    parser.add_argument("runs", nargs="+", metavar="RUN",
                        help="run folder(s), or folders of runs, e.g. datasets/run42/")
    parser.add_argument("--model", choices=("quadratic", "linear", "free"),
                        default="quadratic",
                        help="throw model: quadratic drag (Chen 2018, default), linear "
                             "drag (Liao 2021) or drag-free (Hou 2019)")
    parser.add_argument("--bootstrap", type=int, default=0, metavar="N",
                        help="residual-bootstrap resamples for the errors (default 0: "
                             "from the Jacobian; at most 100000), e.g. --bootstrap 200")
    parser.add_argument("--seed", type=int, default=0,
                        help="random seed of the bootstrap (default 0; 0 to 2^32-1)")
    parser.add_argument("--jobs", type=int, default=1, metavar="N",
                        help="fit runs in N parallel processes (1 to 256), e.g. --jobs 2")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="dask.distributed scheduler to fit runs on, e.g. "
                             "tcp://10.0.0.5:8786 (needs: pip install 'vidtrack[dask]')")
    parser.add_argument("--force", action="store_true",
                        help="rerun every stage even when its inputs are unchanged")
    parser.add_argument("--no-report", action="store_true",
                        help="skip report.md and report.html (a report of an earlier fit "
                             "is removed)")
    parser.add_argument("--accept-disagreement", action="store_true",
                        help="fit even when the inputs disagree (the views on X, a wrong "
                             "fps, one footage for two views, implausible accelerations); "
                             "the warning is printed and kept in fit.json")
    parser.add_argument("--json", action="store_true",
                        help="print the fit.json record(s) to stdout (a list for several runs)")
    parser.add_argument("--profile", metavar="FILE", default=argparse.SUPPRESS,
                        help="write a cProfile of the command to FILE (read it with python "
                             "-m pstats FILE); it covers this process only: the view "
                             "tracked by the worker process (with the report's plots it "
                             "draws) and the runs of --jobs or --scheduler are not in it, "
                             "e.g. --profile fit.prof")


#: Said under the table when any k carries the calibration's part.
SCALE_LEGEND = ("k: value ± fit ± scale (standard errors): the fit's own (the points' "
                "scatter), then the views' scales' (systematic: shared by every throw of "
                "the run, averaging throws does not reduce it); fit.json's stderr and ci95 "
                "hold both, stderr_fit and ci95_fit the fit's own")


def _k_cell(c):
    """``2.203 ± 0.0013 ± 0.016`` (value ± fit ± scale), ``n.d.`` when not determined."""
    if not c["determined"]:
        return "n.d."
    cell = f"{c['value']:.4g} ± {c.get('stderr_fit', c['stderr']):.2g}"
    if c.get("stderr_calibration") is not None:
        cell += f" ± {c['stderr_calibration']:.2g}"
    return cell


def format_records(records):
    """One line per run: k1..k4 as value ± fit stderr (± scale stderr where known; n.d.
    when not determined)."""
    scaled = any(r["coefficients"][k].get("stderr_calibration") is not None
                 for r in records for k in ("k1", "k2", "k3", "k4"))
    w = 22 if scaled else 16
    head = (f"{'run':<14} {'k1':>{w}} {'k2':>{w}} {'k3':>{w}} {'k4':>{w}} "
            f"{'rms mm x/y/z':>16} {'s':>6}")
    lines = [head, "-" * len(head)]
    for r in records:
        cells = [_k_cell(r["coefficients"][k]) for k in ("k1", "k2", "k3", "k4")]
        rms = "/".join("-" if r["residual_rms_m"][a] is None
                       else f"{1000 * r['residual_rms_m'][a]:.2f}" for a in "xyz")
        total = r["timings_s"].get("total", sum(r["timings_s"].values()))
        lines.append(f"{r['run']:<14} " + " ".join(f"{c:>{w}}" for c in cells)
                     + f" {rms:>16} {total:6.2f}")
    if scaled:
        lines.append(SCALE_LEGEND)
    notes = []
    for r in records:
        if "fit" in r.get("stages_reused", []):
            when = r.get("throws_fitted_at") or r.get("fitted_at")
            notes.append(f"{r['run']}: nothing changed: reused the fit of "
                         f"{when or 'an earlier run'} (--force fits again)")
        for k in ("k1", "k2", "k3", "k4"):
            c = r["coefficients"][k]
            if not c["determined"]:
                notes.append(f"{r['run']}: {k} not determined: {c.get('reason', '')}")
    return "\n".join(lines + ([""] + notes if notes else []))


def run(args):
    import json
    import logging
    import sys

    from vidtrack._text import printable
    from vidtrack.cli._profile import check_profile_path, profiled
    from vidtrack.run.pipeline import FitOptions, check_counts, find_runs, fit_runs

    check_counts(jobs=args.jobs, bootstrap=args.bootstrap, seed=args.seed)
    runs = find_runs(args.runs)
    profile = getattr(args, "profile", None)    # vidtrack --profile F fit, fit --profile F
    if profile:
        check_profile_path(profile, inputs=runs)
    options = FitOptions(model=args.model, bootstrap=args.bootstrap, seed=args.seed,
                         force=args.force, report=not args.no_report, quiet=args.quiet,
                         view_process=True, accept_disagreement=args.accept_disagreement)

    log = logging.getLogger(__name__)

    def progress(record):
        log.info("fitted %s", record["run"])
        if (not args.quiet and not args.json and sys.stderr.isatty()
                and not log.isEnabledFor(logging.INFO)):
            print(f"  fitted {printable(record['run'])}", file=sys.stderr)

    try:
        with sigterm_as_interrupt(), profiled(profile):
            # every run is checked before any is tracked (fit_runs: prepare_runs)
            records = fit_runs(runs, options, jobs=args.jobs, scheduler=args.scheduler,
                               progress=progress)
    except KeyboardInterrupt:
        print(f"vidtrack fit: {INTERRUPTED}", file=sys.stderr)
        return 130
    if args.json:
        print(json.dumps(records[0] if len(records) == 1 else records, indent=2))
    else:
        print(printable(format_records(records), keep="\n"))
    return 0


#: What Ctrl-C (or SIGTERM) during a fit or report leaves, said on stderr (exit 130).
INTERRUPTED = ("interrupted; every file in the runs' vidtrack/ folders is whole (the "
               "unfinished stage left none) and finished stages are reused: run the same "
               "command again to finish")


@contextlib.contextmanager
def sigterm_as_interrupt():
    """SIGTERM raises KeyboardInterrupt here, as Ctrl-C does: the worker process is
    stopped and temporary files are removed on the way out."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def on_term(signum, frame):
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGTERM, on_term)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)
