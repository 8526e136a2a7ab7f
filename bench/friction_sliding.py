#!/usr/bin/env python3
"""Sliding friction against Coulomb's law: how far a block slides down a
slope, by Newton tolerance and lagged friction iterations.

The block of ``examples/sweep_slope.py`` (10 cm, 6 tets, stable
Neo-Hookean, IPC contact with a half-space, adaptive barrier stiffness,
friction smoothed below eps_v = 1e-3 m/s) starts at rest on a 30-degree
slope and is stepped by implicit Euler (dt = 0.01 s). Sliding at the
constant acceleration a = g (sin - mu cos), implicit Euler moves it
a dt^2 N (N + 1) / 2 in N steps: the reference. For each Young's modulus,
friction coefficient, Newton velocity tolerance and number of friction
lags per step (1: IPC's default, normal forces and bases from the step's
start; more: re-lagged at each solution until a solve after a lag converges
at once), the bench prints the distance slid, its error against the
reference, the closest approach to the plane (ipctk), the Newton and CG
iterations and the wall time of the run (one thread; kernels compiled by a
first run that is not timed).

``--demo FRAMES`` also times the README's contact demo (cloth 20x20, boxes
of 3^3 cells, with friction 0.2) for that many frames at each tolerance and
lag count (the cost of the accurate settings on a larger scene).

The tables also go to ``--json`` (bench/results/friction_sliding.json):
``runs`` (every run as printed), ``error`` (each run's error and Newton
iterations, a row per Young's modulus and mu, a column per tolerance and
lag count) and, with ``--demo``, ``demo``.

    python3 bench/friction_sliding.py [--steps 30] [--mu 0.2 0.4] [--demo 40]
"""

from __future__ import annotations

import argparse
import importlib
import itertools
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("YASPS_CACHE_DIR",
                      tempfile.mkdtemp(prefix="yasps-bench-"))
ROOT = Path(__file__).resolve().parents[1]
import benchlib  # noqa: E402

benchlib.use_this_checkout()
sys.path.insert(0, str(ROOT / "examples"))

import numpy as np  # noqa: E402

from benchlib.results import Results, add_json_argument  # noqa: E402
from sweep_slope import DT, simulate  # noqa: E402

newton = importlib.import_module("yasps.sim.newton")
ANGLE = 30.0


def law(mu: float, steps: int) -> float:
    """Implicit Euler's distance under Coulomb's law from rest."""
    theta = np.radians(ANGLE)
    a = 9.81 * (np.sin(theta) - mu * np.cos(theta))
    return max(a, 0.0) * DT * DT * steps * (steps + 1) / 2


def exponent(x: float) -> str:
    """1e-2 for 0.01, 1e5 for 100000.0 (as the docs write them)."""
    mantissa, power = f"{x:.0e}".split("e")
    return f"{mantissa}e{int(power)}"


def setting(tol: float, lags: int) -> str:
    """A column of the error and newton tables."""
    return f"{exponent(tol)} m/s, {lags} lag{'' if lags == 1 else 's'}"


