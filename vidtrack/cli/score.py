"""``vidtrack score EXPERIMENT``: a rehearsal's fits against its truth."""

HELP = "score a rehearsed experiment: every throw's fit against its truth, the regressions"
DESCRIPTION = """\
After 'vidtrack synth EXPERIMENT --regression ...' rendered every run and 'vidtrack
report EXPERIMENT' fitted them, pair each throw's truth.json with its fit.json: the
error of each k, whether its 95 % interval (ci95) covers the truth, and per k the mean,
RMS and largest error and the coverage over all throws. Then the response-surface
regression of each k, as 'vidtrack report' fits it, on the fitted k beside the same
regression on the true k (each run's mean over its throws): the terms backward
elimination selects on each, and the coefficients on the true k's terms side by side
(coded units) with their largest absolute difference.

Prints the tables; writes EXPERIMENT/vidtrack/score_throws.csv (one row per throw),
score_regression.csv (one row per k and term), score.json and score.txt. Nothing
else is written; a run without truth.json or fit.json gives one line and exit code 2.

Examples:
  vidtrack score exp2
  vidtrack score exp2 --alpha 0.1 --json
"""


def add_arguments(parser):
    parser.add_argument("experiment", metavar="EXPERIMENT",
                        help="a rehearsed experiment folder (rendered by vidtrack synth, "
                             "fitted by vidtrack report), e.g. exp2/")
    parser.add_argument("--alpha", type=float, default=0.05,
                        help="significance level of the backward elimination, as "
                             "'vidtrack report --alpha' (default 0.05), e.g. --alpha 0.1")
    parser.add_argument("--json", action="store_true",
                        help="print score.json to stdout instead of the tables")


def run(args):
    import json
    from pathlib import Path

    from vidtrack._text import printable
    from vidtrack.rehearsal import score_experiment, write_score

    score = score_experiment(args.experiment, alpha=args.alpha)
    out = Path(score.experiment) / "vidtrack"
    write_score(out, score)
    if args.json:
        print(json.dumps(score.to_dict(), indent=2, allow_nan=False))
        return 0
    print(printable(score.summary(), keep="\n"))
    print(printable(f"\nwritten to {out}/ (score_throws.csv, score_regression.csv, "
                    "score.json, score.txt)", keep="\n"))
    return 0
