#!/usr/bin/env python3
"""f32 against f64 derivative kernels on the CPU, one thread.

For every energy of ``bench/benchlib/energy_cases.py`` (or those named with
``--cases``) the gradient, Hessian and projected-Hessian kernels are
compiled from the scene in f64 and in f32 (``yasps.config.precision``; each
with its default SIMD width: twice the lanes in f32), timed alternately on
the same instances, and compared. Prints per kernel the time per instance
in f64 and f32, the speed-up, and the f32 result's largest error relative to
the largest f64 entry.

With ``--newton``, also one Newton iteration (``minimizeEnergy``) on the
19k-vertex bunny of ``bench/newton_system.py`` in each precision, timed in
turns: the median time per stage, the speed-up and the directions'
relative difference.

The tables go to --json (default bench/results/precision.json):
``kernels`` (per energy and kernel, f64 / f32 ns per instance and the
speed-up), ``errors`` (f32's error per kernel) and with --newton
``newton`` (per stage) and ``newton_direction``.

    python3 bench/precision.py [--count 20000] [--repeat 7] [--cases snh]
                               [--newton] [--json PATH]
"""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

os.environ.setdefault("YASPS_CACHE_DIR", tempfile.mkdtemp(prefix="yasps-bench-"))
HERE = Path(__file__).resolve().parent
import benchlib  # noqa: E402

benchlib.use_this_checkout()

import numpy as np  # noqa: E402

import yasps  # noqa: E402
from benchlib.energy_cases import CASES  # noqa: E402
from benchlib.timing import at_new_point  # noqa: E402
from benchlib.results import Results, add_json_argument  # noqa: E402
from benchlib.elastic_scenes import bunny_snh as bunny_scene  # noqa: E402

KERNELS = ("grad", "hess", "hess_proj")
PRECISIONS = ("f64", "f32")


def alternate(launches, repeat: int):
    """Median seconds of each launch, timed in turns so that both
    precisions see the same machine."""
    import time
    times = [[] for _ in launches]
    for _ in range(repeat):
        for k, launch in enumerate(launches):
            t0 = time.perf_counter()
            launch()
            times[k].append(time.perf_counter() - t0)
    return [float(np.median(t)) for t in times]


#: The kernels' names in the tables.
KERNEL_NAMES = {"grad": "gradient", "hess": "Hessian",
                "hess_proj": "projected Hessian"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=20000)
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--newton", action="store_true",
                        help="also time a Newton iteration on the bunny")
    parser.add_argument("--cases", default="",
                        help="only energies whose name contains this text "
                             "(e.g. 'Neo-Hookean')")
    add_json_argument(parser, "precision")
    args = parser.parse_args()
    results = Results("precision")
    results.values.update(count=args.count, repeat=args.repeat,
                          cases=args.cases)
    n = args.count
    title = (f"{n} instances, one thread, median of {args.repeat}; time per "
             f"instance f64 / f32 (speed-up)")
    print(f"{title}, f32's largest error relative to the largest f64 entry")
    print(f"{'energy':34s}" + "".join(f"{k:>36s}" for k in KERNELS))
    # Per energy: a cell {"f64": ns, "f32": ns, "speedup": f64 / f32} per
    # kernel, and f32's error per kernel.
    times, errors = [], []
    for case in CASES:
        if args.cases.lower() not in case.name.lower():
            continue
        energy = case.build(case.instances(n))
        launches, outputs = {}, {}
        for precision in PRECISIONS:
            yasps.config.precision = precision
            energy.scene.precision = precision
            _, _, calls = energy.kernels(list(KERNELS))
            for name, call in zip(KERNELS, calls):
                call()
                launches[precision, name] = call
                # The launch's buffers (its next-to-last argument), the
                # output first.
                outputs[precision, name] = call.args[-2][0].copy()
        yasps.config.precision = "f64"
        cells, errs = [], []
        for name in KERNELS:
            t64, t32 = alternate([launches["f64", name],
                                  launches["f32", name]], args.repeat)
            want, got = outputs["f64", name], outputs["f32", name]
            errs.append(float(np.abs(got - want).max() / np.abs(want).max()))
            cells.append({"f64": t64 * 1e9 / n, "f32": t32 * 1e9 / n,
                          "speedup": t64 / t32})
        times.append([case.name] + cells)
        errors.append([case.name] + errs)
        print(f"{case.name:34s}" + "".join(
            f"{c['f64']:7.0f} /{c['f32']:6.0f} ns ({c['speedup']:4.2f}x) "
            f"{e:7.1e}".rjust(36) for c, e in zip(cells, errs)), flush=True)
    columns = ["energy (parameters)"] + [KERNEL_NAMES[k] for k in KERNELS]
    results.table("kernels", columns, times,
                  [""] + ["{0[f64]:.0f} / {0[f32]:.0f} ns ({0[speedup]:.2f}x)"]
                  * len(KERNELS),
                  f"{title}, f64 and f32 timed in turns.")
    results.table("errors", columns, errors, [""] + ["{:.1e}"] * len(KERNELS),
                  f"f32's largest error relative to the largest f64 entry, "
                  f"{n} instances.")
    if args.newton:
        yasps.config.num_threads = 1
        newton(args.repeat, results)
    path = results.write(args.json)
    print(f"results: {path}")


