"""Timing that tolerates a shared, noisy machine: the median of repeats in a budget."""

import statistics
import time


def median_time(fn, *, budget_s=0.3, max_repeats=25, min_repeats=1):
    """Median wall time of ``fn()`` in seconds, and its last result.

    Repeats until ``budget_s`` is spent or ``max_repeats`` runs were made (at least
    ``min_repeats``), so slow methods run once and fast ones are measured many times.
    """
    times, result = [], None
    start = time.perf_counter()
    while len(times) < max_repeats:
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
        if len(times) >= min_repeats and time.perf_counter() - start > budget_s:
            break
    return statistics.median(times), result
