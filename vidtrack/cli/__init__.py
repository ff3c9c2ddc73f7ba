"""The ``vidtrack`` command line: parse, call the library once, print or write.

Each subcommand is a module of this package with ``HELP`` (one line), ``DESCRIPTION``
(with an example), ``add_arguments(parser)`` and ``run(args) -> int``. Command modules
import heavy libraries inside ``run`` so that ``vidtrack --help`` stays fast.

Exit codes: 0 success, 2 bad usage or bad input (one line on stderr, no traceback) or
a full disk (``no space left on device writing X``), 1 internal error, 130 interrupted.

Messages: the library logs under the ``vidtrack``, ``fits`` and ``calibration`` loggers;
:func:`main` puts one handler on stderr for them (``vidtrack COMMAND: warning: ...``),
at WARNING by default, INFO with ``-v``, DEBUG with ``-vv`` and ERROR with ``-q``
(which also turns the progress bars off). ``-v`` and ``-q`` go before or after the
command: ``vidtrack -v fit RUN`` and ``vidtrack fit RUN -v`` are the same.

Profiling: ``vidtrack --profile FILE COMMAND ...`` writes a cProfile of any command
(:mod:`vidtrack.cli._profile`; ``vidtrack fit`` takes it after the command too), and
``python -m cProfile -o FILE $(which vidtrack) COMMAND ...`` works as well.
"""

import argparse
import importlib
import logging
import os
import sys

from vidtrack import LOGGERS  # the loggers configure_logging sets (re-exported)
from vidtrack._text import printable

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
COMMANDS = ("design", "init", "view", "fit", "overlay", "report", "anova", "predict", "synth",
            "score", "frames", "calibrate", "bench")


def _load(name):
    return importlib.import_module(f"vidtrack.cli.{name}")


def add_common_options(parser, *, level=1):
    """``-q/--quiet`` and ``-v/--verbose`` on a (sub)parser.

    ``level`` 0 is the top-level parser (it holds the defaults: not quiet, verbosity 0);
    deeper parsers (a command, a command's mode) set the options only when given
    (``argparse.SUPPRESS``), so that ``vidtrack -q fit RUN`` is not undone by the
    command's own default. Each level counts its ``-v`` apart (argparse copies a
    subparser's values over its parent's); :func:`verbosity` adds them up.
    """
    top = level == 0
    parser.add_argument("-q", "--quiet", action="store_true",
                        default=False if top else argparse.SUPPRESS,
                        help="no progress bars and no chatter on stderr (errors only)")
    parser.add_argument("-v", "--verbose", action="count",
                        dest="verbose" if top else f"_verbose_{level}",
                        default=0 if top else argparse.SUPPRESS,
                        help="say more on stderr: -v what is being done, -vv details")


def verbosity(args):
    """The number of ``-v`` given before and after the command."""
    return sum(v for k, v in vars(args).items()
               if k == "verbose" or k.startswith("_verbose_"))


class _StderrHandler(logging.StreamHandler):
    """A stream handler writing to the current ``sys.stderr`` (as tests capture it)."""

    @property
    def stream(self):
        return sys.stderr

    @stream.setter
    def stream(self, value):
        pass


class CliFormatter(logging.Formatter):
    """``vidtrack COMMAND: [LABEL: ]message``, the command line's stderr style.

    The label is ``warning``, ``error``, ``debug``, none for INFO, or the record's own
    ``label`` (``log.warning(msg, extra={"label": "note"})``); DEBUG records name their
    logger.
    """

    LABELS = {logging.DEBUG: "debug", logging.WARNING: "warning", logging.ERROR: "error",
              logging.CRITICAL: "error"}

    def __init__(self, command):
        super().__init__()
        self.prefix = f"vidtrack {command}: " if command else "vidtrack: "

    def format(self, record):
        label = getattr(record, "label", None) or self.LABELS.get(record.levelno)
        text = self.prefix + (f"{label}: " if label else "")
        if record.levelno <= logging.DEBUG:
            text += f"[{record.name}] "
        text += printable(record.getMessage())     # one line, whatever names it holds
        if record.exc_info:
            text += "\n" + self.formatException(record.exc_info)
        return text


