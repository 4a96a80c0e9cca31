"""Benchmark parts discovered by scripts/bench.py: each module defines run(args) -> [(name, value, desc)]."""
import time


def best_time(fn, repeat, clock=time.perf_counter):
    """Minimum wall (or given clock) time of ``repeat`` calls of fn [s]."""
    best = float("inf")
    for _ in range(max(1, repeat)):
        t0 = clock()
        fn()
        best = min(best, clock() - t0)
    return best
