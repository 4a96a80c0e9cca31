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


class fused_on:
    """``with fused_on():`` the compiled co-step (mjbench/backends/fused.py) for the runs inside,
    forced (MJBENCH_FUSED=1, MJBENCH_JIT=1), then the previous settings back (scripts/bench.py
    measures the Python kernel by default)."""

    KEYS = ("MJBENCH_FUSED", "MJBENCH_JIT")

    def __enter__(self):
        import os
        self._old = {k: os.environ.get(k) for k in self.KEYS}
        os.environ.update({k: "1" for k in self.KEYS})

    def __exit__(self, *exc):
        import os
        for k, v in self._old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
