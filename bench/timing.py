"""Timing helper shared by the benchmark scripts."""

import time

import numpy as np


def median(fn, repeat: int) -> float:
    """Median wall time of `repeat` calls of fn, in seconds."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))
