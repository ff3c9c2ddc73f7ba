"""Timing that tolerates a shared, noisy machine: warm, repeated calls, CPU and wall.

:func:`timed` calls a function once uncounted (the warm-up: imports, caches, files in
the page cache), then a number of counted times, and keeps the min and the median of
each call's CPU time and wall time. :func:`timed_each` does the same for several
functions, interleaved round by round (A B C, A B C, ...), so that other work on the
machine slows each of them alike and their ratios hold.

CPU time is the process's own (every thread: OpenCV's, a thread pool's) plus that of
its child processes that ended during the call (``resource.getrusage`` of
``RUSAGE_SELF`` and ``RUSAGE_CHILDREN``; where the ``resource`` module is missing, the
process's own through :func:`time.process_time`). It counts what the work costs
whatever else the machine runs; wall time counts what a user waits.
"""

import dataclasses
import statistics
import time

__all__ = ["Timing", "cpu_seconds", "timed", "timed_each"]

try:
    import resource
except ImportError:                                      # not on Windows
    resource = None


def cpu_seconds():
    """CPU seconds (user + system) used so far by this process and its ended children."""
    if resource is None:
        return time.process_time()
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


@dataclasses.dataclass(frozen=True)
class Timing:
    """The counted calls of one function.

    Attributes
    ----------
    result : object
        What the last call returned.
    calls : int
        Calls counted (the warm-up not among them).
    cpu_s, wall_s : tuple of float
        CPU and wall seconds of each counted call, in order.
    """

    result: object
    calls: int
    cpu_s: tuple
    wall_s: tuple

    @property
    def cpu_min_s(self):
        return min(self.cpu_s) if self.cpu_s else float("nan")

    @property
    def cpu_median_s(self):
        return statistics.median(self.cpu_s) if self.cpu_s else float("nan")

    @property
    def wall_min_s(self):
        return min(self.wall_s) if self.wall_s else float("nan")

    @property
    def wall_median_s(self):
        return statistics.median(self.wall_s) if self.wall_s else float("nan")

    def columns(self, prefix=""):
        """``{prefix}cpu_min_s``, ``..cpu_median_s``, ``..wall_min_s``,
        ``..wall_median_s`` and ``..calls`` (a dict, for a table's row)."""
        return {f"{prefix}cpu_min_s": self.cpu_min_s,
                f"{prefix}cpu_median_s": self.cpu_median_s,
                f"{prefix}wall_min_s": self.wall_min_s,
                f"{prefix}wall_median_s": self.wall_median_s,
                f"{prefix}calls": self.calls}


def _one_call(fn):
    c0, w0 = cpu_seconds(), time.perf_counter()
    result = fn()
    w1, c1 = time.perf_counter(), cpu_seconds()
    return result, c1 - c0, w1 - w0


def _check(repeats, warmup):
    if repeats < 1 or warmup < 0:
        raise ValueError(f"repeats must be >= 1 and warmup >= 0, not {repeats} and {warmup}")


def timed(fn, *, repeats=3, warmup=1, budget_s=0.0, max_repeats=None):
    """Time ``fn()``: ``warmup`` calls uncounted, then ``repeats`` counted calls.

    With ``budget_s``, counted calls go on past ``repeats`` while their wall time
    together is under ``budget_s`` (and fewer than ``max_repeats`` were made), so a
    method of microseconds is measured many times and a slow one ``repeats`` times.

    Returns
    -------
    Timing
    """
    _check(repeats, warmup)
    result = None
    for _ in range(warmup):
        result = fn()
    cpu, wall = [], []
    limit = max(repeats, max_repeats or repeats)
    while len(wall) < limit and (len(wall) < repeats or sum(wall) < budget_s):
        result, c, w = _one_call(fn)
        cpu.append(c)
        wall.append(w)
    return Timing(result, len(wall), tuple(cpu), tuple(wall))


def timed_each(fns, *, repeats=3, warmup=1):
    """Time several functions in turn, round by round: ``{name: Timing}``.

    ``fns`` maps names to functions of no argument. Each round calls every function once,
    in the order given; the first ``warmup`` rounds are not counted, the next ``repeats``
    are.
    """
    _check(repeats, warmup)
    results = {name: None for name in fns}
    cpu = {name: [] for name in fns}
    wall = {name: [] for name in fns}
    for _ in range(warmup):
        for name, fn in fns.items():
            results[name] = fn()
    for _ in range(repeats):
        for name, fn in fns.items():
            results[name], c, w = _one_call(fn)
            cpu[name].append(c)
            wall[name].append(w)
    return {name: Timing(results[name], repeats, tuple(cpu[name]), tuple(wall[name]))
            for name in fns}
