"""Timing helper shared by the benchmark applications (medians, never timed tests)."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable


def median_us(
    fn: Callable[[], object],
    repeats: int,
    per: int = 1,
    clock: Callable[[], float] = time.perf_counter,
) -> float:
    """Median over ``repeats`` calls of ``fn``, divided by ``per`` states per call [us]
    (``clock``: wall-clock time by default; ``time.process_time`` for the process's CPU
    time, all its threads)."""
    fn()  # warm-up
    times = []
    for _ in range(repeats):
        t0 = clock()
        fn()
        times.append(clock() - t0)
    return statistics.median(times) / per * 1e6
