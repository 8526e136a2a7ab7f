#!/usr/bin/env python3
"""The STARK side of bench/stark_peer.py: runs one scene through pystark,
STARK's public Python API, and writes what every frame did.

Our own code (yasps ships no STARK code): bench/stark_peer.py runs it in a
subprocess whose ``PYTHONPATH`` holds the pystark it built, with the scene
that bench/benchlib/stark_scenes.py exported from the yasps side (``scene.npz``:
the meshes, pins and held edges; ``scene.json``: the STARK constants
matched to yasps' materials):

    python3 bench/stark_driver.py SCENE_DIR --frames 100 --threads 1 \
        --codegen DIR --output RUN.npz

It imports numpy, pystark and benchlib.memory (the standard library's
own) only. The STARK settings it changes from
STARK's defaults are the ones the comparison fixes (docs/benchmarks.md,
"yasps against STARK, whole contact scenes"): the time step, gravity, no
friction, Newton's step tolerance (STARK's DoFs are velocities, so 1e-2 is
1e-2 m/s) with its residual rule off, PCG's relative tolerance, the
threads, and no frame files. ``RUN.npz`` holds per frame: ``seconds``
(wall time of STARK's time steps, its one-time initialisation and code
generation excluded; ``timer_names`` / ``timer_seconds``: STARK's own
timers over the run), ``directions`` (linear solves that gave a Newton
direction), ``cg`` (their CG iterations), ``solves`` (linear solves,
retries with more projection included), ``capped`` (solves that stopped at
STARK's CG cap), ``steps`` / ``failed`` (time steps
taken / attempts STARK rejected and retried), ``stiffness`` (its contact
stiffness) and ``positions`` (frames + 1, N, 3; the first is the start).
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import re
import sys
import time
from pathlib import Path
from typing import Dict, List, Tuple

import numpy as np

import pystark

from benchlib.memory import peak_rss_kb

#: Attempts STARK may make at one frame (failed Newton solves halve its
#: time step; stiffened contacts or pins retry it) before we give up.
MAX_ATTEMPTS = 200


def settings(spec: Dict, threads: int, codegen: Path, output: Path,
             stamp: str):
    """STARK's settings for the comparison (its defaults otherwise)."""
    s = pystark.Settings()
    s.output.simulation_name = spec["name"]
    s.output.output_directory = str(output)
    s.output.codegen_directory = str(codegen)
    # Our stamp names the log file that cg_per_step() reads.
    s.output.time_stamp = stamp
    s.output.enable_frame_writes = False
    s.output.console_verbosity = pystark.Verbosity.Summary
    s.simulation.gravity = np.asarray(spec["gravity"], dtype=float)
    s.simulation.max_time_step_size = spec["dt"]
    # Newton stops on the step alone, as yasps does: STARK's DoFs are
    # velocities, so the largest entry of the step is in m/s. Its residual
    # rule (largest gradient entry) is turned off.
    s.newton.step_tolerance = spec["velocity_tolerance"]
    s.newton.residual_tolerance_abs = 0.0
    s.newton.cg_rel_tolerance = spec["cg_tolerance"]
    s.execution.n_threads = threads
    return s


def add_cloth(sim, spec: Dict, vertices: np.ndarray, faces: np.ndarray):
    """The cloth: STARK's Neo-Hookean membrane and flat-rest bending, with
    the constants stark_scenes matched to yasps' Baraff-Witkin cloth."""
    cloth = spec["cloth"]
    params = pystark.Surface.Params()
    params.inertia.density = cloth["density"]
    params.inertia.damping = 0.0
    params.strain.elasticity_only = True
    params.strain.thickness = cloth["thickness"]
    params.strain.youngs_modulus = cloth["youngs_modulus"]
    params.strain.poissons_ratio = cloth["poissons_ratio"]
    params.strain.damping = 0.0
    params.bending.flat_rest_angle = True
    params.bending.stiffness = cloth["bending"]
    params.bending.damping = 0.0
    return sim.presets().deformables().add_surface(
        "cloth", vertices, faces, params)


def add_bunny(sim, spec: Dict, vertices: np.ndarray, tets: np.ndarray):
    """The bunny: STARK's stable Neo-Hookean tets (its surface collides)."""
    bunny = spec["bunny"]
    params = pystark.Volume.Params()
    params.inertia.density = bunny["density"]
    params.inertia.damping = 0.0
    params.strain.elasticity_only = True
    params.strain.youngs_modulus = bunny["youngs_modulus"]
    params.strain.poissons_ratio = bunny["poissons_ratio"]
    params.strain.damping = 0.0
    return sim.presets().deformables().add_volume(
        "bunny", vertices, tets, params)


