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

Prints milliseconds per Newton step of each stage and their ratio (table
``stages``), whether the collision sets agree (as sets of pairs with their
weights), and the step bounds both find (``agreement``). With ``--run N``
(``--run 0``: not) it then also steps the scene N frames as yasps does now
and prints seconds per frame, Newton iterations per frame, CG iterations
per Newton iteration, the unconverged frames, the closest distance,
ipctk's intersection verdict (``run``) and the time per stage
(``run_stages``). The tables also go to ``--json``
(bench/results/contact_step.json).

    python3 bench/contact_step.py [--frames 45] [--measure 5] [--run 100]
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
from benchlib.results import Results, add_json_argument  # noqa: E402
from yasps.contact.detection import (IpctkDetection,  # noqa: E402
                                     RuntimeDetection)
from yasps.contact.sweep import Sweep  # noqa: E402

#: Line-search candidates timed per step (fractions of the bounded step).
CANDIDATES = (1.0, 0.5)

#: The stages timed per Newton step, and their names in the tables.
STAGES = {"broad phase": "broad phase", "ccd": "CCD",
          "sets": "collision sets, as pair arrays"}


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


def whole_run(frames: int, results: Results) -> None:
    """Steps the twisting cloth ``frames`` frames; prints the run's
    figures."""
    mat_twist.DT["small"] = 0.01
    stepper, contact, _, _ = mat_twist.build("small")
    warnings.simplefilter("ignore")
    total = stepper.run(frames, progress=False)
    seconds = sum(v for k, v in total.seconds.items() if k != "compile")
    closest, intersecting = contact.min_distance(), contact.has_intersections()
    results.values["run"] = {
        "frames": frames, "kappa": contact.kappa,
        "unconverged": [frame for frame, _ in total.unconverged],
        "intersections": bool(intersecting)}
    row = [results.meta["commit"], seconds / frames, total.iterations / frames,
           float(np.mean(total.cg_iterations)), len(total.unconverged),
           closest, total.seconds.get("ccd", 0.0) / seconds,
           total.seconds.get("pcg", 0.0) / seconds]
    results.table(
        "run",
        ["yasps", "s/frame", "Newton/frame", "CG/Newton", "frames at the cap",
         "closest distance", "CCD", "PCG"],
        [row], ["", "{:.3f}", "{:.2f}", "{:.0f}", "{}", "{:.1e} m", "{:.0%}",
                "{:.0%}"],
        f"The twisting cloth, 625 vertices, dt = 0.01 s, {frames} frames "
        "(compiling excluded); CCD and PCG: their shares of the time. "
        f"Intersections (ipctk): {'yes' if intersecting else 'none'}.")
    _, per_frame, newton_per_frame, cg_per_newton, at_cap, _, _, _ = row
    print(f"twisting cloth, 625 vertices, dt = 0.01 s, {frames} frames: "
          f"{per_frame:.3f} s/frame (compiling excluded), "
          f"{newton_per_frame:.2f} Newton/frame, "
          f"{cg_per_newton:.0f} CG/Newton, "
          f"{at_cap} unconverged, kappa {contact.kappa:.3g}, "
          f"closest {closest:.3g} m, intersections: {intersecting}")
    rows = [[stage, value, value / seconds]
            for stage, value in total.seconds.items() if stage != "compile"]
    results.table("run_stages", ["stage", "s", "share"], rows,
                  ["", "{:.2f}", "{:.1%}"],
                  f"The time of the {frames} frames by stage (compiling "
                  "excluded).")
    for stage, value, share in rows:
        print(f"  {stage:<12}{value:8.2f} s {100 * share:6.1f}%")


def timed(fn):
    start = time.perf_counter()
    value = fn()
    return time.perf_counter() - start, value


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=45)
    parser.add_argument("--measure", type=int, default=5)
    parser.add_argument("--run", type=int, default=100,
                        help="then step this many frames and report the "
                        "run (0: not)")
    add_json_argument(parser, "contact_step")
    args = parser.parse_args()
    results = Results("contact_step")
    per_step(args.frames, args.measure, results)
    if args.run:
        print()
        whole_run(args.run, results)
    path = results.write(args.json)
    print(f"results: {path}")


def per_step(frames: int, measure: int, results: Results) -> None:
    """Both detections on the steps of the last ``measure`` of ``frames``
    frames; prints and adds the tables ``stages`` and ``agreement``."""
    contact, steps = captured_steps(frames, measure)
    schemes = {"ipctk": IpctkDetection(contact.mesh, contact.dhat),
               "runtime": RuntimeDetection(contact.mesh, contact.dhat)}
    seconds = {name: {stage: 0.0 for stage in STAGES} for name in schemes}
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
    first = frames - measure + 1
    print(f"twisting cloth, 625 vertices, frames {first}-{frames}: {count} "
          f"Newton steps, {len(CANDIDATES)} line-search candidates each")
    rows = []
    for stage, label in list(STAGES.items()) + [("total", "total")]:
        ipctk_s, runtime_s = (
            sum(seconds[name].values()) if stage == "total"
            else seconds[name][stage] for name in ("ipctk", "runtime"))
        rows.append([label, 1e3 * ipctk_s / count, 1e3 * runtime_s / count,
                     ipctk_s / runtime_s])
    results.table(
        "stages", ["stage", "ipctk", "runtime", "ipctk / runtime"], rows,
        ["", "{:.2f}", "{:.2f}", "{:.1f}x"],
        f"ms per Newton step (frames {first}-{frames}: {count} steps, "
        f"{len(CANDIDATES)} line-search candidates each).")
    print(f"{'ms per Newton step':<32}{'ipctk':>10}{'runtime':>10}"
          f"{'ratio':>8}")
    for label, ipctk_ms, runtime_ms, ratio in rows:
        print(f"{label:<32}{ipctk_ms:>10.2f}{runtime_ms:>10.2f}"
              f"{ratio:>7.1f}x")
    ipctk_bounds, runtime_bounds = np.array(bounds).reshape(-1, 2).T
    row = [agree, sets, float(np.abs(ipctk_bounds - runtime_bounds).max()),
           int((ipctk_bounds == 1).sum()), int((runtime_bounds == 1).sum()),
           count]
    results.table(
        "agreement",
        ["collision sets equal", "candidates", "largest step-bound difference",
         "steps left whole (ipctk)", "steps left whole (runtime)",
         "Newton steps"],
        [row], ["{}", "{}", "{:.2g}", "{}", "{}", "{}"])
    agree, sets, difference, whole_ipctk, whole_runtime, count = row
    print(f"collision sets equal: {agree}/{sets}; step bounds: largest "
          f"difference {difference:.2g}, steps left whole {whole_ipctk} "
          f"(ipctk) and {whole_runtime} (runtime) of {count}")


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
