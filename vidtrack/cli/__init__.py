"""The ``vidtrack`` command line: parse, call the library once, print or write.

Each subcommand is a module of this package with ``HELP`` (one line), ``DESCRIPTION``
(with an example), ``add_arguments(parser)`` and ``run(args) -> int``. Command modules
import heavy libraries inside ``run`` so that ``vidtrack --help`` stays fast.

Exit codes: 0 success, 2 bad usage or bad input (one line on stderr, no traceback),
1 internal error, 130 interrupted.
"""

import argparse
import importlib
import os
import sys

# One BLAS thread per process, set before numpy loads: vidtrack's matrices are small
# (hundreds of rows), where BLAS threads gain nothing, and the work is already spread
# over the cores by view and by run; threaded BLAS spinning on cores that the tracker
# or other runs hold slowed a fit from 0.4 s to 30 s. A user's own setting wins.
# The same for OpenCV's worker threads (read when cv2 loads): on the tracker's regions
# of interest they cost more than they give (a full-size view tracked in 1.8 s instead
# of 2.3 s without them); decoding does not use them.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS",
             "OPENCV_FOR_THREADS_NUM"):
    os.environ.setdefault(_var, "1")

#: Subcommands in the order ``vidtrack --help`` lists them (module names in this package).
COMMANDS = ("init", "fit", "report", "anova", "predict", "synth", "frames", "calibrate", "bench")


def _load(name):
    return importlib.import_module(f"vidtrack.cli.{name}")


def build_parser():
    """The top-level parser with every subcommand registered."""
    from vidtrack import __version__

    parser = argparse.ArgumentParser(
        prog="vidtrack",
        description="High-speed footage of a thrown straw to drag-model coefficients "
                    "k1..k4 and their response-surface ANOVA.",
        epilog="Run 'vidtrack COMMAND --help' for a command's options and an example.",
    )
    parser.add_argument("--version", action="version", version=f"vidtrack {__version__}")
    parser.add_argument("--debug", action="store_true",
                        help="show the full traceback of an internal error")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMANDS:
        module = _load(name)
        p = sub.add_parser(name, help=module.HELP, description=module.DESCRIPTION,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        p.add_argument("-q", "--quiet", action="store_true",
                       help="no progress bars and no chatter on stderr")
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


def main(argv=None):
    """Entry point of the ``vidtrack`` console script; returns the exit code."""
    from vidtrack.errors import INPUT_ERRORS

    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args._run(args) or 0)
    except INPUT_ERRORS as exc:
        print(f"vidtrack {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # the reader of the output went away (``| head``): nothing more to say
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except KeyboardInterrupt:
        print(f"vidtrack {args.command}: interrupted; no partial output was kept",
              file=sys.stderr)
        return 130
    except Exception as exc:  # an internal error: say so, keep the traceback on request
        if args.debug:
            raise
        print(f"vidtrack {args.command}: internal error: {type(exc).__name__}: {exc} "
              "(run with 'vidtrack --debug ...' for the traceback)", file=sys.stderr)
        return 1


def run():
    """The console script: :func:`main`, then exit without the interpreter's teardown.

    Every output is written and closed, and every worker stopped, before ``main``
    returns; what is left is freeing the loaded libraries' objects one by one (0.2 s of
    a 3 s fit), which the operating system does at once.
    """
    code = main()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):   # a closed pipe (``| head``): nothing more to say
            pass
    os._exit(code)


if __name__ == "__main__":  # pragma: no cover
    run()
