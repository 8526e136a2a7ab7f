#!/usr/bin/env python3
"""Whole simulations on a GPU machine that has no compiler: the scenes'
kernels compiled ahead here into a kernel store (python/yasps/compiler/
store.py), then each scene run there on the GPU backend and on the CPU
beside it, from that store.

    python3 bench/device_sim.py prepare STORE [--scenes ...] [--chips sm_90]
                                              [--cpu x86-64-v3]
    python3 bench/device_sim.py run STORE [--scenes ...] [--frames N]
                                          [--limit S] [--json OUT]

``prepare`` (needs the compiler) writes every kernel the scenes' runs need,
CPU kernels for ``--cpu`` (any x86 machine with AVX2 by default) and GPU
kernels for ``--chips`` ("host": the stand-in driver of the tests).
``run`` steps each scene for at most ``--frames`` frames or ``--limit``
seconds per backend, each run in a process of its own, checks every frame
with ipctk, and prints per scene

    sim <scene>: <N> frames, <t> s/frame (CPU <t> s/frame), positions within <e> of the CPU's

with the Newton and CG counts and each stage's share of the frame. The CPU
runs the GPU backend's solver (block-Jacobi PCG on f64 blocks), so that
both take the same steps up to round-off.
``scripts/device_kit.sh`` puts a prepared store into the device kit and
``scripts/device_check.sh`` runs this there.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Dict, List, Tuple

import numpy as np

import benchlib

benchlib.use_this_checkout()
sys.path.insert(0, str(benchlib.ROOT / "examples"))

from benchlib.results import Results, add_json_argument  # noqa: E402

#: The scenes: the README demo, and the bunny on the pinned cloth at the
#: sizes of the scale series (bench/benchlib/stark_scenes.py).
SCENES = ("demo", "bunny", "bunny-4.3k", "bunny-28.6k", "bunny-56k")


def build(name: str) -> Tuple[object, object, object, list]:
    """(scene, stepper, contact, attributes to compile besides)."""
    if name == "demo":
        from contact_demo import build as build_demo
        scene, stepper, contact, bodies = build_demo(40, 4)
        return scene, stepper, contact, [contact.positions,
                                         bodies["rigid"].positions]
    from benchlib.stark_scenes import build_bunny
    built = build_bunny(name)
    stepper, contact = built.stepper, built.contact
    return stepper.scene, stepper, contact, [contact.positions]


def prepare(store: Path, scenes: List[str], chips: List[str],
            cpu: str) -> None:
    """Compiles every kernel of the scenes' runs into ``store``: CPU
    kernels for ``cpu``, GPU kernels for ``chips``."""
    os.environ["YASPS_KERNEL_STORE"] = str(store)
    # Every request of the scenes' building and compiling is recorded, for
    # the CPU and for the chips (a Contact computes world positions when it
    # is made, on the scene as it was then).
    os.environ["YASPS_STORE_KERNELS"] = "1"
    os.environ["YASPS_STORE_CHIPS"] = " ".join(chips)
    import yasps
    yasps.config.cpu_target = cpu or None
    for name in scenes:
        start = time.perf_counter()
        scene, _, contact, also = build(name)
        yasps.compile(scene, also=also, contact=contact, progress=False,
                      backend="cpu", store=True)
        yasps.compile(scene, also=also, contact=contact, progress=False,
                      backend="gpu", chips=chips)
        print(f"prepared {name}: CPU ({cpu or 'this host'}) and GPU "
              f"({', '.join(chips)}) kernels in "
              f"{time.perf_counter() - start:.1f} s", flush=True)
    # What scripts/device_check.sh runs from this store.
    (store / "scenes.txt").write_text(" ".join(scenes) + "\n")


def one(name: str, frames: int, limit: float, out: Path,
        tight: bool) -> None:
    """Steps one scene on the backend ``YASPS_BACKEND`` names, for at most
    ``frames`` frames or ``limit`` seconds (``tight``: to tolerances far
    below the defaults); writes per frame the seconds, Newton and CG
    counts, convergence, ipctk's verdict and the positions."""
    import ipctk
    import yasps
    if os.environ.get("YASPS_BACKEND") == "cpu":
        # The GPU backend's solver on the CPU (block-Jacobi, f64 blocks: its
        # only choices so far), so that the two runs take the same Newton
        # steps up to round-off and their positions compare.
        yasps.config.preconditioner = "block-jacobi"
        yasps.config.hessian_storage = "f64"
    scene, stepper, contact, also = build(name)
    if tight:
        # Newton and PCG far below their defaults: both backends then reach
        # each step's minimiser to within round-off, whatever the order of
        # their sums, and the positions compare to ~1e-10.
        stepper.velocity_tolerance = 1e-9
        stepper.settings = dataclasses.replace(
            stepper.settings, cg_tolerance=1e-12, cg_forcing=False,
            cg_max_iterations=20000)
    yasps.compile(scene, also=also, contact=contact, progress=False)
    rows: Dict[str, list] = {k: [] for k in ("seconds", "newton", "cg",
                                             "converged", "intersecting")}
    positions = [contact.world()]
    stages: Dict[str, float] = {}
    started = time.perf_counter()
    for _ in range(frames):
        if time.perf_counter() - started > limit:
            break
        start = time.perf_counter()
        report = stepper.step(warn=False)
        rows["seconds"].append(time.perf_counter() - start)
        rows["newton"].append(len(report.cg_iterations))
        rows["cg"].append(sum(report.cg_iterations))
        rows["converged"].append(report.converged)
        for stage, seconds in report.seconds.items():
            stages[stage] = stages.get(stage, 0.0) + seconds
        V = contact.world()
        positions.append(V)
        rows["intersecting"].append(ipctk.has_intersections(contact.mesh, V))
    backend = scene.lastSolve["backend"] if rows["seconds"] else ""
    np.savez(out, backend=np.array(backend),
             positions=np.asarray(positions),
             stage_names=np.array(list(stages)),
             stage_seconds=np.array(list(stages.values())),
             **{k: np.asarray(v, dtype=float) for k, v in rows.items()})


