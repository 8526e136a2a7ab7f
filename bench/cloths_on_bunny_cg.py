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

``--preconditioner`` takes one or more, each a run of its own, one after
the other (by default block-Jacobi, multilevel and auto). The frames go to
table ``frames`` and each run's totals to ``summary``, both also in
``--json`` (bench/results/cloths_on_bunny_cg.json).

    python3 bench/cloths_on_bunny_cg.py [--frames 30] [--scale paper]
        [--preconditioner block-jacobi multilevel auto]
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
from benchlib.results import Results, add_json_argument  # noqa: E402

#: The preconditioners' names in the tables.
LABELS = {"block-jacobi": "block-Jacobi"}


def run(preconditioner: str, args) -> tuple:
    """Steps the scene with ``preconditioner``, printing each frame;
    returns the CG rule and the rows of the ``frames`` table."""
    yasps.config.preconditioner = preconditioner
    stepper, contact, _ = cloths_on_bunny.build(args.scale, 1)
    if args.cg_stopping is not None:
        stepper.cg_stopping = args.cg_stopping
    if args.cg_tolerance is not None:
        stepper.cg_tolerance = args.cg_tolerance
    rule = f"{stepper.cg_stopping} rule at {stepper.cg_tolerance:g}"
    print(f"CG: {rule}, {preconditioner}", flush=True)
    warnings.simplefilter("ignore")
    yasps.compile(stepper.scene, also=[contact.positions], progress=False)
    label = LABELS.get(preconditioner, preconditioner)
    rows = []
    newton = cg = 0
    for frame in range(1, args.frames + 1):
        start = time.perf_counter()
        report = stepper.step(warn=False)
        seconds = time.perf_counter() - start
        directions, iterations = len(report.cg_iterations), \
            sum(report.cg_iterations)
        newton, cg = newton + directions, cg + iterations
        rows.append([label, frame, seconds, directions, iterations,
                     iterations / max(directions, 1), cg / max(newton, 1),
                     report.projection_retries, bool(report.converged),
                     bool(contact.has_intersections())])
        _, _, seconds, directions, _, per_newton, running, retries, \
            converged, intersecting = rows[-1]
        print(f"frame {frame}: {seconds:.1f} s, {directions} Newton, "
              f"{per_newton:.0f} CG/Newton, running {running:.0f} CG/Newton, "
              f"{retries} retries, converged {converged}, intersecting "
              f"{intersecting}", flush=True)
    return rule, rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=30)
    parser.add_argument("--scale", choices=("small", "paper"),
                        default="paper")
    parser.add_argument("--preconditioner", nargs="+",
                        choices=yasps.config.PRECONDITIONERS,
                        default=["block-jacobi", "multilevel", "auto"],
                        help="one run per preconditioner given, one after "
                        "the other (default: all three)")
    parser.add_argument("--cg-stopping", default=None,
                        choices=("residual", "energy_norm", "preconditioned"))
    parser.add_argument("--cg-tolerance", type=float, default=None)
    add_json_argument(parser, "cloths_on_bunny_cg")
    args = parser.parse_args()
    results = Results("cloths_on_bunny_cg")
    frames, summary, rules = [], [], []
    for preconditioner in args.preconditioner:
        rule, rows = run(preconditioner, args)
        frames += rows
        rules.append(rule)
        newton = sum(r[3] for r in rows)
        summary.append([LABELS.get(preconditioner, preconditioner),
                        sum(r[4] for r in rows) / max(newton, 1), newton,
                        sum(r[2] for r in rows)])
    results.values["cg"] = rules[0]
    results.table(
        "frames",
        ["preconditioner", "frame", "seconds", "Newton", "CG", "CG/Newton",
         "running CG/Newton", "retries", "converged", "intersecting"],
        frames,
        ["", "{}", "{:.1f}", "{}", "{:,}", "{:.0f}", "{:.0f}", "{}", "", ""],
        "Per frame: Newton directions solved (the solves repeated with more "
        "projection included), their CG iterations, the projection retries, "
        "whether Newton converged and whether ipctk finds an intersection.")
    results.table(
        "summary",
        [f"frames 1-{args.frames}", "CG/Newton", "Newton iterations",
         "seconds"],
        summary, ["", "{:.0f}", "{:,}", "{:.1f}"],
        f"CG: {rules[0]}; one run per preconditioner, one after the other; "
        "seconds: the frames', compiling excluded.")
    print()
    for label, cg_per_newton, newton, seconds in summary:
        print(f"{label}, frames 1-{args.frames}: {cg_per_newton:.0f} "
              f"CG/Newton, {newton} Newton iterations, {seconds:.1f} s")
    path = results.write(args.json)
    print(f"results: {path}")


if __name__ == "__main__":
    main()
