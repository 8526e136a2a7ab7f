"""Timing helper shared by the benchmark scripts."""

import time

import numpy as np


def per_call(fn, repeat: int, finish=lambda result: None) -> float:
    """Seconds per call of fn over `repeat` back-to-back calls after a
    warm-up call. `finish(result)` waits for work that fn only queued (on a
    GPU) after the warm-up and after the last call."""
    finish(fn())
    start = time.perf_counter()
    result = None
    for _ in range(repeat):
        result = fn()
    finish(result)
    return (time.perf_counter() - start) / repeat


def median(fn, repeat: int) -> float:
    """Median wall time of `repeat` calls of fn, in seconds."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def at_new_point(scene) -> None:
    """Makes the next ``minimizeEnergy`` of ``scene`` compute the local
    derivatives again, as at a new point: the targets' values are written
    back unchanged, which gives them new versions (an assembly at the point
    of the last one reuses its derivatives, so timing repeated calls at
    one point would time no derivatives)."""
    for target in scene.minimizeTargets:
        target.updateValue(target.value)
