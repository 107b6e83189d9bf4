"""Timing helper shared by the benchmark applications (medians, never timed tests)."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable


def median_us(fn: Callable[[], object], repeats: int, per: int = 1) -> float:
    """Median over ``repeats`` calls of ``fn``, divided by ``per`` states per call [us]."""
    fn()  # warm-up
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times) / per * 1e6