STAGES = ("derivatives", "indices", "assembly", "solve")

#: (name, kernels' precision, Hessian storage of the solve's products)
NEWTON_SETTINGS = (("f64", "f64", "f64"), ("f32", "f32", "f64"),
                   ("mixed", "f32", "f32"))


def newton(repeat: int, results: Results) -> None:
    """One Newton iteration on the bunny per setting, in turns: f64; f32
    derivative kernels; and those with f32 Hessian blocks in PCG's SpMV.
    Adds the tables ``newton`` and ``newton_direction`` to ``results``."""
    scenes = {}
    for name, precision, storage in NEWTON_SETTINGS:
        yasps.config.hessian_storage = storage
        s = bunny_scene()
        s.precision = precision
        s.minimizeEnergy(tolerance=1e-4)      # compiles, builds the structure
        scenes[name] = (s, storage)
    seconds = {n: {k: [] for k in STAGES + ("total",)} for n in scenes}
    directions, iterations = {}, {}
    for _ in range(repeat):
        for name, (s, storage) in scenes.items():
            yasps.config.hessian_storage = storage
            at_new_point(s)
            directions[name] = s.minimizeEnergy(tolerance=1e-4)[0]
            iterations[name] = s.lastSolve["iterations"]
            stages = s.lastSolve["seconds"]
            for k in STAGES:
                seconds[name][k].append(stages[k])
            seconds[name]["total"].append(sum(stages[k] for k in STAGES))
    yasps.config.hessian_storage = "f64"
    names = list(scenes)
    print(f"\none Newton iteration, bunny-19k, one thread, median of {repeat}"
          f" (speed-up against f64): " + " / ".join(names))
    counts = set(iterations.values())
    rows = []
    for k in STAGES + ("total",):
        t = [float(np.median(seconds[n][k])) for n in names]
        cells = "".join(f"{v * 1e3:8.1f} ms ({t[0] / v:4.2f}x)" for v in t)
        print(f"  {k:12s}{cells}")
        # The iterations go in the solve's label where every setting took
        # as many.
        label = (f"solve ({next(iter(counts))} PCG iterations)"
                 if k == "solve" and len(counts) == 1 else k)
        rows.append([label, t[0] * 1e3] + [
            {"ms": v * 1e3, "speedup": t[0] / v} for v in t[1:]])
    results.table(
        "newton", ["stage"] + names, rows,
        ["", "{:.1f} ms"] + ["{0[ms]:.1f} ms ({0[speedup]:.2f}x)"]
        * (len(names) - 1),
        f"One Newton iteration on bunny-19k (79,935 tets, stable Neo-Hookean "
        f"and inertia, CG tolerance 1e-4), one thread, median of {repeat}, "
        f"the settings timed in turns; speed-up against f64. f32: f32 "
        f"derivative kernels; mixed: those and f32 Hessian blocks in PCG's "
        f"SpMV.")
    d64 = directions["f64"]
    rows = [["f64", iterations["f64"], None]]
    for name in names[1:]:
        error = float(np.abs(directions[name] - d64).max() / np.abs(d64).max())
        rows.append([name, iterations[name], error])
        print(f"  {name}: PCG iterations {iterations[name]} (f64: "
              f"{iterations['f64']}), direction {error:.1e} off f64's "
              f"(relative to its largest entry)")
    results.table("newton_direction",
                  ["setting", "PCG iterations", "direction off f64's"], rows,
                  ["", "", "{:.1e}"],
                  "The Newton direction's largest difference to f64's, "
                  "relative to its largest entry.")


if __name__ == "__main__":
    main()
