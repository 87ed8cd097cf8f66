"""Timing helpers: medians of repeats, on a shared and noisy machine."""

import statistics
import time


def median_time(fn, repeats=5, warmup=1):
    """Median wall time [s] of ``fn()`` over ``repeats`` calls after ``warmup`` calls.

    Returns (median, all times).
    """
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), times
