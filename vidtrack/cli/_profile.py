"""Profiling a command: ``vidtrack --profile FILE COMMAND ...`` and profilers round it.

``--profile FILE`` writes a cProfile of the command (``python -m pstats FILE``). The
console script ends with ``os._exit`` (:func:`vidtrack.cli.run`), which would also end
a profiler or a tracer round the command (``python -m cProfile -o F $(which vidtrack)
...``, coverage, a debugger) before it writes what it gathered: :func:`observed` says
when one is there, and the command then lets the interpreter finish.
"""

import contextlib
import sys

#: sys.monitoring's tool ids (Python 3.12+): a debugger, coverage, a profiler, and the
#: ids left for other tools (cProfile uses sys.monitoring from 3.12 on, not setprofile).
_MONITORING_TOOLS = range(6)


def observed():
    """True when a profiler, a tracer or a debugger watches this process."""
    if sys.getprofile() is not None or sys.gettrace() is not None:
        return True
    monitoring = getattr(sys, "monitoring", None)
    return monitoring is not None and any(monitoring.get_tool(i) is not None
                                          for i in _MONITORING_TOOLS)


def check_profile_path(path, *, inputs=()):
    """Refuse a ``--profile`` path before any work: an input of the command, a folder,
    an unwritable place, or an existing file that is not a profile (one of the
    command's input files, say); an earlier profile is replaced."""
    from pathlib import Path

    from vidtrack._atomic import check_output
    from vidtrack.errors import VidtrackError

    label = f"--profile {path}"
    check_output(path, inputs=inputs, label=label)
    if Path(path).is_file() and Path(path).stat().st_size > 0:
        import pstats

        try:
            pstats.Stats(str(path))
        except Exception:      # noqa: BLE001 (whatever it is, it is not a profile)
            raise VidtrackError(f"{label}: exists and is not a profile (cProfile's "
                                "statistics); expected a new file name or an earlier "
                                "profile to replace") from None


@contextlib.contextmanager
def profiled(path):
    """cProfile what runs inside, the statistics written to ``path`` on the way out.

    Written whole or not at all, also when the command fails or is interrupted (its
    profile is then of what ran); ``path`` None profiles nothing.
    """
    if path is None:
        yield
        return
    import cProfile

    from vidtrack._atomic import atomic_path

    profiler = cProfile.Profile()
    profiler.enable()
    try:
        yield
    finally:
        profiler.disable()
        with atomic_path(path) as tmp:
            profiler.dump_stats(tmp)
