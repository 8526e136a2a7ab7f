#!/usr/bin/env python3
"""CG iterations per Newton iteration on the paper's cloths-on-bunny scene.

Steps examples/paper/cloths_on_bunny.py (one cloth layer) at the paper's
scale (a 100 x 100-cell pinned cloth and the 19k-vertex bunny of
../shared/data, about 30,000 vertices) and prints, frame by frame as it
goes (a paper-scale frame takes seconds to minutes), the seconds, Newton
iterations, CG iterations per Newton iteration (the solves repeated with
more projection included, as NewtonReport counts them), their running
mean, the retries, whether the frame converged and ipctk's intersection
verdict. The paper's YASPS needs 152 CG iterations per Newton iteration on
this scene, GIPC 56 (paper Table 1), both stopping CG once r^T M^-1 r <=
1e-4 b^T M^-1 b: the scene's default (``cg_stopping="preconditioned"`` at
1e-2); ``--cg-stopping residual --cg-tolerance 1e-4`` measures the
stricter ||r|| <= 1e-4 ||b|| instead.

    python3 bench/cloths_on_bunny_cg.py [--frames 30] [--scale paper]
        [--preconditioner block-jacobi|multilevel]
        [--cg-stopping residual|energy_norm|preconditioned]
        [--cg-tolerance T]
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
import benchlib  # noqa: E402

benchlib.use_this_checkout()
sys.path.insert(0, str(REPO / "examples" / "paper"))

import cloths_on_bunny  # noqa: E402
import yasps  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=30)
    parser.add_argument("--scale", choices=("small", "paper"),
                        default="paper")
    parser.add_argument("--preconditioner", choices=yasps.config.PRECONDITIONERS,
                        default=yasps.config.preconditioner)
    parser.add_argument("--cg-stopping", default=None,
                        choices=("residual", "energy_norm", "preconditioned"))
    parser.add_argument("--cg-tolerance", type=float, default=None)
    args = parser.parse_args()
    yasps.config.preconditioner = args.preconditioner
    stepper, contact, _ = cloths_on_bunny.build(args.scale, 1)
    if args.cg_stopping is not None:
        stepper.cg_stopping = args.cg_stopping
    if args.cg_tolerance is not None:
        stepper.cg_tolerance = args.cg_tolerance
    print(f"CG: {stepper.cg_stopping} rule at {stepper.cg_tolerance:g}, "
          f"{args.preconditioner}", flush=True)
    warnings.simplefilter("ignore")
    yasps.compile(stepper.scene, also=[contact.positions], progress=False)
    newton = cg = 0
    for frame in range(1, args.frames + 1):
        start = time.perf_counter()
        report = stepper.step(warn=False)
        seconds = time.perf_counter() - start
        directions, iterations = len(report.cg_iterations), \
            sum(report.cg_iterations)
        newton, cg = newton + directions, cg + iterations
        print(f"frame {frame}: {seconds:.1f} s, {directions} Newton, "
              f"{iterations / max(directions, 1):.0f} CG/Newton, running "
              f"{cg / max(newton, 1):.0f} CG/Newton, "
              f"{report.projection_retries} retries, converged "
              f"{report.converged}, intersecting "
              f"{contact.has_intersections()}", flush=True)


if __name__ == "__main__":
    main()
