#!/usr/bin/env python3
"""Collision detection per Newton step, by ipctk and by the runtime: on
the steps the twisting cloth (examples/paper/mat_twist.py at dt = 0.01 s,
in heavy self-contact) really takes, the same positions are given to both
of yasps.contact.detection's schemes, each with one broad phase per step
(:mod:`yasps.contact.sweep`):

- *ipctk*: ipctk's broad phase over the step's swept boxes, its additive
  CCD over those candidates, its collision sets at the line-search
  candidates as narrow phases over them, and the Python conversion of its
  collisions into pair arrays (:func:`yasps.contact.pairs.collision_pairs`);
- *runtime* (the default): the runtime's C++ broad phase, additive CCD and
  collision sets, which hand over the pair arrays directly.

Prints milliseconds per Newton step of each stage and their ratio, whether
the collision sets agree (as sets of pairs with their weights), and the
step bounds both find. With ``--run N`` it instead steps the scene N frames
as yasps does now and prints seconds per frame, Newton iterations per
frame, CG iterations per Newton iteration, the unconverged frames, the
closest distance, ipctk's intersection verdict and the time per stage.

    python3 bench/contact_step.py [--frames 45] [--measure 5] [--run N]
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
import benchlib  # noqa: E402

benchlib.use_this_checkout()
sys.path.insert(0, str(REPO / "examples" / "paper"))

import mat_twist  # noqa: E402
from yasps.contact.detection import (IpctkDetection,  # noqa: E402
                                     RuntimeDetection)
from yasps.contact.sweep import Sweep  # noqa: E402

#: Line-search candidates timed per step (fractions of the bounded step).
CANDIDATES = (1.0, 0.5)


def captured_steps(frames: int, measure: int):
    """Runs the twisting cloth; returns its contact and the (V0, V1) of
    every Newton step in the last ``measure`` frames."""
    mat_twist.DT["small"] = 0.01
    stepper, contact, _, _ = mat_twist.build("small")
    steps = []
    original = contact.step_bound_and_length

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
    contact.step_bound_and_length = recording
    warnings.simplefilter("ignore")
    for frame in range(1, frames + 1):
        recording.on = frame > frames - measure
        stepper.step(warn=False)
    return contact, steps


def whole_run(frames: int) -> None:
    """Steps the twisting cloth ``frames`` frames; prints the run's
    figures."""
    mat_twist.DT["small"] = 0.01
    stepper, contact, _, _ = mat_twist.build("small")
    warnings.simplefilter("ignore")
    total = stepper.run(frames, progress=False)
    seconds = sum(v for k, v in total.seconds.items() if k != "compile")
    print(f"twisting cloth, 625 vertices, dt = 0.01 s, {frames} frames: "
          f"{seconds / frames:.3f} s/frame (compiling excluded), "
          f"{total.iterations / frames:.2f} Newton/frame, "
          f"{np.mean(total.cg_iterations):.0f} CG/Newton, "
          f"{len(total.unconverged)} unconverged, kappa {contact.kappa:.3g}, "
          f"closest {contact.min_distance():.3g} m, intersections: "
          f"{contact.has_intersections()}")
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
    schemes = {"ipctk": IpctkDetection(contact.mesh, contact.dhat),
               "runtime": RuntimeDetection(contact.mesh, contact.dhat)}
    seconds = {name: {"broad phase": 0.0, "ccd": 0.0, "sets": 0.0}
               for name in schemes}
    bounds, agree, sets = [], 0, 0
    for V0, V1, _ in steps:
        found = {}
        for name, scheme in schemes.items():
            spent, sweep = timed(lambda: Sweep(scheme.candidates, V0, V1,
                                               contact.dhat))
            seconds[name]["broad phase"] += spent
            spent, bound = timed(lambda: scheme.swept_bound(sweep, V0, V1))
            seconds[name]["ccd"] += spent
            found[name] = []
            for fraction in CANDIDATES:
                V = V0 + fraction * bound * (V1 - V0)
                spent, pairs = timed(lambda: scheme.pairs(V, sweep))
                seconds[name]["sets"] += spent
                found[name].append(pair_rows(pairs[0]))
            bounds.append(bound)
        sets += len(CANDIDATES)
        agree += sum(a == b for a, b in zip(found["ipctk"], found["runtime"]))
    count = len(steps)
    print(f"twisting cloth, 625 vertices, frames {args.frames - args.measure + 1}"
          f"-{args.frames}: {count} Newton steps, {len(CANDIDATES)} "
          f"line-search candidates each")
    print(f"{'ms per Newton step':<24}{'ipctk':>10}{'runtime':>10}")
    for stage in ("broad phase", "ccd", "sets"):
        print(f"{stage:<24}{1e3 * seconds['ipctk'][stage] / count:>10.2f}"
              f"{1e3 * seconds['runtime'][stage] / count:>10.2f}")
    totals = {name: sum(s.values()) for name, s in seconds.items()}
    print(f"{'total':<24}{1e3 * totals['ipctk'] / count:>10.2f}"
          f"{1e3 * totals['runtime'] / count:>10.2f}   ratio "
          f"{totals['ipctk'] / totals['runtime']:.1f}x")
    ipctk_bounds, runtime_bounds = np.array(bounds).reshape(-1, 2).T
    print(f"collision sets equal: {agree}/{sets}; step bounds: largest "
          f"difference {np.abs(ipctk_bounds - runtime_bounds).max():.2g}, "
          f"steps left whole {int((ipctk_bounds == 1).sum())} (ipctk) and "
          f"{int((runtime_bounds == 1).sum())} (runtime) of {count}")


def pair_rows(found) -> dict:
    """Pair arrays as sets of (vertices, weight) per kind, the two edges of
    an edge-edge pair unordered (the broad phases list pairs either way
    round)."""
    out = {}
    for kind, pairs in found.items():
        rows = set()
        for ids, weight in zip(pairs.vertices.tolist(), pairs.weight):
            if kind in ("vv", "ee"):
                ids = sorted([sorted(ids[:2]), sorted(ids[2:])]) \
                    if kind == "ee" else sorted(ids)
            elif kind == "ee_vv":
                ids = sorted([ids[:2], ids[2:]])
            rows.add((str(ids), float(weight)))
        out[kind] = rows
    return out


if __name__ == "__main__":
    main()