def _run_one(store: Path, name: str, backend: str, frames: int,
             limit: float, tight: bool,
             folder: Path) -> Dict[str, np.ndarray]:
    """One scene on one backend in a process of its own (a crash or a hang
    costs that run only); its arrays, or {"error": text}."""
    out = folder / f"{name}.{backend}.npz"
    env = dict(os.environ, YASPS_KERNEL_STORE=str(store),
               YASPS_BACKEND=backend)
    try:
        done = subprocess.run(
            [sys.executable, __file__, "one", name, str(frames), str(limit),
             str(out)] + (["--tight"] if tight else []), env=env,
            capture_output=True, text=True,
            timeout=limit + 120)
    except subprocess.TimeoutExpired:
        return {"error": np.array(f"timed out after {limit + 120:.0f} s")}
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["no output"])[-1]
        return {"error": np.array(f"exit {done.returncode}: {last}")}
    return dict(np.load(out))


def summary(name: str, gpu: Dict[str, np.ndarray],
            cpu: Dict[str, np.ndarray]) -> Tuple[str, dict]:
    """The scene's summary line, and its figures."""
    if "error" in gpu:
        return f"sim {name}: FAILED on the GPU ({gpu['error']})", {}
    frames = len(gpu["seconds"])
    per_frame = float(np.mean(gpu["seconds"])) if frames else float("nan")
    figures = {"frames": frames, "seconds_per_frame": per_frame,
               "newton_per_frame": float(np.mean(gpu["newton"])) if frames
               else 0.0,
               "cg_per_newton": float(np.sum(gpu["cg"]) /
                                      max(np.sum(gpu["newton"]), 1)),
               "unconverged": int(frames - np.sum(gpu["converged"])),
               "intersecting": int(np.sum(gpu["intersecting"])),
               "backend": str(gpu["backend"])}
    cpu_text, gap_text = "CPU failed", "no CPU run to compare"
    if "error" not in cpu and len(cpu["seconds"]):
        figures["cpu_seconds_per_frame"] = float(np.mean(cpu["seconds"]))
        cpu_text = f"CPU {figures['cpu_seconds_per_frame']:.3g} s/frame"
        common = min(len(cpu["positions"]), len(gpu["positions"])) - 1
        gap = float(np.abs(gpu["positions"][common] -
                           cpu["positions"][common]).max())
        figures["positions_gap"], figures["compared_frame"] = gap, common
        gap_text = f"positions within {gap:.1e} of the CPU's"
        if common < frames:
            gap_text += f" (at frame {common})"
    line = (f"sim {name}: {frames} frames, {per_frame:.3g} s/frame "
            f"({cpu_text}), {gap_text}")
    return line, figures


