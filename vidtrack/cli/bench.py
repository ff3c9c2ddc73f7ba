"""``vidtrack bench``: error against run time, side by side with the alternatives."""

HELP = "benchmarks: error against run time, side by side with the alternatives"
DESCRIPTION = """\
Measure error and run time of vidtrack's methods and the alternatives a user could
pick, in one run on this machine, and write a table (TEXT, CSV) and a plot (PNG).

  model  the throw model: vidtrack's closed form, Chen 2018's printed eqs. 12-18 and
         scipy's solve_ivp (RK45, DOP853, Radau, BDF, LSODA at rtol 1e-3..1e-12) on a
         typical, a stiff and an extreme case, against 50-digit truth; plus the blade
         slide (eqs. 2 and 3 against the exact solution)
  track  the tracker against decode-only, trackpy.locate and an OpenCV tracker
         --real: the tracker scoreboard instead: every clip of <shared>/data/real
         that has footage (launcher, balltoss, the two bears, diabolo, the two
         badminton cameras with their target) and every synthetic distractor scene
         (both views), tracked by each engine and scored against a reference made by
         others: the share of the flight unflagged; median, 95th percentile, largest
         and RMS distance (px) from the reference; a fit's figure from the track
         against the same from the reference's own points (launcher k2/k1 of a
         drag-free fit; balltoss and diabolo g; bears k of a linear-drag fit;
         badminton and synth |a| of a 2-D parabola); CPU s of track() and decode-only
         time / track time. Writes bench_track_real.csv and .txt. A clip whose files
         are absent is skipped, saying so; one an engine refuses is a 'failed' row
  fit    k error against frames used (1200..150 fps) and run time, interval coverage
         over seeded runs, and the whole 'vidtrack fit' against plain decoding
  stages one throw's fit stage (cross-checks, least squares, the scales' and the
         perspective's part) and report stage (report.html and report.md), each
         timed cold (its first call in a fresh process) and warm, in CPU seconds
         against decoding the same footage; --run RUN (default: the sample run of a
         checkout), --baseline DIR times another checkout in the same rounds
  perspective
         pinhole cameras 60..120 degrees apart, 1..3 m away: k error read as calibrated
         cameras, and the square rig at 1.5 and 3 m read orthographically (without and
         with camera_distance_m) and as calibrated cameras, with the fit's run time

Every time is measured on warm calls: one uncounted warm-up call (--warmup), then
--repeats counted calls, interleaved round by round where methods are compared; the
tables give the min and median of CPU time (the process's threads and its child
processes) and of wall time, and ratios to decoding (model: to the closed form)
measured in the same run.

Examples:
  vidtrack bench model
  vidtrack bench model --out results/ --quick
  vidtrack bench perspective --seeds 3
  vidtrack bench track --real --quick
  vidtrack bench track --quick --repeats 5
  vidtrack bench track --real --repeats 1 --warmup 0
  vidtrack bench track --real --engine rules --clips balltoss,launcher,synth:shadow
  vidtrack bench stages --repeats 5
  vidtrack bench stages --baseline /tmp/vidtrack-main     (e.g. git archive main, unpacked)
"""


