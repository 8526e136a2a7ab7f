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

    python3 bench/preconditioners.py [--repeat 5] [--threads 1 2]
        [--boxes 10 20 30] [--tolerance 1e-4] [--gpu] [--json FILE]
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
    parser.add_argument("--tolerance", type=float, default=TOLERANCE,
                        help="CG relative residual")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    TOLERANCE = args.tolerance

    results: Dict[str, dict] = {}
    lines = ["| scene | DoFs | threads | iterations BJ / ML | levels | "
             "solve BJ / ML (ms) | setup BJ / ML (ms) | per iteration BJ / ML (ms) | "
             "iterations ratio | solve ratio |", "|" + "---|" * 10]
    for name, (verts, tets, dt2, mass) in scenes(args.boxes).items():
        s = snh_scene(name.replace(" ", "_").replace("^", "").replace("-", "_"),
                  verts, tets, dt2, mass)
        runs = {}
        backends = [("cpu", t) for t in args.threads]
        if args.gpu:
            backends.append(("gpu", 0))
        for backend, threads in backends:
            yasps.config.backend = backend
            yasps.config.num_threads = threads
            key = f"{backend} {threads} thread(s)" if backend == "cpu" else "gpu"
            print(f"{name}: {key}", flush=True)
            runs[key] = r = measure(s, args.repeat)
            bj, ml = r["block-jacobi"], r["multilevel"]
            lines.append(
                f"| {name} | {3 * len(verts)} | {key} | {bj['iterations']} / "
                f"{ml['iterations']} | {ml['levels']} | {bj['solve_s'] * 1e3:.1f} / "
                f"{ml['solve_s'] * 1e3:.1f} | {bj['setup_s'] * 1e3:.1f} / "
                f"{ml['setup_s'] * 1e3:.1f} | {bj['per_iteration_s'] * 1e3:.3f} / "
                f"{ml['per_iteration_s'] * 1e3:.3f} | "
                f"{bj['iterations'] / ml['iterations']:.2f}x | "
                f"{bj['solve_s'] / ml['solve_s']:.2f}x |")
        yasps.config.backend = "cpu"
        if args.stand_in:
            print(f"{name}: GPU path (stand-in driver)", flush=True)
            runs["gpu stand-in"] = r = stand_in(args.stand_in, verts, tets, dt2, mass)
            bj, ml = r["block-jacobi"], r["multilevel"]
            lines.append(
                f"| {name} | {3 * len(verts)} | GPU path (stand-in) | "
                f"{bj['iterations']} / {ml['iterations']} | {ml['levels']} | | | | "
                f"{bj['iterations'] / ml['iterations']:.2f}x | |")
        results[name] = runs
    print()
    print("\n".join(lines))
    print(f"\nCG relative residual {TOLERANCE:g}. BJ: block-Jacobi, ML: "
          "multilevel; ratios BJ / ML (above 1: the multilevel solve takes "
          "fewer iterations or less time)")
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
