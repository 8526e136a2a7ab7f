#!/usr/bin/env python3
"""The spread of many warm Newton iterations on the 19k-vertex bunny.

bench/benchlib/elastic_scenes.py's bunny_snh scene, ``minimizeEnergy`` (CG relative residual
1e-4) called ``--calls`` times after three warm-up calls: per stage
(derivatives, indices, assembly, solve) and in total, the median, the 90th
percentile and the slowest call, and the minor page faults each call took
(a warm loop allocates nothing: any fault is a fresh buffer). Slow
outliers, where they exist, show as a maximum far above the median.

``--threads 1 2`` times several thread counts side by side: each round
makes one call per count, so a shared machine's swings reach all of them,
and prints each count's table and its speed-up over the first count.

``--sorted-tets`` numbers the tets by their smallest and largest vertex
first (the mesher's numbering otherwise): assembly then writes nearby
blocks one after another.

    python3 bench/newton_calls.py [--calls 60] [--threads 1 [2 ...]]
        [--sorted-tets] [--preconditioner block-jacobi|multilevel]
"""

from __future__ import annotations

import argparse
import os
import resource
import tempfile
import time
from pathlib import Path

os.environ.setdefault("YASPS_CACHE_DIR", tempfile.mkdtemp(prefix="yasps-bench-"))
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

HERE = Path(__file__).resolve().parent
import benchlib  # noqa: E402

benchlib.use_this_checkout()

import numpy as np  # noqa: E402

import yasps  # noqa: E402
from benchlib.meshes import bunny  # noqa: E402
from benchlib.elastic_scenes import bunny_snh, snh_scene  # noqa: E402

STAGES = ("derivatives", "indices", "assembly", "solve")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--calls", type=int, default=60)
    parser.add_argument("--threads", type=int, nargs="+", default=[1])
    parser.add_argument("--sorted-tets", action="store_true")
    parser.add_argument("--preconditioner", default="block-jacobi",
                        choices=yasps.config.PRECONDITIONERS)
    args = parser.parse_args()
    yasps.config.preconditioner = args.preconditioner
    if args.sorted_tets:
        # snh_scene is bunny_snh's scene for any mesh.
        verts, tets = bunny("19k")
        tets = tets[np.lexsort((tets.max(axis=1), tets.min(axis=1)))]
        s = snh_scene("bunny_sorted", verts, tets, 1e-4)
    else:
        s = bunny_snh()
    for threads in args.threads:
        for _ in range(3):
            s.minimizeEnergy(tolerance=1e-4, threads=threads)
    rows: dict[int, list[list[float]]] = {t: [] for t in args.threads}
    for _ in range(args.calls):
        for threads in args.threads:
            rows[threads].append(timed_call(s, threads))
    names = (("total (ms)",) + tuple(f"{k} (ms)" for k in STAGES)
             + ("page faults",))
    first = np.array(rows[args.threads[0]])
    for threads in args.threads:
        table = np.array(rows[threads])
        print(f"{args.calls} warm minimizeEnergy calls, {threads} thread(s), "
              f"{args.preconditioner}, tets "
              f"{'sorted by vertex' if args.sorted_tets else 'as meshed'}")
        print("| stage | median | 90th percentile | slowest | speed-up (medians) |")
        print("|---|---|---|---|---|")
        for column, name in enumerate(names):
            values = table[:, column]
            median = np.median(values)
            ratio = (f"{np.median(first[:, column]) / median:.2f}x"
                     if column < len(names) - 1 and median > 0 else "")
            print(f"| {name} | {median:.1f} | {np.percentile(values, 90):.1f} | "
                  f"{values.max():.1f} | {ratio} |")


def timed_call(s, threads: int) -> list[float]:
    """One minimizeEnergy call: total and per-stage milliseconds, page faults."""
    faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    start = time.perf_counter()
    s.minimizeEnergy(tolerance=1e-4, threads=threads)
    total = time.perf_counter() - start
    faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - faults
    seconds = s.lastSolve["seconds"]
    return [total * 1e3] + [seconds[k] * 1e3 for k in STAGES] + [faults]

if __name__ == "__main__":
    main()
