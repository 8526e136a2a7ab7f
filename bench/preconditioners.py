#!/usr/bin/env python3
"""Block-Jacobi against the multilevel preconditioner on the same solves.

One Newton direction (``minimizeEnergy`` at CG relative residual 1e-4, warm)
of stable Neo-Hookean + inertia, the constants of bench/newton_system.py
(mu = 1e4, lambda = 4e4, mass 1e-3 per vertex, vertices moved by normal
noise of 1e-3), on:

- bunny-19k (../shared/data) with dt^2 = 1e-4, and with dt^2 = 1e-2 (100x
  stiffer against the inertia);
- a box of 0.2 m, n^3 cells (6 tets each), n from ``--boxes``, with the
  mass of a density of 1000 kg/m^3 (1e-3 kg per vertex at n = 20): the same
  body at growing resolution, whose stiffness grows against its inertia
  as 1/h^2.

Per scene, thread count and preconditioner: PCG iterations, the solve's
time (median of ``--repeat``), its setup (a solve stopped at 0 iterations:
the preconditioner's construction, the finiteness checks and the residual)
and the time per iteration after it; ratios block-Jacobi / multilevel.

``--stand-in LIB`` also runs each scene's solve on the GPU backend through
the runtime's stand-in CUDA driver (runtime/test/FakeCuda.cpp, which runs
the GPU solver's kernels on the host, one thread after another): the GPU
path's iteration counts, whose times mean nothing. On a machine with a GPU,
``--gpu`` times the GPU backend itself.

``--tolerance`` takes several relative residuals (``--tolerance 1e-4
1e-6``): every scene is then solved to each, and each gets its table. The
tables go to --json (default bench/results/preconditioners.json), one per
tolerance, named ``solves_<tolerance>`` (``solves_1e-4``), with every
figure of every run in its values.

    python3 bench/preconditioners.py [--repeat 5] [--threads 1 2]
        [--boxes 10 20 30] [--tolerance 1e-4 [1e-6 ...]] [--gpu] [--json FILE]
        [--stand-in build/runtime/test/libYaspsFakeCuda.so]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Dict, List

os.environ.setdefault("YASPS_CACHE_DIR", tempfile.mkdtemp(prefix="yasps-bench-"))

HERE = Path(__file__).resolve().parent
import benchlib  # noqa: E402

benchlib.use_this_checkout()

import numpy as np  # noqa: E402

import yasps  # noqa: E402
from benchlib.elastic_scenes import MASS, snh_scene  # noqa: E402
from benchlib.meshes import bunny  # noqa: E402
from benchlib.results import Results, add_json_argument  # noqa: E402
from benchlib.tables import markdown  # noqa: E402
from yasps.sim import box_tet_mesh  # noqa: E402

#: The CG relative residual (--tolerance).
TOLERANCE = 1e-4
PRECONDITIONERS = ("block-jacobi", "multilevel")


def scenes(boxes: List[int]) -> Dict[str, tuple]:
    """Scene name -> (vertices, tets, dt2, mass per vertex)."""
    verts, tets = bunny("19k")
    out = {"bunny-19k": (verts, tets, 1e-4, MASS),
           "bunny-19k stiff": (verts, tets, 1e-2, MASS)}
    for n in boxes:
        bv, bt = box_tet_mesh(n, 0.2)
        out[f"box {n}^3"] = (bv, bt.astype(np.int32), 1e-4, 1e3 * (0.2 / n) ** 3)
    return out


def solve_once(s, max_iterations: int = 10000) -> dict:
    try:
        s.minimizeEnergy(tolerance=TOLERANCE, maxIterations=max_iterations)
    except yasps.SolverError:
        pass  # maxIterations=0: the setup only
    return dict(s.lastSolve)


def solve_seconds(s, repeat: int, max_iterations: int = 10000) -> float:
    """The median over `repeat` minimizeEnergy calls of their solve's time
    (lastSolve's, the PCG call alone)."""
    return float(np.median([solve_once(s, max_iterations)["seconds"]["solve"]
                            for _ in range(repeat)]))


def measure(s, repeat: int) -> Dict[str, dict]:
    """Per preconditioner: iterations, solve and setup seconds."""
    out = {}
    for preconditioner in PRECONDITIONERS:
        yasps.config.preconditioner = preconditioner
        info = solve_once(s)  # warm: the levels' structure is built here
        assert info["converged"], info
        solve = solve_seconds(s, repeat)
        setup = solve_seconds(s, repeat, 0)
        out[preconditioner] = {
            "iterations": info["iterations"], "levels": info["preconditionerLevels"],
            "solve_s": solve, "setup_s": setup,
            "per_iteration_s": (solve - setup) / max(1, info["iterations"])}
    yasps.config.preconditioner = "block-jacobi"
    return out


STAND_IN = """
import json, sys
sys.path.insert(0, %r)
import benchlib
benchlib.use_this_checkout()
import benchlib.elastic_scenes as scenes
import preconditioners as bench
import numpy as np, yasps
yasps.config.gpu_derivatives = False
yasps.config.backend = "gpu"
verts, tets = np.load(%r), np.load(%r)
bench.TOLERANCE = %r
s = scenes.snh_scene("stand_in", verts, tets, %r, %r)
out = {}
for p in bench.PRECONDITIONERS:
    yasps.config.preconditioner = p
    info = bench.solve_once(s)
    assert info["backend"] == "gpu" and info["converged"], info
    out[p] = {"iterations": info["iterations"], "levels": info["preconditionerLevels"]}
print(json.dumps(out))
"""


def stand_in(library: Path, verts, tets, dt2: float, mass: float) -> Dict[str, dict]:
    """The GPU path's iteration counts through the stand-in driver."""
    with tempfile.TemporaryDirectory() as tmp:
        np.save(f"{tmp}/v.npy", verts)
        np.save(f"{tmp}/t.npy", tets)
        result = subprocess.run(
            [sys.executable, "-c", STAND_IN % (str(HERE), f"{tmp}/v.npy",
                                               f"{tmp}/t.npy", TOLERANCE, dt2,
                                               mass)],
            env=dict(os.environ, YASPS_CUDA_LIBRARY=str(library)),
            capture_output=True, text=True)
    if result.returncode != 0:
        raise SystemExit(f"preconditioners: the stand-in run failed:\n{result.stderr}")
    return json.loads(result.stdout.splitlines()[-1])


def tolerance_name(tolerance: float) -> str:
    """1e-04 -> 1e-4, 1.5e-05 -> 1.5e-5: the tolerance in a table's name."""
    mantissa, exponent = f"{tolerance:e}".split("e")
    return f"{mantissa.rstrip('0').rstrip('.')}e{int(exponent)}"


#: The table's columns and formats. A pair of cells "BJ / ML" is one cell
#: {"BJ": value, "ML": value}: the JSON keeps both numbers.
COLUMNS = (("scene", ""), ("DoFs", ""), ("threads", ""),
           ("iterations BJ / ML", "{0[BJ]} / {0[ML]}"), ("levels", ""),
           ("solve BJ / ML (ms)", "{0[BJ]:.1f} / {0[ML]:.1f}"),
           ("setup BJ / ML (ms)", "{0[BJ]:.1f} / {0[ML]:.1f}"),
           ("per iteration BJ / ML (ms)", "{0[BJ]:.3f} / {0[ML]:.3f}"),
           ("iterations ratio", "{:.2f}x"), ("solve ratio", "{:.2f}x"))


def pair(r: Dict[str, dict], key: str, scale: int = 1) -> dict:
    """A "BJ / ML" cell: the figure ``key`` of both preconditioners."""
    return {"BJ": r["block-jacobi"][key] * scale,
            "ML": r["multilevel"][key] * scale}


def row(name: str, dofs: int, key: str, r: Dict[str, dict]) -> list:
    """A line of the table: a timed run, or the stand-in's counts alone."""
    bj, ml = r["block-jacobi"], r["multilevel"]
    timed = "solve_s" in bj
    return [name, dofs, key, pair(r, "iterations"), ml["levels"],
            pair(r, "solve_s", 1000) if timed else None,
            pair(r, "setup_s", 1000) if timed else None,
            pair(r, "per_iteration_s", 1000) if timed else None,
            bj["iterations"] / ml["iterations"],
            bj["solve_s"] / ml["solve_s"] if timed else None]


def main() -> None:
    global TOLERANCE
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--boxes", type=int, nargs="*", default=[10, 20, 30])
    parser.add_argument("--stand-in", type=Path, default=None,
                        help="the stand-in CUDA driver library, for the GPU "
                             "path's iteration counts")
    parser.add_argument("--gpu", action="store_true",
                        help="also time the GPU backend (needs a GPU)")
    parser.add_argument("--tolerance", type=float, nargs="+",
                        default=[TOLERANCE],
                        help="CG relative residual(s): each scene is solved "
                        "to each, and each has its table")
    add_json_argument(parser, "preconditioners")
    args = parser.parse_args()
    results = Results("preconditioners")
    results.values.update(repeat=args.repeat, threads=args.threads,
                          boxes=args.boxes, tolerances=args.tolerance)

    # tolerance -> scene -> run ("cpu 1 thread(s)", "gpu", "gpu stand-in")
    # -> preconditioner -> figures.
    runs: Dict[float, Dict[str, dict]] = {t: {} for t in args.tolerance}
    rows: Dict[float, List[list]] = {t: [] for t in args.tolerance}
    for name, (verts, tets, dt2, mass) in scenes(args.boxes).items():
        s = snh_scene(name.replace(" ", "_").replace("^", "").replace("-", "_"),
                  verts, tets, dt2, mass)
        for tolerance in args.tolerance:
            TOLERANCE = tolerance
            scene_runs = runs[tolerance][name] = {}
            backends = [("cpu", t) for t in args.threads]
            if args.gpu:
                backends.append(("gpu", 0))
            for backend, threads in backends:
                yasps.config.backend = backend
                yasps.config.num_threads = threads
                key = f"{backend} {threads} thread(s)" if backend == "cpu" else "gpu"
                label = key if len(args.tolerance) == 1 else \
                    f"{key}, CG {tolerance_name(tolerance)}"
                print(f"{name}: {label}", flush=True)
                scene_runs[key] = r = measure(s, args.repeat)
                rows[tolerance].append(row(name, 3 * len(verts), key, r))
            yasps.config.backend = "cpu"
            if args.stand_in:
                print(f"{name}: GPU path (stand-in driver), CG "
                      f"{tolerance_name(tolerance)}", flush=True)
                scene_runs["gpu stand-in"] = r = stand_in(
                    args.stand_in, verts, tets, dt2, mass)
                rows[tolerance].append(row(name, 3 * len(verts),
                                           "GPU path (stand-in)", r))
    for tolerance in args.tolerance:
        note = (f"CG relative residual {tolerance:g}. BJ: block-Jacobi, ML: "
                "multilevel; ratios BJ / ML (above 1: the multilevel solve "
                "takes fewer iterations or less time)")
        table = results.table(f"solves_{tolerance_name(tolerance)}",
                              [c for c, _ in COLUMNS], rows[tolerance],
                              [f for _, f in COLUMNS], note)
        print()
        print(markdown(table))
        print(f"\n{note}")
    results.values["runs"] = {tolerance_name(t): runs[t] for t in args.tolerance}
    path = results.write(args.json)
    print(f"results: {path}")


if __name__ == "__main__":
    main()
