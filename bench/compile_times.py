#!/usr/bin/env python3
"""Compile times of a soft+affine contact scene, and what pair-count
changes cost afterwards.

The scene (bench/benchlib/contact_scene.py): a soft box (stable Neo-Hookean,
inertia) and an affine box (inertia on A and t, ABD orthogonality) whose
vertices form one UNION, with dynamic PP, PE, PT and EE pairs carrying the
IPC barrier. Prints:

1. per energy, cold (fresh process and kernel cache): the kernels that
   minimizeEnergy needs (gradient, projected Hessian or its factors,
   placement indices), then what energyDerivatives adds (values, the
   unprojected Hessian); each energy's storage per instance as assembled
   (inner gradient and P with J in shared per-member tables, or the dense
   gradient and block) against padded per-instance factors and the dense
   n x n block, and the size of the tables it reads (per member vertex,
   not per pair);
2. the whole scene, cold and warm (a new process with the disk cache): the
   first minimizeEnergy and evaluateEnergy, and the compiler requests made;
3. ``--calls`` minimizeEnergy calls with every pair type's count drawn
   between 0 and ``--max-pairs``: compiler requests made (should be none),
   and the median time of a call whose counts changed against one whose
   counts (and pairs) were set again unchanged.

The tables also go to ``--json`` (bench/results/compile_times.json):
``energies`` (1.), ``whole_scene`` (2.) and ``pair_counts`` (3.).

    python3 bench/compile_times.py [--calls 200] [--max-pairs 5000]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
import benchlib  # noqa: E402

benchlib.use_this_checkout()

from benchlib.results import Results, add_json_argument  # noqa: E402

#: The energies' names in the tables (docs/benchmarks.md), by qualified name.
LABELS = {
    "soft.t.elastic": "soft tets, stable Neo-Hookean",
    "soft.v.inertia": "soft inertia",
    "rigid.body.inertia": "affine inertia",
    "rigid.body.orth": "ABD orthogonality",
    "world.pp.barrier": "PP barrier",
    "world.pe.barrier": "PE barrier",
    "world.pt.barrier": "PT barrier",
    "world.ee.barrier": "EE barrier",
}


def worker(task: str, energy: str) -> dict:
    """Runs in a fresh process (the cache directory comes from the
    environment): builds the scene and times ``task``."""
    import yasps
    from benchlib.contact_scene import build
    from yasps.runtime import (FactoredInputs, SlotFactoredInputs,
                               cpu_backend)
    from yasps.solve import assembly_inputs

    yasps.config.backend = "cpu"
    s, *_ = build()
    if task == "energy":
        attr = next(e for e in s.energies if e.owner.qualifiedName + "." +
                    e.name == energy)
        start = time.perf_counter()
        inputs, _ = assembly_inputs(s, attr, cpu_backend())
        assembly = time.perf_counter() - start
        start = time.perf_counter()
        d = s.energyDerivatives(attr)
        extra = time.perf_counter() - start
        n = d.gradient.shape[1]
        m = inputs.inner_size if isinstance(
            inputs, (SlotFactoredInputs, FactoredInputs)) else 0
        if isinstance(inputs, SlotFactoredInputs):
            how = "tables"
            stored = inputs.slot_factors.stored_per_instance(m)
            tables = sum(t.size for t in inputs.slot_factors.tables)
        elif isinstance(inputs, FactoredInputs):
            how, stored, tables = "padded J", n + m * (n + m), 0
        else:
            how, stored, tables = "dense", n + n * n, 0
        # The padded factors of the same energy, for comparison.
        yasps.config.slot_jacobians = False
        padded, _ = assembly_inputs(s, attr, cpu_backend())
        padded_stored = (n + m * (n + m) if isinstance(padded, FactoredInputs)
                         else n + n * n)
        return {"assembly": assembly, "derivatives": extra, "n": n,
                "stored": stored, "how": how, "tables": tables,
                "padded": padded_stored}
    start = time.perf_counter()
    if task == "compile":
        summary = yasps.compile(s, progress=False)
    s.minimizeEnergy()
    s.evaluateEnergy()
    return {"seconds": time.perf_counter() - start,
            "requests": sum(yasps.compiler.invocations().values()),
            "kernels_compiled": yasps.compiler.cpu.kernels_compiled(),
            "kernels": summary.kernels if task == "compile" else 0}


def run_worker(task: str, energy: str, cache: str) -> dict:
    env = dict(os.environ, YASPS_CACHE_DIR=cache)
    out = subprocess.run([sys.executable, __file__, "--worker", task, energy],
                         env=env, check=True, capture_output=True, text=True)
    return json.loads(out.stdout.splitlines()[-1])


def count_changes(calls: int, max_pairs: int, results: Results) -> None:
    import numpy as np

    import yasps
    from benchlib.contact_scene import PAIR_TYPES, build, random_pairs
    from benchlib.timing import median

    yasps.config.backend = "cpu"
    s, primitives, connectivities, positions = build()
    rng = np.random.default_rng(0)
    s.minimizeEnergy()

    def set_pairs(counts):
        for (name, (arity, _)), n in zip(PAIR_TYPES.items(), counts):
            primitives[name].updateNumInstances(int(n))
            connectivities[name].updateConnectivity(
                random_pairs(int(n), positions, arity, rng))

    before = yasps.compiler.invocations()
    changed, same = [], []
    for _ in range(calls):
        counts = rng.integers(0, max_pairs + 1, size=len(PAIR_TYPES))
        for times in (changed, same):
            # The second call sets the same counts again (new pairs): the
            # difference is what a change of counts costs.
            set_pairs(counts)
            start = time.perf_counter()
            s.minimizeEnergy(tolerance=1e-4)
            times.append(time.perf_counter() - start)
    requests = sum(yasps.compiler.invocations().values()) - \
        sum(before.values())
    print(f"\n{calls} minimizeEnergy calls, pair counts 0-{max_pairs} per "
          f"type: {requests} compiler requests")
    set_pairs([0] * len(PAIR_TYPES))
    without, _, _, _ = build(pair_types=())
    without.minimizeEnergy()
    empty = median(lambda: s.minimizeEnergy(tolerance=1e-4), 50)
    none = median(lambda: without.minimizeEnergy(tolerance=1e-4), 50)
    changed_ms = 1e3 * float(np.median(changed))
    same_ms = 1e3 * float(np.median(same))
    row = [calls, max_pairs, requests, 1e3 * empty, 1e3 * none,
           1e3 * (empty - none), changed_ms, same_ms, changed_ms - same_ms]
    table = results.table(
        "pair_counts",
        ["calls", "pairs per type", "compiler requests",
         "no pairs (ms)", "without pair energies (ms)",
         "pair energies' fixed cost (ms)", "counts changed (ms)",
         "counts set again (ms)", "difference (ms)"],
        [row],
        ["{:,}", "0-{:,}", "{:,}", "{:.2f}", "{:.2f}", "{:.2f}", "{:.2f}",
         "{:.2f}", "{:+.2f}"],
        "minimizeEnergy calls with every pair type's count drawn in the "
        "range: compiler requests made, the time per call with no pairs "
        "against the same scene without the four pair energies, and the "
        "median time of a call whose counts changed against one whose "
        "counts (and pairs) were set again unchanged.")
    _, _, _, empty_ms, none_ms, fixed_ms, changed_ms, same_ms, diff_ms = \
        table.rows[0]
    print(f"  per call with no pairs: {empty_ms:.2f} ms; the same scene "
          f"without the four pair energies: {none_ms:.2f} ms (the pair "
          f"energies' fixed cost {fixed_ms:.2f} ms)")
    print(f"  median per call, counts changed: {changed_ms:.2f} ms; counts "
          f"set again unchanged: {same_ms:.2f} ms; difference "
          f"{diff_ms:+.2f} ms")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--calls", type=int, default=200)
    parser.add_argument("--max-pairs", type=int, default=5000)
    parser.add_argument("--worker", nargs=2, help=argparse.SUPPRESS)
    add_json_argument(parser, "compile_times")
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(*args.worker)))
        return

    from benchlib.contact_scene import build
    results = Results("compile_times")
    s, *_ = build()
    names = [e.owner.qualifiedName + "." + e.name for e in s.energies]
    print("cold compile per energy (fresh process and cache), seconds; "
          "doubles stored per instance for assembly (gradient and Hessian "
          "or its factors) as assembled, with padded per-instance J, and "
          "dense; doubles of the shared Jacobian tables it reads")
    print(f"{'energy':29} {'minimizeEnergy':>15} {'+energyDerivatives':>19} "
          f"{'n':>4} {'stored':>16} {'padded J':>9} {'dense':>6} "
          f"{'tables':>7}")
    rows = []
    for name in names:
        with tempfile.TemporaryDirectory() as cache:
            r = run_worker("energy", name, cache)
        n = r["n"]
        rows.append([LABELS.get(name, name), r["assembly"], r["derivatives"],
                     n, {"stored": r["stored"], "as": r["how"]}, r["padded"],
                     n + n * n, r["tables"]])
        label, assembly, derivatives, n, stored, padded, dense, tables = \
            rows[-1]
        print(f"{label:29} {assembly:15.2f} {derivatives:19.2f} "
              f"{n:4d} {stored['stored']:>6} ({stored['as']:>7}) "
              f"{padded:>9} {dense:>6} {tables:>7}")
    results.table(
        "energies",
        ["energy", "cold, minimizeEnergy's kernels (s)",
         "+ energyDerivatives (s)", "n", "stored per instance",
         "padded J", "dense", "tables"],
        rows,
        ["", "{:.2f}", "{:.2f}", "{}", "{0[stored]:,} ({0[as]})", "{:,}",
         "{:,}", "{:,}"])
    rows = []
    for task, how, label in (
            ("compile", "yasps.compile(scene), then", "yasps.compile(scene)"),
            ("scene", "without yasps.compile:", "without yasps.compile")):
        with tempfile.TemporaryDirectory() as cache:
            cold = run_worker(task, "", cache)
            warm = run_worker(task, "", cache)
        rows.append([label, cold["seconds"], cold["kernels_compiled"],
                     cold["requests"], warm["seconds"],
                     warm["kernels_compiled"], warm["requests"]])
        _, cold_s, cold_k, cold_r, warm_s, warm_k, warm_r = rows[-1]
        print(f"\nwhole scene, {how} the first minimizeEnergy and "
              f"evaluateEnergy:")
        print(f"  cold {cold_s:.2f} s ({cold_k} kernels compiled, {cold_r} "
              f"compiler requests); warm, new process with the disk cache "
              f"{warm_s:.2f} s ({warm_k} compiled, {warm_r} requests)")
    results.table(
        "whole_scene",
        ["whole scene", "cold (s)", "kernels compiled", "compiler requests",
         "warm (s)", "kernels compiled, warm", "compiler requests, warm"],
        rows, ["", "{:.2f}", "{}", "{}", "{:.2f}", "{}", "{}"],
        "The first minimizeEnergy and evaluateEnergy of the whole scene, "
        "cold (fresh process and kernel cache) and warm (a new process with "
        "the disk cache).")
    count_changes(args.calls, args.max_pairs, results)
    path = results.write(args.json)
    print(f"results: {path}")


if __name__ == "__main__":
    main()
