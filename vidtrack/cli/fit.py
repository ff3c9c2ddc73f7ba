"""``vidtrack fit``: footage -> tracks -> world track -> k1..k4, for one or many runs."""

HELP = "fit k1..k4 to a run's footage (frames, tracks, 3-D track, least squares)"
DESCRIPTION = """\
For each run folder (scene.toml plus footage; SPEC "A run folder"): read the frames,
track the straw in every view, merge the views into the world track, fit the throw
model axis by axis, and write <run>/vidtrack/tracks.h5, fit.json, report.md and
report.html. Only the stages the scene needs run; a stage whose inputs and settings are
unchanged is reused (--force reruns). A run with throws/ is fitted per throw and its
fit.json holds the mean over the throws. What the scene cannot determine (k4 without a
top view, k2 without a descent) is reported as not determined, with the reason.

RUN may be a run folder, an experiment folder (experiment.toml: its runs) or a folder
whose sub-folders are runs.

Examples:
  vidtrack fit datasets/run42/
  vidtrack fit exp2016/runs/ --jobs 2
  vidtrack fit run42/ --json --model linear
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
                             "from the Jacobian), e.g. --bootstrap 200")
    parser.add_argument("--seed", type=int, default=0,
                        help="random seed of the bootstrap (default 0)")
    parser.add_argument("--jobs", type=int, default=1, metavar="N",
                        help="fit runs in N parallel processes, e.g. --jobs 2")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="dask.distributed scheduler to fit runs on, e.g. "
                             "tcp://10.0.0.5:8786 (needs: pip install 'vidtrack[dask]')")
    parser.add_argument("--force", action="store_true",
                        help="rerun every stage even when its inputs are unchanged")
    parser.add_argument("--no-report", action="store_true",
                        help="skip report.md and report.html")
    parser.add_argument("--json", action="store_true",
                        help="print the fit.json record(s) to stdout (a list for several runs)")


def format_records(records):
    """One line per run: k1..k4 as value ± stderr (n.d. when not determined)."""
    head = f"{'run':<14} {'k1':>16} {'k2':>16} {'k3':>16} {'k4':>16} {'rms mm x/y/z':>16} {'s':>6}"
    lines = [head, "-" * len(head)]
    for r in records:
        cells = []
        for k in ("k1", "k2", "k3", "k4"):
            c = r["coefficients"][k]
            cells.append(f"{c['value']:.4g} ± {c['stderr']:.2g}" if c["determined"]
                         else "n.d.")
        rms = "/".join("-" if r["residual_rms_m"][a] is None
                       else f"{1000 * r['residual_rms_m'][a]:.2f}" for a in "xyz")
        total = r["timings_s"].get("total", sum(r["timings_s"].values()))
        lines.append(f"{r['run']:<14} " + " ".join(f"{c:>16}" for c in cells)
                     + f" {rms:>16} {total:6.2f}")
    notes = []
    for r in records:
        for k in ("k1", "k2", "k3", "k4"):
            c = r["coefficients"][k]
            if not c["determined"]:
                notes.append(f"{r['run']}: {k} not determined: {c.get('reason', '')}")
    return "\n".join(lines + ([""] + notes if notes else []))


def run(args):
    import json
    import sys

    from vidtrack.errors import VidtrackError
    from vidtrack.run.pipeline import FitOptions, find_runs, fit_runs

    if args.jobs < 1:
        raise VidtrackError(f"--jobs must be >= 1, got {args.jobs}")
    if args.bootstrap < 0:
        raise VidtrackError(f"--bootstrap must be >= 0, got {args.bootstrap}")
    runs = find_runs(args.runs)
    options = FitOptions(model=args.model, bootstrap=args.bootstrap, seed=args.seed,
                         force=args.force, report=not args.no_report, quiet=args.quiet,
                         view_process=True)

    def progress(record):
        if not args.quiet and not args.json and sys.stderr.isatty():
            print(f"  fitted {record['run']}", file=sys.stderr)

    records = fit_runs(runs, options, jobs=args.jobs, scheduler=args.scheduler,
                       progress=progress)
    if args.json:
        print(json.dumps(records[0] if len(records) == 1 else records, indent=2))
    else:
        print(format_records(records))
    return 0
