"""``vidtrack report``: fit every run of an experiment and write its ANOVA report."""

HELP = "fit every run of an experiment, build the coefficient table and its ANOVA report"
DESCRIPTION = """\
Read EXPERIMENT/experiment.toml (design, factor coding, responses, runs), fit every run
as 'vidtrack fit' does (reusing runs already fitted), build the coefficient table in the
layout of Chen 2018 Table 2 and analyse it as 'vidtrack anova' does (response-surface
regression with backward elimination, lack of fit and pure error). Writes
EXPERIMENT/vidtrack/coefficients.csv, anova.json and report.html.

Examples:
  vidtrack report exp2016/
  vidtrack report exp2016/ --jobs 2 --alpha 0.1
"""


def add_arguments(parser):
    parser.add_argument("experiment", metavar="EXPERIMENT",
                        help="experiment folder holding experiment.toml, e.g. exp2016/")
    parser.add_argument("--jobs", type=int, default=1, metavar="N",
                        help="fit runs in N parallel processes")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="dask.distributed scheduler address (needs the dask extra)")
    parser.add_argument("--alpha", type=float, default=0.05,
                        help="significance level of the backward elimination (default 0.05)")
    parser.add_argument("--force", action="store_true", help="refit every run")
    parser.add_argument("--model", choices=("quadratic", "linear", "free"),
                        default="quadratic", help="throw model (default quadratic)")


def run(args):
    from pathlib import Path

    from vidtrack.errors import VidtrackError
    from vidtrack.experiment import analyse, coefficient_table, write_outputs
    from vidtrack.run.pipeline import FitOptions, fit_runs
    from vidtrack.scene import load_experiment

    if not 0 < args.alpha < 1:
        raise VidtrackError(f"--alpha must be in (0, 1), got {args.alpha}")
    exp = load_experiment(args.experiment)
    options = FitOptions(model=args.model, force=args.force, quiet=args.quiet,
                         view_process=True)
    records = fit_runs(exp.run_dirs(), options, jobs=args.jobs, scheduler=args.scheduler)
    table = coefficient_table(exp, records)
    fits = analyse(exp, table, alpha=args.alpha)
    out = Path(exp.folder) / "vidtrack"
    write_outputs(out, exp, table, fits)
    print(table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    for fit in fits:
        print()
        print(fit.summary())
    print(f"\nwritten to {out}/ (coefficients.csv, anova.json, report.html)")
    return 0
