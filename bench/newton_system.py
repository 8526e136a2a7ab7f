#!/usr/bin/env python3
"""One Newton iteration on the 19k-vertex bunny: time split and SpMV.

Stable Neo-Hookean on the 79,935 tets of ../shared/data/bunny-19k.msh plus
inertia, minimised over the vertex positions. Prints the time of one
`minimizeEnergy` split into derivatives, indices, assembly and PCG (the
second call, which reuses the static structure), the PCG
iterations, and the block-sparse SpMV of the runtime against SciPy's CSR
SpMV on the same matrix (one thread each; SciPy's is single-threaded).

Writes the tables (``stages``, ``spmv``) to --json (default
bench/results/newton_system.json).

    python3 bench/newton_system.py [--repeat 20] [--threads 1] [--json PATH]
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
import scipy.sparse as sparse  # noqa: E402

import yasps  # noqa: E402
from benchlib.results import Results, add_json_argument  # noqa: E402
from benchlib.timing import at_new_point, median  # noqa: E402
from yasps.runtime import cpu_backend  # noqa: E402
from yasps.solve import assemble  # noqa: E402
from benchlib.elastic_scenes import bunny_snh  # noqa: E402


STAGES = ("derivatives", "indices", "assembly", "solve")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=20)
    parser.add_argument("--threads", type=int, default=1,
                        help="threads for the Newton iteration (the SpMV "
                        "comparison stays on one)")
    add_json_argument(parser, "newton_system")
    args = parser.parse_args()
    results = Results("newton_system")
    yasps.config.num_threads = args.threads
    s = bunny_snh()
    s.minimizeEnergy(tolerance=1e-4)          # compiles the kernels
    first_indices = s.lastSolve["seconds"]["indices"]
    at_new_point(s)
    s.minimizeEnergy(tolerance=1e-4)
    info = s.lastSolve
    seconds = info["seconds"]
    total = sum(seconds.values())
    print("one Newton iteration, bunny-19k (19,193 vertices, 79,935 tets), "
          f"stable Neo-Hookean + inertia, {args.threads} thread(s)")
    stages = results.table(
        "stages", ["stage", "time (ms)", "share"],
        [[stage, seconds[stage] * 1e3, 100 * seconds[stage] / total]
         for stage in STAGES],
        ["", "{:.1f}", "{:.1f}%"],
        note=f"One Newton iteration (the second `minimizeEnergy`), bunny-19k "
        f"(19,193 vertices, 79,935 tets), stable Neo-Hookean + inertia, "
        f"{args.threads} thread(s). Indices of the first iteration, which "
        f"builds the static structure: {first_indices * 1e3:.1f} ms; later "
        f"ones reuse it. PCG: {info['iterations']} iterations to relative "
        f"residual {info['relativeResidual']:.2e}.")
    for stage, ms, share in stages.rows:
        print(f"  {stage:12s}{ms:9.1f} ms  {share:5.1f}%")
    print(f"  (indices of the first iteration, which builds the static "
          f"structure: {first_indices * 1e3:.1f} ms; later ones reuse it)")
    print(f"  PCG: {info['iterations']} iterations to relative residual "
          f"{info['relativeResidual']:.2e}")
    results.values.update({
        "threads": args.threads, "repeat": args.repeat,
        "seconds": dict(seconds), "first_indices_s": first_indices,
        "pcg_iterations": info["iterations"],
        "relative_residual": info["relativeResidual"]})

    system = assemble(s, cpu_backend(), threads=1).system
    nnz = system.non_zeros
    rows, cols = np.empty(nnz, np.int64), np.empty(nnz, np.int64)
    values = np.empty(nnz)
    system.coordinates(rows, cols, values)
    csr = sparse.csr_matrix((values, (rows, cols)), shape=(system.size,) * 2)
    x = np.random.default_rng(1).normal(size=system.size)
    y = np.empty(system.size)
    system.multiply(x, y, 1)
    np.testing.assert_allclose(y, csr @ x, rtol=1e-10, atol=1e-10 * np.abs(y).max())
    ours = median(lambda: system.multiply(x, y, 1), args.repeat)
    scipy_time = median(lambda: csr @ x, args.repeat)
    sizes = (f"{system.size} DoFs, {system.stored_blocks} stored blocks, "
             f"{nnz} scalar non-zeros")
    spmv = results.table(
        "spmv", ["SpMV, one thread", "time (ms)", "time / yasps' time"],
        [["yasps block-sparse", ours * 1e3, None],
         ["SciPy CSR", scipy_time * 1e3, scipy_time / ours]],
        ["", "{:.2f}", "{:.2f}x"],
        note=f"The SpMV of the iteration's matrix ({sizes}), median of "
        f"{args.repeat}.")
    results.values.update({"dofs": system.size,
                           "stored_blocks": system.stored_blocks,
                           "non_zeros": nnz})
    print(f"  SpMV ({sizes}):")
    for name, ms, ratio in spmv.rows:
        print(f"    {name:20s}{ms:7.2f} ms"
              + (f"   ({ratio:.2f}x yasps)" if ratio is not None else ""))
    path = results.write(args.json)
    print(f"results: {path}")


if __name__ == "__main__":
    main()