def pin(sim, point_set, indices: np.ndarray, stiffness: float):
    """STARK's prescribed positions (a penalty spring per vertex, target
    where the vertex starts) on ``indices`` of ``point_set``."""
    params = pystark.EnergyPrescribedPositions.Params()
    params.stiffness = stiffness
    return sim.deformables().prescribed_positions().add(
        point_set, np.asarray(indices, dtype=np.int32), params)


class Frames:
    """What each frame did, read from STARK's logger as differences of its
    series and timers from one frame to the next."""

    def __init__(self, sim, sets: List):
        self.sim, self.sets = sim, sets
        self.logger = sim.logger()
        self.rows: Dict[str, List[float]] = {
            k: [] for k in ("seconds", "directions", "solves", "steps",
                            "failed", "stiffness")}
        self.positions = [self.world()]
        self.marks = self._counts()

    def world(self) -> np.ndarray:
        """Every vertex's position now (the cloth's, then the bunny's)."""
        return np.array([ps.get_position(i) for ps in self.sets
                         for i in range(ps.size())])

    def _counts(self) -> Dict[str, float]:
        # STARK's logger ends the process when asked for a label it has not
        # logged yet: its timers' labels say what there is.
        labels = set(self.logger.get_timer_labels())
        counts = dict.fromkeys(("directions", "solves", "initialization"),
                               0.0)
        if "initialization" in labels:
            counts["initialization"] = self.logger.get_timer_total(
                "initialization")
        if "linear_system_solve" in labels:
            # One entry per linear solve that gave a direction.
            counts.update(
                directions=len(self.logger.get_int_series("cg_iterations")),
                solves=self.logger.get_timer_count("linear_system_solve"))
        return counts

    def record(self, seconds: float, steps: int, failed: int) -> None:
        """Closes a frame that took ``seconds`` in ``steps`` time steps
        after ``failed`` rejected attempts."""
        now = self._counts()
        # The first step initialises STARK (code generation or loading the
        # compiled kernels): not part of a frame.
        seconds -= now["initialization"] - self.marks["initialization"]
        for key in ("directions", "solves"):
            self.rows[key].append(now[key] - self.marks[key])
        self.marks = now
        self.rows["seconds"].append(seconds)
        self.rows["steps"].append(steps)
        self.rows["failed"].append(failed)
        self.rows["stiffness"].append(
            self.sim.interactions().contact().get_contact_stiffness())
        self.positions.append(self.world())


def cg_per_step(log: Path, cap: int) -> List[Tuple[int, int]]:
    """Per time step STARK attempted, in order, from its log file (written
    at its default "Full" verbosity): its CG iterations and its linear
    solves that stopped at ``cap`` iterations. Each solve logs "#CG n";
    each Newton iteration "#CG: n", its CG iterations with those of the
    solves it retried with more projection (STARK's logger series counts
    only the solve that succeeded)."""
    steps: List[List[int]] = []
    for line in log.read_text().splitlines():
        if re.match(r"\s*\d+\. dt: ", line):
            steps.append([0, 0])
        if steps:
            steps[-1][0] += sum(int(n) for n in re.findall(r"#CG:\s*(\d+)", line))
            steps[-1][1] += sum(int(n) >= cap for n in
                                re.findall(r"#CG\s+(\d+)", line))
    return [(cg, capped) for cg, capped in steps]


def build(spec: Dict, arrays, threads: int, codegen: Path, output: Path,
          stamp: str):
    """The STARK scene: (simulation, point sets, held edges as (side,
    handler))."""
    sim = pystark.Simulation(settings(spec, threads, codegen, output, stamp))
    contact = pystark.EnergyFrictionalContact.GlobalParams()
    # STARK's contact distance is the sum of both sides' thicknesses.
    contact.default_contact_thickness = spec["contact"]["thickness"]
    contact.min_contact_stiffness = spec["contact"]["min_stiffness"]
    contact.friction_enabled = False
    sim.interactions().contact().set_global_params(contact)

    vertices = np.asarray(arrays["vertices"], dtype=float)
    clothed = int(spec["cloth_vertices"])
    cloth = add_cloth(sim, spec, vertices[:clothed],
                      np.asarray(arrays["cloth_faces"], dtype=np.int32))
    sets = [cloth.point_set]
    if "tets" in arrays.files:
        bunny = add_bunny(sim, spec, vertices[clothed:],
                          np.asarray(arrays["tets"], dtype=np.int32))
        sets.append(bunny.point_set)
    if len(arrays["pinned"]):
        pin(sim, cloth.point_set, arrays["pinned"], spec["pin_stiffness"])
    held = []
    if len(arrays["held"]):
        # Each held edge turns about the x axis: +speed where x > 0.
        sides = np.asarray(arrays["sides"])
        for side in (-1.0, 1.0):
            rows = np.asarray(arrays["held"])[sides == side]
            held.append((side, pin(sim, cloth.point_set, rows,
                                   spec["pin_stiffness"])))
    return sim, sets, held


