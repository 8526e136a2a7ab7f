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

from sweep_slope import DT, simulate  # noqa: E402

newton = importlib.import_module("yasps.sim.newton")
ANGLE = 30.0


def law(mu: float, steps: int) -> float:
    """Implicit Euler's distance under Coulomb's law from rest."""
    theta = np.radians(ANGLE)
    a = 9.81 * (np.sin(theta) - mu * np.cos(theta))
    return max(a, 0.0) * DT * DT * steps * (steps + 1) / 2


def demo_costs(frames: int, tolerances, lags_options) -> None:
    """Times the contact demo's frames at each setting."""
    import contact_demo
    from yasps.sim import ImplicitEuler

    print(f"\ncontact demo, {frames} frames: {'tol (m/s)':>9} {'lags':>4} "
          f"{'Newton':>6} {'CG':>7} {'s':>6}")
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
        print(f"{'':>29} {tol:9.0e} {lags:4d} {total.iterations:6d} "
              f"{sum(total.cg_iterations):7d} {seconds:6.1f}", flush=True)


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
    args = parser.parse_args()
    for youngs in args.youngs:  # compile every kernel before timing
        simulate({"angle": ANGLE, "youngs": youngs, "steps": 1})
    print(f"{'E (Pa)':>7} {'mu':>4} {'tol (m/s)':>9} {'lags':>4} "
          f"{'slid (cm)':>9} {'law (cm)':>8} {'error':>7} {'closest (m)':>11} "
          f"{'Newton':>6} {'CG':>6} {'s':>5}")
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
        print(f"{youngs:7.0e} {mu:4.1f} {tol:9.0e} {lags:4d} "
              f"{100 * out['slid']:9.2f} {100 * reference:8.2f} "
              f"{out['slid'] / reference - 1:+7.1%} {out['lowest']:11.1e} "
              f"{after['newton'] - before['newton']:6d} "
              f"{after['cg'] - before['cg']:6d} {seconds:5.1f}", flush=True)
    if args.demo:
        demo_costs(args.demo, args.tolerances, args.lags)


if __name__ == "__main__":
    main()
