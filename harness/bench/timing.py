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


def median_times_interleaved(fns, repeats=5, warmup=1):
    """Median wall times [s] of several callables timed in turn (A, B, A, B, ...), so that a drift of the
    machine's speed (another process, the clock) falls on all of them alike.  Returns a list of medians."""
    for _ in range(warmup):
        for fn in fns:
            fn()
    times = [[] for _ in fns]
    for _ in range(repeats):
        for i, fn in enumerate(fns):
            t0 = time.perf_counter()
            fn()
            times[i].append(time.perf_counter() - t0)
    return [statistics.median(t) for t in times]