def configure_logging(command=None, *, verbose=0, quiet=False):
    """One stderr handler on the ``vidtrack``, ``fits`` and ``calibration`` loggers.

    Level: ERROR with ``quiet``, else WARNING, INFO (``verbose=1``) or DEBUG (2 or
    more). Calling it again replaces the handler (no duplicate lines).

    Returns
    -------
    logging.Handler
        The handler installed.
    """
    level = (logging.ERROR if quiet else logging.WARNING if verbose <= 0 else
             logging.INFO if verbose == 1 else logging.DEBUG)
    handler = _StderrHandler()
    handler.setFormatter(CliFormatter(command))
    handler._vidtrack_cli = True
    for name in LOGGERS:
        logger = logging.getLogger(name)
        for old in [h for h in logger.handlers if getattr(h, "_vidtrack_cli", False)]:
            logger.removeHandler(old)
        logger.addHandler(handler)
        logger.setLevel(level)
    return handler


class _Parser(argparse.ArgumentParser):
    """argparse with one line for a usage error, as for any other bad input.

    ``vidtrack fit: error: unrecognized arguments: --bogus (see 'vidtrack fit --help')``
    instead of the usage block (up to 27 lines) and the message; exit code 2.
    Subcommands' parsers are of this class too (argparse makes them of the parent's).
    """

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def build_parser():
    """The top-level parser with every subcommand registered."""
    from vidtrack import __version__

    parser = _Parser(
        prog="vidtrack",
        description="High-speed footage of a thrown straw to drag-model coefficients "
                    "k1..k4 and their response-surface ANOVA.",
        epilog="Run 'vidtrack COMMAND --help' for a command's options and an example.",
    )
    parser.add_argument("--version", action="version", version=f"vidtrack {__version__}")
    parser.add_argument("--debug", action="store_true",
                        help="show the full traceback of an internal error")
    parser.add_argument("--profile", metavar="FILE", default=None,
                        help="write a cProfile of the command to FILE (read it with "
                             "python -m pstats FILE); it covers this process only, not "
                             "the worker processes a command starts, e.g. vidtrack "
                             "--profile report.prof report exp2016/")
    add_common_options(parser, level=0)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMANDS:
        module = _load(name)
        p = sub.add_parser(name, help=module.HELP, description=module.DESCRIPTION,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        add_common_options(p, level=1)
        module.add_arguments(p)
        p.set_defaults(_run=module.run,
                       _profiles_itself=getattr(module, "PROFILES_ITSELF", False))
    return parser


def main(argv=None):
    """Entry point of the ``vidtrack`` console script; returns the exit code."""
    from vidtrack.errors import INPUT_ERRORS

    parser = build_parser()
    args = parser.parse_args(argv)
    args.verbose = verbosity(args)
    for key in [k for k in vars(args) if k.startswith("_verbose_")]:
        delattr(args, key)
    configure_logging(args.command, verbose=args.verbose, quiet=args.quiet)
    try:
        if args.profile is None or args._profiles_itself:
            return int(args._run(args) or 0)
        from vidtrack.cli._profile import check_profile_path, profiled

        check_profile_path(args.profile)
        with profiled(args.profile):
            return int(args._run(args) or 0)
    except INPUT_ERRORS as exc:
        # one line whatever the names in it hold (a newline, a terminal's escapes)
        print(f"vidtrack {args.command}: error: {printable(exc)}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # the reader of the output went away (``| head``): nothing more to say
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except KeyboardInterrupt:
        print(f"vidtrack {args.command}: interrupted; no partial output was kept",
              file=sys.stderr)
        return 130
    except OSError as exc:
        from vidtrack._atomic import disk_full

        full = disk_full(exc)
        if full is None:
            return _internal(args, exc)
        print(f"vidtrack {args.command}: error: {printable(full)}", file=sys.stderr)
        return 2
    except Exception as exc:  # an internal error: say so, keep the traceback on request
        return _internal(args, exc)


def _internal(args, exc):
    """Exit code 1 for an internal error: one line, the traceback with ``--debug``."""
    if args.debug:
        raise exc
    print(f"vidtrack {args.command}: internal error: {type(exc).__name__}: {printable(exc)} "
          "(run with 'vidtrack --debug ...' for the traceback)", file=sys.stderr)
    return 1


def run():
    """The console script: :func:`main`, then exit without the interpreter's teardown.

    Every output is written and closed, and every worker stopped, before ``main``
    returns; what is left is freeing the loaded libraries' objects one by one (0.2 s of
    a 3 s fit), which the operating system does at once. Under a profiler or a tracer
    (``python -m cProfile -o F $(which vidtrack) ...``, coverage, a debugger; through
    ``sys.setprofile``/``sys.settrace`` or, from Python 3.12, ``sys.monitoring``, which
    cProfile uses there) the exit code is returned instead, so that the interpreter
    finishes and they write what they gathered.
    """
    from vidtrack.cli._profile import observed

    code = main()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):   # a closed pipe (``| head``): nothing more to say
            pass
    if observed():
        return code
    os._exit(code)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(run())
