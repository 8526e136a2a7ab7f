#!/usr/bin/env python3
"""Collision detection per Newton step, before and after one broad phase
per step: on the steps the twisting cloth (examples/paper/mat_twist.py at
dt = 0.01 s, in heavy self-contact) really takes, the same positions are
given to

- *per query* (yasps before): ipctk's CCD with its own broad phase and
  Tight Inclusion narrow phase, and a full collision-set build (broad phase
  included) at each line-search candidate;
- *per step* (yasps now, :mod:`yasps.contact.sweep`): one broad phase over
  the step's swept boxes, ipctk's additive CCD over its candidates, and
  collision sets at the candidates as narrow phases over them.

Prints seconds per Newton step of each and their ratio, the step bounds
both find, and the pairs-to-primitives conversion the line search pays.
With ``--run N`` it instead steps the scene N frames as yasps does now and
prints seconds per frame, Newton iterations per frame, CG iterations per
Newton iteration, the unconverged frames, the closest distance, ipctk's
intersection verdict and the time per stage.

    python3 bench/contact_step.py [--frames 45] [--measure 5] [--run N]
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import ipctk
import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "examples" / "paper"))

import mat_twist  # noqa: E402
from yasps.contact import MIN_SEPARATION, NARROW_PHASE_CCD  # noqa: E402
from yasps.contact.sweep import Sweep  # noqa: E402

#: Line-search candidates timed per step (fractions of the bounded step).
CANDIDATES = (1.0, 0.5)


def captured_steps(frames: int, measure: int):
    """Runs the twisting cloth; returns its contact and the (V0, V1) of
    every Newton step in the last ``measure`` frames."""
    mat_twist.DT["small"] = 0.01
    stepper, contact, _, twister = mat_twist.build("small")
    steps = []
    original = contact.stepBoundAndLength

    def recording(directions, *args):
        V0 = contact.world()
        result = original(directions, *args)
        if recording.on:
            before = [t.value for t in contact.scene.minimizeTargets]
            for t, x, p in zip(contact.scene.minimizeTargets, before,
                               directions):
                t.updateValue(x + p.reshape(x.shape))
            steps.append((V0, contact.world(), result[0]))
            for t, x in zip(contact.scene.minimizeTargets, before):
                t.updateValue(x)
        return result

    recording.on = False
    contact.stepBoundAndLength = recording
    twister.advance()
    warnings.simplefilter("ignore")
    for frame in range(1, frames + 1):
        recording.on = frame > frames - measure
        stepper.step(warn=False)
        twister.advance()
    return contact, steps


def whole_run(frames: int) -> None:
    """Steps the twisting cloth ``frames`` frames; prints the run's
    figures."""
    mat_twist.DT["small"] = 0.01
    stepper, contact, _, twister = mat_twist.build("small")
    twister.advance()
    warnings.simplefilter("ignore")
    total = stepper.run(frames, on_frame=lambda frame, report:
                        twister.advance(), progress=False)
    seconds = sum(v for k, v in total.seconds.items() if k != "compile")
    print(f"twisting cloth, 625 vertices, dt = 0.01 s, {frames} frames: "
          f"{seconds / frames:.3f} s/frame (compiling excluded), "
          f"{total.iterations / frames:.2f} Newton/frame, "
          f"{np.mean(total.cgIterations):.0f} CG/Newton, "
          f"{len(total.unconverged)} unconverged, kappa {contact.kappa:.3g}, "
          f"closest {contact.minDistance():.3g} m, intersections: "
          f"{contact.hasIntersections()}")
    for stage, value in total.seconds.items():
        if stage != "compile":
            print(f"  {stage:<12}{value:8.2f} s {100 * value / seconds:6.1f}%")


def timed(fn):
    start = time.perf_counter()
    value = fn()
    return time.perf_counter() - start, value


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=45)
    parser.add_argument("--measure", type=int, default=5)
    parser.add_argument("--run", type=int, default=0,
                        help="step this many frames and report the run")
    args = parser.parse_args()
    if args.run:
        whole_run(args.run)
        return
    contact, steps = captured_steps(args.frames, args.measure)
    mesh, dhat = contact.mesh, contact.dhat
    old = {"ccd": 0.0, "sets": 0.0}
    new = {"broad phase": 0.0, "ccd": 0.0, "sets": 0.0}
    pairs_seconds, bounds = 0.0, []
    for V0, V1, _ in steps:
        seconds, old_bound = timed(lambda: ipctk.compute_collision_free_stepsize(
            mesh, V0, V1))
        old["ccd"] += seconds
        seconds, sweep = timed(lambda: Sweep(mesh, V0, V1, dhat))
        new["broad phase"] += seconds
        seconds, new_bound = timed(
            lambda: sweep.candidates.compute_collision_free_stepsize(
                mesh, V0, V1, min_distance=MIN_SEPARATION,
                narrow_phase_ccd=NARROW_PHASE_CCD))
        new["ccd"] += seconds
        bounds.append((old_bound, new_bound))
        for fraction in CANDIDATES:
            V = V0 + fraction * new_bound * (V1 - V0)
            full, reused = ipctk.NormalCollisions(), ipctk.NormalCollisions()
            old["sets"] += timed(lambda: full.build(mesh, V, dhat))[0]
            new["sets"] += timed(lambda: reused.build(sweep.candidates, mesh,
                                                      V, dhat))[0]
            contact.collisions = reused
            pairs_seconds += timed(lambda: contact._normal_pairs(V))[0]
    count = len(steps)
    old_total, new_total = sum(old.values()), sum(new.values())
    print(f"twisting cloth, 625 vertices, frames {args.frames - args.measure + 1}"
          f"-{args.frames}: {count} Newton steps, {len(CANDIDATES)} "
          f"line-search candidates each")
    print(f"{'per step, ms':<34}{'per query':>12}{'per step':>12}")
    print(f"{'broad phase (own)':<34}{'-':>12}"
          f"{1e3 * new['broad phase'] / count:>12.2f}")
    print(f"{'CCD':<34}{1e3 * old['ccd'] / count:>12.2f}"
          f"{1e3 * new['ccd'] / count:>12.2f}")
    print(f"{'collision sets':<34}{1e3 * old['sets'] / count:>12.2f}"
          f"{1e3 * new['sets'] / count:>12.2f}")
    print(f"{'total':<34}{1e3 * old_total / count:>12.2f}"
          f"{1e3 * new_total / count:>12.2f}   ratio "
          f"{old_total / new_total:.1f}x")
    print(f"pairs to primitives (Python): {1e3 * pairs_seconds / count:.2f} "
          f"ms per step")
    old_bounds, new_bounds = np.array(bounds).T
    print(f"step bounds: Tight Inclusion median {np.median(old_bounds):.3f}, "
          f"additive median {np.median(new_bounds):.3f}; steps both leave "
          f"whole: {int(((old_bounds == 1) & (new_bounds == 1)).sum())}/{count}")


if __name__ == "__main__":
    main()
