"""``vidtrack report``: fit every run of an experiment and write its ANOVA report."""

HELP = "fit every run of an experiment, build the coefficient table and its ANOVA report"
DESCRIPTION = """\
Read EXPERIMENT/experiment.toml (design, factor coding, responses, runs), fit every run
as 'vidtrack fit' does (reusing runs already fitted), build the coefficient table in the
layout of Chen 2018 Table 2 and analyse it as 'vidtrack anova' does (response-surface
regression with backward elimination, lack of fit and pure error). Writes
EXPERIMENT/vidtrack/coefficients.csv, anova.json and report.html.

Before any run is fitted, every run's scene is read and checked against the experiment
(each factor of the design named in its [factors], as a number), every footage is
opened and every output folder is checked. The outputs of an earlier report are
removed when the runs are fitted again, so a report that fails leaves none. Inputs
that disagree stop the run as in 'vidtrack fit' unless --accept-disagreement.

Examples:
  vidtrack report exp2016/
  vidtrack report exp2016/ --jobs 2 --alpha 0.1
"""


def add_arguments(parser):
    parser.add_argument("experiment", metavar="EXPERIMENT",
                        help="experiment folder holding experiment.toml, e.g. exp2016/")
    parser.add_argument("--jobs", type=int, default=1, metavar="N",
                        help="fit runs in N parallel processes (1 to 256)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="dask.distributed scheduler address (needs the dask extra)")
    parser.add_argument("--alpha", type=float, default=0.05,
                        help="significance level of the backward elimination (default 0.05)")
    parser.add_argument("--force", action="store_true", help="refit every run")
    parser.add_argument("--model", choices=("quadratic", "linear", "free"),
                        default="quadratic", help="throw model (default quadratic)")
    parser.add_argument("--accept-disagreement", action="store_true",
                        help="fit runs whose inputs disagree (as 'vidtrack fit "
                             "--accept-disagreement'), with a warning")


def run(args):
    import sys
    from pathlib import Path

    from vidtrack._text import printable
    from vidtrack.cli.fit import INTERRUPTED, sigterm_as_interrupt
    from vidtrack.errors import VidtrackError
    from vidtrack.experiment import (OUTPUTS, analyse, check_runs, coefficient_table,
                                     run_table, write_outputs)
    from vidtrack.run.pipeline import FitOptions, check_counts, fit_runs, prepare_runs
    from vidtrack.run.preflight import check_output_folder
    from vidtrack.scene import load_experiment, load_scene

    if not 0 < args.alpha < 1:
        raise VidtrackError(f"--alpha must be in (0, 1), got {args.alpha}")
    check_counts(jobs=args.jobs)
    exp = load_experiment(args.experiment)
    options = FitOptions(model=args.model, force=args.force, quiet=args.quiet,
                         view_process=True, accept_disagreement=args.accept_disagreement)
    run_dirs = exp.run_dirs()
    # everything checkable, before the first run is fitted: the scenes against the
    # design, then each run's footage and output folders, then the report's own folder
    check_runs(exp, [load_scene(r) for r in run_dirs])
    out = Path(exp.folder) / "vidtrack"
    try:
        with sigterm_as_interrupt():
            plans = prepare_runs(run_dirs, options)
            check_output_folder(out, OUTPUTS, f"experiment {exp.folder.name!r}")
            # the report is made again from the runs' fits: until then there is none
            for name in OUTPUTS:
                (out / name).unlink(missing_ok=True)
            records = fit_runs(run_dirs, options, jobs=args.jobs, scheduler=args.scheduler,
                               plans=plans)
    except KeyboardInterrupt:
        print(f"vidtrack report: {INTERRUPTED}", file=sys.stderr)
        return 130
    table = coefficient_table(exp, records)
    fits = analyse(exp, table, alpha=args.alpha)
    write_outputs(out, exp, table, fits,
                  runs=run_table(exp, table, records, run_dirs, out))
    print(printable(table.to_string(index=False, float_format=lambda v: f"{v:.3g}"),
                    keep="\n"))
    for fit in fits:
        print()
        print(fit.summary())
    print(printable(f"\nwritten to {out}/ (coefficients.csv, anova.json, report.html)",
                    keep="\n"))
    return 0