def run(spec: Dict, arrays, frames: int, threads: int, codegen: Path,
        output: Path, stamp: str) -> Dict[str, np.ndarray]:
    """Steps the scene ``frames`` frames of spec["dt"]; per frame STARK
    takes as many time steps as it needs (more where it halves its step
    after a failed solve)."""
    sim, sets, held = build(spec, arrays, threads, codegen, output, stamp)
    cap = sim.settings().newton.cg_max_iterations
    speed_deg = math.degrees(spec.get("twist_speed", 0.0))
    axis = np.array([1.0, 0.0, 0.0])
    record = Frames(sim, sets)
    dt = spec["dt"]
    for frame in range(1, frames + 1):
        steps = failed = 0
        seconds = 0.0
        while sim.get_time() < frame * dt - 1e-9 * dt:
            if steps + failed >= MAX_ATTEMPTS:
                raise SystemExit(f"stark_driver: frame {frame} not done after "
                                 f"{MAX_ATTEMPTS} attempts")
            # The held edges' targets: their angle at the end of the step.
            angle = speed_deg * (sim.get_time() + sim.get_time_step_size())
            for side, handler in held:
                handler.set_transformation(np.zeros(3), side * angle, axis)
            before = sim.get_time()
            start = time.perf_counter()
            sim.run_one_time_step()
            seconds += time.perf_counter() - start
            if sim.get_time() > before:
                steps += 1
            else:
                failed += 1
        record.record(seconds, steps, failed)
        print(f"@frame {frame} {record.rows['seconds'][-1]:.4f} s, "
              f"{record.rows['directions'][-1]:.0f} directions, "
              f"{steps} steps, {failed} failed", flush=True)
    out = {k: np.asarray(v, dtype=float) for k, v in record.rows.items()}
    out["positions"] = np.asarray(record.positions)
    # Where the time went: STARK's own timers (they nest), over all frames;
    # the initialisation, with frame 0's output in it, is no frame's.
    labels = [label for label in record.logger.get_timer_labels()
              if label not in ("initialization", "write_frame")]
    out["timer_names"] = np.array(labels)
    out["timer_seconds"] = np.array([record.logger.get_timer_total(label)
                                     for label in labels])
    # STARK closes its log file when the simulation goes.
    log = output / f"{spec['name']}__{stamp}.log"
    del sim, record, sets, held
    gc.collect()
    per_step = iter(cg_per_step(log, cap))
    frames_cg = [np.sum([next(per_step) for _ in range(int(n + f))], axis=0)
                 for n, f in zip(out["steps"], out["failed"])]
    out["cg"] = np.array([cg for cg, _ in frames_cg], dtype=float)
    out["capped"] = np.array([capped for _, capped in frames_cg], dtype=float)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("scene", type=Path, help="folder with scene.npz and scene.json")
    parser.add_argument("--frames", type=int, required=True)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--codegen", type=Path, required=True,
                        help="STARK's code generation folder (kept between runs)")
    parser.add_argument("--output", type=Path, required=True, help="the .npz to write")
    args = parser.parse_args()
    spec = json.loads((args.scene / "scene.json").read_text())
    arrays = np.load(args.scene / "scene.npz")
    # STARK's log and YAML files go beside the output, named after it.
    result = run(spec, arrays, args.frames, args.threads, args.codegen,
                 args.output.parent / f"stark-{spec['name']}",
                 args.output.stem)
    # The process's peak resident memory (kB): mesh, matrices and code.
    result["peak_rss_kb"] = np.array(peak_rss_kb())
    np.savez(args.output, **result)


if __name__ == "__main__":
    sys.exit(main())