def add_arguments(parser):
    from vidtrack.bench.run import available

    parser.add_argument("which", nargs="?", default="model", choices=available(),
                        help="which benchmark to run (default: model)")
    parser.add_argument("--out", default="vidtrack-bench", metavar="DIR",
                        help="folder for the CSV, PNG and text table "
                             "(default: ./vidtrack-bench)")
    parser.add_argument("--quick", action="store_true",
                        help="smaller footage, fewer tolerances, seeds and clips: a smoke run")
    parser.add_argument("--seeds", type=int, default=None, metavar="N",
                        help="fit and perspective: number of seeded synthetic runs "
                             "(default 10 for fit, 3 for perspective; e.g. --seeds 40 for "
                             "the interval coverage)")
    parser.add_argument("--coverage", type=int, default=None, metavar="THROWS",
                        help="fit: how often each k's 95 %% interval covers the truth over "
                             "THROWS synthetic throws (the sample run's geometry and "
                             "tracker errors; scenes exact and read by eye; the views' "
                             "scales independent and reconciled on the shared X), e.g. "
                             "--coverage 200 (about 3 s of CPU a throw with one BLAS thread)")
    parser.add_argument("--repeats", type=int, default=3, metavar="N",
                        help="counted calls of each timed method, after the warm-up "
                             "(default 3; 1 allowed; track: trackpy and the OpenCV tracker "
                             "make min(3, N); model: fast methods more, in a time budget)")
    parser.add_argument("--warmup", type=int, default=1, metavar="N",
                        help="uncounted calls of each timed method before the counted ones "
                             "(default 1; 0: time cold calls)")
    stages = parser.add_argument_group("one throw's stages (vidtrack bench stages)")
    stages.add_argument("--run", default=None, metavar="RUN",
                        help="the run folder whose throw is timed (default: datasets/run42 "
                             "of this checkout), e.g. --run datasets/run42")
    stages.add_argument("--baseline", default=None, metavar="DIR",
                        help="the root of another vidtrack checkout, timed in the same "
                             "rounds, its k beside this one's, e.g. --baseline /tmp/main")
    real = parser.add_argument_group("the tracker scoreboard (vidtrack bench track --real)")
    real.add_argument("--real", action="store_true",
                      help="track: the scoreboard on real clips and synthetic distractor "
                           "scenes instead of the synthetic speed benchmark; with --quick "
                           "the slow clips (diabolo, badminton) are left out")
    real.add_argument("--engine", action="append", default=None, metavar="NAME",
                      help="with --real: a tracker engine to score, repeatable (default: "
                           "every engine of vidtrack.track.tracker.ENGINES, or 'rules'); "
                           "e.g. --engine rules --engine flight")
    real.add_argument("--clips", default=None, metavar="A,B",
                      help="with --real: only these clips, e.g. 'balltoss,launcher', "
                           "'synth:shadow' (both views), 'synth:shadow/front', or the "
                           "groups real, synth, bear, badminton (default: all)")
    real.add_argument("--shared", default=None, metavar="DIR",
                      help="with --real: the folder holding data/real (third-party "
                           "clips with their references), read in place; without it the "
                           "real clips are skipped, saying so; e.g. --shared /data/shared")


def run(args):
    import logging
    import sys

    from vidtrack.bench.run import RUNNERS

    log = logging.getLogger(__name__)

    def progress(name):
        log.info("%s: %s done", args.which, name)
        if (not args.quiet and sys.stderr.isatty()
                and not log.isEnabledFor(logging.INFO)):
            print(f"  {args.which}: {name} done", file=sys.stderr)

    from vidtrack.errors import VidtrackError

    if args.seeds is not None and (args.which not in ("fit", "perspective")
                                   or args.seeds < 1):
        raise VidtrackError("--seeds goes with 'vidtrack bench fit' or 'vidtrack bench "
                            "perspective' and must be >= 1")
    if args.repeats < 1 or args.warmup < 0:
        raise VidtrackError("--repeats must be >= 1 and --warmup >= 0")
    import importlib.util

    if args.which == "model" and importlib.util.find_spec("mpmath") is None:
        raise VidtrackError("vidtrack bench model measures against 50-digit truth and needs "
                            "mpmath: pip install 'vidtrack[bench]'")
    if args.which != "stages" and (args.run is not None or args.baseline is not None):
        raise VidtrackError("--run and --baseline go with 'vidtrack bench stages'")
    scoreboard = (args.engine, args.clips, args.shared)
    if not args.real and any(x is not None for x in scoreboard):
        raise VidtrackError("--engine, --clips and --shared go with 'vidtrack bench track "
                            "--real'")
    if args.real:
        if args.which != "track":
            raise VidtrackError(f"--real goes with 'vidtrack bench track', not "
                                f"'{args.which}'")
        from vidtrack.bench.run import bench_track_real

        print(bench_track_real(args.out, quick=args.quick, progress=progress,
                               engines=args.engine, clips=args.clips, shared=args.shared,
                               repeats=args.repeats, warmup=args.warmup))
        print(f"\nwritten to {args.out}/")
        return 0
    if args.coverage is not None and (args.which != "fit" or args.coverage < 1):
        raise VidtrackError("--coverage goes with 'vidtrack bench fit' and must be >= 1 "
                            f"throws, got {args.coverage}")
    extra = {"seeds": args.seeds} if args.which in ("fit", "perspective") else {}
    if args.which == "fit":
        extra["coverage"] = args.coverage
    if args.which == "stages":
        if args.quick:
            raise VidtrackError("--quick does not go with 'vidtrack bench stages' (one "
                                "throw; --repeats sets its length)")
        extra = {"run": args.run, "baseline": args.baseline}
    text = RUNNERS[args.which](args.out, quick=args.quick, progress=progress,
                               repeats=args.repeats, warmup=args.warmup, **extra)
    print(text)
    print(f"\nwritten to {args.out}/")
    return 0
