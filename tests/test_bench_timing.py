"""vidtrack.bench._timing against what the clock and the kernel say, not the code.

A sleep takes its wall time and almost no CPU; a busy loop takes as much CPU as wall
time; a child process's CPU is counted; the warm-up is not; the functions of
timed_each run round by round.
"""

import subprocess
import sys
import time

import pytest

from vidtrack.bench._timing import Timing, timed, timed_each

#: A child process that spins for about 0.15 s of CPU.
CHILD_SPIN = "import time\nt = time.process_time()\nwhile time.process_time() - t < 0.15: pass"


def _spin(seconds):
    t = time.process_time()
    n = 0
    while time.process_time() - t < seconds:
        n += 1
    return n


def test_a_sleep_is_wall_time_not_cpu():
    t = timed(lambda: time.sleep(0.05), repeats=2, warmup=0)
    assert t.calls == 2 and len(t.wall_s) == len(t.cpu_s) == 2
    assert t.wall_min_s >= 0.05
    assert t.cpu_median_s < 0.2 * t.wall_median_s


def test_a_busy_loop_is_cpu_and_wall_alike():
    t = timed(lambda: _spin(0.1), repeats=1, warmup=0)
    assert t.result > 0
    assert t.cpu_min_s == pytest.approx(0.1, abs=0.05)
    # the machine may be shared: wall time is at least the CPU time, within a loose bound
    assert 0.9 * t.cpu_min_s <= t.wall_min_s < 10 * t.cpu_min_s


def test_a_child_process_is_counted_in_cpu():
    t = timed(lambda: subprocess.run([sys.executable, "-c", CHILD_SPIN], check=True),
              repeats=1, warmup=0)
    assert t.cpu_min_s >= 0.12


def test_warm_up_calls_are_not_counted():
    calls = []
    t = timed(lambda: calls.append(1) or len(calls), repeats=3, warmup=2)
    assert len(calls) == 5 and t.calls == 3 and len(t.wall_s) == 3
    assert t.result == 5                                  # the last call's
    t = timed(lambda: calls.append(1), repeats=1, warmup=0)
    assert len(calls) == 6 and t.calls == 1


def test_a_budget_adds_calls_up_to_max_repeats():
    calls = []
    t = timed(lambda: calls.append(1), repeats=2, warmup=1, budget_s=10.0, max_repeats=7)
    assert t.calls == 7 and len(calls) == 8
    t = timed(lambda: time.sleep(0.02), repeats=2, warmup=0, budget_s=0.01, max_repeats=9)
    assert t.calls == 2


def test_timed_each_interleaves_round_by_round():
    order = []
    fns = {name: (lambda name=name: order.append(name) or name) for name in "abc"}
    out = timed_each(fns, repeats=2, warmup=1)
    assert order == list("abc") * 3
    assert list(out) == ["a", "b", "c"]
    assert all(isinstance(t, Timing) and t.calls == 2 and t.result == n
               for n, t in out.items())
    order.clear()
    timed_each(fns, repeats=1, warmup=0)
    assert order == list("abc")


def test_min_and_median_of_the_counted_calls():
    t = Timing(None, 3, (0.3, 0.1, 0.2), (1.0, 3.0, 2.0))
    assert (t.cpu_min_s, t.cpu_median_s, t.wall_min_s, t.wall_median_s) == (0.1, 0.2, 1.0, 2.0)
    assert t.columns("x_") == {"x_cpu_min_s": 0.1, "x_cpu_median_s": 0.2,
                               "x_wall_min_s": 1.0, "x_wall_median_s": 2.0, "x_calls": 3}


@pytest.mark.parametrize("repeats, warmup", [(0, 1), (1, -1)])
def test_no_counted_call_is_refused(repeats, warmup):
    with pytest.raises(ValueError):
        timed(lambda: None, repeats=repeats, warmup=warmup)
    with pytest.raises(ValueError):
        timed_each({"a": lambda: None}, repeats=repeats, warmup=warmup)
