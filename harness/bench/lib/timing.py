"""Timing helpers: medians of repeats, on a shared and noisy machine."""

import os
import platform
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


def cpu_model():
    """The CPU's model name (``/proc/cpuinfo``, else :func:`platform.processor`), its logical core count and
    the architecture, as one string: ``AMD EPYC, 2 cores, x86_64``."""
    name = ""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            name = next((line.split(":", 1)[1].strip() for line in fh if line.startswith("model name")), "")
    except OSError:
        pass
    return f"{name or platform.processor() or 'unknown CPU'}, {os.cpu_count()} cores, {platform.machine()}"


def load_average():
    """The 1, 5 and 15 minute load averages (:func:`os.getloadavg`), or None where the system has none."""
    try:
        return tuple(round(x, 2) for x in os.getloadavg())
    except (AttributeError, OSError):
        return None