def details(gpu: Dict[str, np.ndarray]) -> str:
    """Newton and CG counts and the stages' shares of a run."""
    if "error" in gpu or not len(gpu["seconds"]):
        return ""
    total = float(np.sum(gpu["stage_seconds"])) or 1.0
    shares = ", ".join(f"{n} {100 * s / total:.0f}%" for n, s in
                       sorted(zip(gpu["stage_names"], gpu["stage_seconds"]),
                              key=lambda p: -p[1]))
    return (f"  {int(np.sum(gpu['newton']))} Newton iterations, "
            f"{int(np.sum(gpu['cg']))} CG iterations, "
            f"{int(len(gpu['converged']) - np.sum(gpu['converged']))} frames "
            f"unconverged, {int(np.sum(gpu['intersecting']))} intersecting; "
            f"stages: {shares}")


def run(store: Path, scenes: List[str], frames: int, limit: float,
        tight: bool, json_out: Path) -> int:
    folder = Path(os.environ.get("TMPDIR", "/tmp")) / "yasps-device-sim"
    folder.mkdir(parents=True, exist_ok=True)
    results, failed = {}, 0
    for name in scenes:
        gpu = _run_one(store, name, "gpu", frames, limit, tight, folder)
        frames_done = len(gpu.get("seconds", [])) or frames
        cpu = _run_one(store, name, "cpu", frames_done, limit, tight, folder)
        line, figures = summary(name, gpu, cpu)
        print(line, flush=True)
        extra = details(gpu)
        if extra:
            print(extra, flush=True)
        if "error" in cpu:
            print(f"  CPU run: {cpu['error']}", flush=True)
        failed += "FAILED" in line or bool(figures.get("intersecting"))
        results[name] = figures
    table = Results("device_sim")
    table.table("sims", ["scene", "frames", "GPU s/frame", "CPU s/frame",
                         "Newton/frame", "CG/Newton", "positions within",
                         "intersecting frames"],
                [[name, f.get("frames"), f.get("seconds_per_frame"),
                  f.get("cpu_seconds_per_frame"), f.get("newton_per_frame"),
                  f.get("cg_per_newton"), f.get("positions_gap"),
                  f.get("intersecting")] for name, f in results.items()])
    table.write(json_out)
    return 1 if failed else 0


def main() -> None:
    cli = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    commands = cli.add_subparsers(dest="command", required=True)
    p = commands.add_parser("prepare", help="compile the scenes' kernels "
                            "into a store (needs the compiler)")
    p.add_argument("store", type=Path)
    p.add_argument("--scenes", nargs="+", default=["demo"], choices=SCENES)
    p.add_argument("--chips", nargs="+", default=["sm_90"])
    p.add_argument("--cpu", default="x86-64-v3",
                   help="LLVM CPU name of the CPU kernels ('' for this host)")
    parser = commands.add_parser("run", help="run the scenes from a store")
    parser.add_argument("store", type=Path)
    parser.add_argument("--scenes", nargs="+", default=["demo"],
                        choices=SCENES)
    parser.add_argument("--frames", type=int, default=20)
    parser.add_argument("--limit", type=float, default=60.0,
                        help="seconds of stepping per scene and backend")
    parser.add_argument("--tight", action="store_true",
                        help="Newton and PCG to tolerances far below the "
                        "defaults, so that the positions compare to ~1e-10")
    add_json_argument(parser, "device_sim")
    o = commands.add_parser("one")
    o.add_argument("scene", choices=SCENES)
    o.add_argument("frames", type=int)
    o.add_argument("limit", type=float)
    o.add_argument("out", type=Path)
    o.add_argument("--tight", action="store_true")
    args = cli.parse_args()
    if args.command == "prepare":
        prepare(args.store.resolve(), args.scenes, args.chips, args.cpu)
    elif args.command == "run":
        sys.exit(run(args.store.resolve(), args.scenes, args.frames,
                     args.limit, args.tight, args.json))
    else:
        one(args.scene, args.frames, args.limit, args.out, args.tight)


if __name__ == "__main__":
    main()