def demo_costs(frames: int, tolerances, lags_options,
               results: Results) -> None:
    """Times the contact demo's frames at each setting."""
    import contact_demo
    from yasps.sim import ImplicitEuler

    print(f"\ncontact demo, {frames} frames: {'tol (m/s)':>9} {'lags':>4} "
          f"{'Newton':>6} {'CG':>7} {'s':>6}")
    rows = []
    for tol, lags in itertools.product(tolerances, lags_options):
        def stepper(*args, **kwargs):
            return ImplicitEuler(*args, velocity_tolerance=tol,
                                 friction_iterations=lags, **kwargs)
        contact_demo.ImplicitEuler = stepper
        s, run, contact, _ = contact_demo.build(20, 3)
        contact.update()
        s.evaluateEnergy()  # compile, or load, every kernel first
        s.minimizeEnergy(fixed=run.fixed)
        start = time.perf_counter()
        total = run.run(frames, progress=False)
        seconds = time.perf_counter() - start
        rows.append([tol, lags, total.iterations, sum(total.cg_iterations),
                     seconds])
        print(f"{'':>29} {tol:9.0e} {lags:4d} {total.iterations:6d} "
              f"{sum(total.cg_iterations):7d} {seconds:6.1f}", flush=True)
    results.table(
        "demo", ["tol (m/s)", "lags", "Newton", "CG", "s"], rows,
        ["{:.0e}", "{}", "{:,}", "{:,}", "{:.1f}"],
        f"The README's contact demo (cloth 20x20, boxes of 3^3 cells, "
        f"friction 0.2), {frames} frames at each setting.")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--steps", type=int, default=30)
    parser.add_argument("--mu", type=float, nargs="+", default=[0.2, 0.4])
    parser.add_argument("--youngs", type=float, nargs="+",
                        default=[1e5, 1e7])
    parser.add_argument("--tolerances", type=float, nargs="+",
                        default=[1e-2, 1e-3])
    parser.add_argument("--lags", type=int, nargs="+", default=[1, 4])
    parser.add_argument("--demo", type=int, default=0, metavar="FRAMES",
                        help="also time the contact demo for FRAMES frames")
    add_json_argument(parser, "friction_sliding")
    args = parser.parse_args()
    results = Results("friction_sliding")
    for youngs in args.youngs:  # compile every kernel before timing
        simulate({"angle": ANGLE, "youngs": youngs, "steps": 1})
    print(f"{'E (Pa)':>7} {'mu':>4} {'tol (m/s)':>9} {'lags':>4} "
          f"{'slid (cm)':>9} {'law (cm)':>8} {'error':>7} {'closest (m)':>11} "
          f"{'Newton':>6} {'CG':>6} {'s':>5}")
    rows = []
    for youngs, mu, tol, lags in itertools.product(
            args.youngs, args.mu, args.tolerances, args.lags):
        before = newton.iteration_totals()
        start = time.perf_counter()
        out = simulate({"angle": ANGLE, "mu": mu, "youngs": youngs,
                        "steps": args.steps, "velocity_tolerance": tol,
                        "friction_iterations": lags})
        seconds = time.perf_counter() - start
        after = newton.iteration_totals()
        reference = law(mu, args.steps)
        rows.append([youngs, mu, tol, lags, 100 * float(out["slid"]),
                     100 * reference, float(out["slid"]) / reference - 1,
                     float(out["lowest"]),
                     after["newton"] - before["newton"],
                     after["cg"] - before["cg"], seconds])
        _, _, _, _, slid, law_cm, error, lowest, iterations, cg, _ = rows[-1]
        print(f"{youngs:7.0e} {mu:4.1f} {tol:9.0e} {lags:4d} "
              f"{slid:9.2f} {law_cm:8.2f} {error:+7.1%} {lowest:11.1e} "
              f"{iterations:6d} {cg:6d} {seconds:5.1f}", flush=True)
    results.table(
        "runs",
        ["E (Pa)", "mu", "tol (m/s)", "lags", "slid (cm)", "law (cm)",
         "error", "closest (m)", "Newton", "CG", "s"],
        rows,
        ["{:.0e}", "{:.1f}", "{:.0e}", "{}", "{:.2f}", "{:.2f}", "{:+.1%}",
         "{:.1e}", "{:,}", "{:,}", "{:.1f}"],
        f"{args.steps} steps from rest down a {ANGLE:g}-degree slope "
        f"(dt = {DT:g} s); law: implicit Euler's distance under Coulomb's "
        "law; closest: the closest approach to the plane; one thread.")
    # The docs' shape: a row per E and mu (E as the docs write it), a
    # column per setting; the error, and the run's Newton iterations.
    settings = list(itertools.product(args.tolerances, args.lags))
    by_run = {(r[0], r[1], r[2], r[3]): r for r in rows}
    results.table(
        "error", ["E (Pa)", "mu", *[setting(*s) for s in settings]],
        [[exponent(youngs), mu,
          *[{"error": by_run[youngs, mu, tol, lags][6],
             "newton": by_run[youngs, mu, tol, lags][8]}
            for tol, lags in settings]]
         for youngs, mu in itertools.product(args.youngs, args.mu)],
        ["", "{:.1f}", *["{0[error]:+.1%} ({0[newton]})"] * len(settings)],
        f"Error of the distance slid against Coulomb's law, and the run's "
        f"Newton iterations ({args.steps} steps), by Newton velocity "
        "tolerance and friction lags per step.")
    if args.demo:
        demo_costs(args.demo, args.tolerances, args.lags, results)
    path = results.write(args.json)
    print(f"results: {path}")


if __name__ == "__main__":
    main()
