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
and prints each count's table and its speed-up over the first count, then
the counts side by side (``calls``: median, 90th percentile and slowest
call of the first count, median and slowest of the others) and their
medians' speed-ups (``speedup``).

``--sorted-tets`` numbers the tets by their smallest and largest vertex
first (the mesher's numbering otherwise): assembly then writes nearby
blocks one after another.

The tables go to --json (default bench/results/newton_calls.json):
``threads_<n>`` per thread count as printed, ``calls`` and ``speedup``.

    python3 bench/newton_calls.py [--calls 60] [--threads 1 [2 ...]]
        [--sorted-tets] [--preconditioner block-jacobi|multilevel]
        [--json PATH]
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
from benchlib.timing import at_new_point  # noqa: E402
from benchlib.results import Results, add_json_argument  # noqa: E402
from benchlib.tables import markdown  # noqa: E402
from benchlib.elastic_scenes import bunny_snh, snh_scene  # noqa: E402

STAGES = ("derivatives", "indices", "assembly", "solve")
#: The measures of a call, in timed_call's order: (row label, label in the
#: tables across thread counts).
MEASURES = (("total (ms)", "total"),) + tuple(
    (f"{k} (ms)", k) for k in STAGES) + (("page faults", "page faults per call"),)


def threads_label(threads: int) -> str:
    return f"{threads} thread" + ("" if threads == 1 else "s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--calls", type=int, default=60)
    parser.add_argument("--threads", type=int, nargs="+", default=[1])
    parser.add_argument("--sorted-tets", action="store_true")
    parser.add_argument("--preconditioner", default="block-jacobi",
                        choices=yasps.config.PRECONDITIONERS)
    add_json_argument(parser, "newton_calls")
    args = parser.parse_args()
    results = Results("newton_calls")
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
    setting = (f"{args.calls} warm minimizeEnergy calls, {args.preconditioner}, "
               f"tets {'sorted by vertex' if args.sorted_tets else 'as meshed'}")
    results.values.update(calls=args.calls, threads=args.threads,
                          preconditioner=args.preconditioner,
                          sorted_tets=args.sorted_tets,
                          per_call={str(t): rows[t] for t in args.threads},
                          per_call_columns=[m[0] for m in MEASURES])
    # Per thread count and measure: median, 90th percentile, slowest.
    stats = {t: [(float(np.median(column)), float(np.percentile(column, 90)),
                  float(column.max()))
                 for column in np.array(rows[t]).T] for t in args.threads}
    first = args.threads[0]
    speedups = {t: [stats[first][k][0] / stats[t][k][0]
                    if stats[t][k][0] > 0 else None
                    for k in range(len(MEASURES) - 1)] + [None]
                for t in args.threads}
    for threads in args.threads:
        print(f"{args.calls} warm minimizeEnergy calls, {threads} thread(s), "
              f"{args.preconditioner}, tets "
              f"{'sorted by vertex' if args.sorted_tets else 'as meshed'}")
        table = results.table(
            f"threads_{threads}",
            ["stage", "median", "90th percentile", "slowest",
             "speed-up (medians)"],
            [[name, *stats[threads][k], speedups[threads][k]]
             for k, (name, _) in enumerate(MEASURES)],
            ["", "{:.1f}", "{:.1f}", "{:.1f}", "{:.2f}x"],
            f"{setting}, {threads} thread(s); speed-up: the median of "
            f"{threads_label(first)} over this one's.")
        print(markdown(table))

    # The thread counts side by side: the first count's median, 90th
    # percentile and slowest call, the others' median and slowest.
    columns = ["stage (ms)"]
    for threads in args.threads:
        columns += ([f"{threads_label(threads)}: median", "90th percentile",
                     "slowest"] if threads == first else
                    [f"{threads_label(threads)}: median", "slowest"])
    calls = results.table(
        "calls", columns,
        [[label] + [v for t in args.threads
                    for v in (stats[t][k] if t == first else
                              (stats[t][k][0], stats[t][k][2]))]
         for k, (_, label) in enumerate(MEASURES)],
        [""] + ["{:.1f}"] * (len(columns) - 1),
        f"{setting}; the thread counts take turns, one call each per round.")
    print()
    print(markdown(calls))
    if len(args.threads) > 1:
        others = args.threads[1:]
        columns = (["stage"] + [f"{threads_label(t)} (median)"
                                for t in args.threads]
                   + ["speed-up" if len(others) == 1 else
                      f"speed-up, {threads_label(t)}" for t in others])
        speedup = results.table(
            "speedup", columns,
            [[label] + [stats[t][k][0] for t in args.threads]
             + [speedups[t][k] for t in others]
             for k, (_, label) in enumerate(MEASURES[:-1])],
            [""] + ["{:.1f} ms"] * len(args.threads) + ["{:.2f}x"] * len(others),
            f"{setting}; speed-up: the median of {threads_label(first)} over "
            "the other count's.")
        print()
        print(markdown(speedup))
    path = results.write(args.json)
    print(f"results: {path}")


def timed_call(s, threads: int) -> list[float]:
    """One minimizeEnergy call: total and per-stage milliseconds, page faults."""
    at_new_point(s)
    faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    start = time.perf_counter()
    s.minimizeEnergy(tolerance=1e-4, threads=threads)
    total = time.perf_counter() - start
    faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - faults
    seconds = s.lastSolve["seconds"]
    return [total * 1e3] + [seconds[k] * 1e3 for k in STAGES] + [faults]


if __name__ == "__main__":
    main()
