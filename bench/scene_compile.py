#!/usr/bin/env python3
"""Time to first frame per scene: building the scene and ``yasps.compile``,
cold (a fresh process and an empty kernel cache) and warm (a new process
with the cache the cold run left), with the kernel count. Building cold
includes compiling what building computes (Contact's world positions for
its collision mesh).

Scenes: the README demo (examples/contact_demo.py), a stack of three small
bodies with contact and friction (about 200 vertices), and the paper's
scenes of examples/paper at small scale (the repulsive curve, which has no
Newton system of this kind, is left out). Each measurement runs in a
process of its own, ``--repeat`` times; the table has the medians.

    python3 bench/scene_compile.py [--repeat 2] [--scenes demo,three,...]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO / "python"), str(REPO / "examples"),
                str(REPO / "examples" / "paper")]

SCENES = ["demo", "three", "cloths_on_bunny", "many_bunnies",
          "caged_bunny_tet4", "caged_bunny_hex8", "mixed_materials",
          "pendulum", "mat_twist"]


def _three_bodies():
    """A pinned cloth (81 vertices), a soft box and an affine box (64 each),
    with contact and friction: 209 vertices."""
    import numpy as np

    import yasps
    from yasps.contact import Contact, surface_of
    from yasps.sim import (add_affine_body, add_cloth, add_elastic_tets,
                           add_free_vertices, box_tet_mesh, cloth_grid,
                           lumped_masses)
    dt = 0.01
    s = yasps.scene("three")
    cv, cf = cloth_grid(8, size=1.0)
    masses = lumped_masses(cv, cf, 0.5)
    cloth = s.addMesh("cloth")
    c = add_free_vertices(cloth, cv, masses)
    add_cloth(cloth, c.x, cv, cf, stretch=2e3, shear=2e2, bending=1e-3,
              scale=dt * dt)
    bv, bt = box_tet_mesh(3, size=0.2)
    faces = surface_of(bt)
    soft = s.addMesh("soft")
    start = bv + [-0.3, -0.1, 0.05]
    b = add_free_vertices(soft, start, lumped_masses(bv, bt, 200.0))
    add_elastic_tets(soft, b.x, start, bt, 1.8e4, 3.6e4, scale=dt * dt)
    body = add_affine_body(s.addMesh("rigid"), bv - 0.1,
                           lumped_masses(bv, bt, 200.0), stiffness=800.0,
                           scale=dt * dt, translation=(0.2, 0.1, 0.2))
    union = s.addMesh("all").addPrimitiveUnion(
        "v", [c.primitive, b.primitive, body.vertices])
    union.addAttribute("position")
    n_c, n_b = len(cv), len(bv)
    contact = Contact(s, union, faces=np.concatenate(
        [cf, faces + n_c, faces + n_c + n_b]), dhat=2e-3,
        average_mass=float(np.mean(masses)), friction=0.2)
    s.addMinimizeTarget([c.x, b.x, body.A, body.t])
    return s, [contact.positions]


def _built(name: str):
    """(scene, attributes to compile besides its energies)."""
    if name == "demo":
        import contact_demo
        s, _, contact, bodies = contact_demo.build(40, 4)
        return s, [contact.positions, bodies["rigid"].positions]
    if name == "three":
        return _three_bodies()
    if name == "pendulum":
        import pendulum
        s, _ = pendulum.build()
        return s, []
    if name.startswith("caged_bunny"):
        import caged_bunny
        stepper, contact, bodies, _ = caged_bunny.build(
            "small", name.rsplit("_", 1)[1], 6)
    else:
        module = __import__(name)
        extra = {"cloths_on_bunny": (1,), "many_bunnies": (4,)}
        stepper, contact, bodies, *_ = module.build("small",
                                                    *extra.get(name, ()))
    shown = [b.positions for b in bodies.values()
             if b.positions.kind not in ("data", "constant")]
    return stepper.scene, [contact.positions] + shown


def worker(name: str) -> dict:
    """In a fresh process: builds the scene and compiles it."""
    import yasps
    start = time.perf_counter()
    s, also = _built(name)
    built = time.perf_counter() - start
    summary = yasps.compile(s, also=also, progress=False)
    return {"build": built, "compile": summary.seconds,
            "kernels": summary.kernels, "compiled": summary.compiled}


def run_worker(name: str, cache: str) -> dict:
    env = dict(os.environ, YASPS_CACHE_DIR=cache)
    done = subprocess.run([sys.executable, __file__, "--worker", name],
                          env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{name}: {done.stderr[-2000:]}")
    return json.loads(done.stdout.splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--scenes", default=",".join(SCENES))
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(args.worker)))
        return
    print("| scene | build, cold (s) | build, warm (s) | kernels | "
          "compile, cold (s) | compile, warm (s) |")
    print("| --- | --- | --- | --- | --- | --- |")
    for name in args.scenes.split(","):
        cold, warm = [], []
        for _ in range(args.repeat):
            with tempfile.TemporaryDirectory() as cache:
                cold.append(run_worker(name, cache))
                warm.append(run_worker(name, cache))
        assert all(w["compiled"] == 0 for w in warm), f"{name} recompiled"

        def median(runs, key):
            return statistics.median(r[key] for r in runs)

        print(f"| {name} | {median(cold, 'build'):.2f} | "
              f"{median(warm, 'build'):.2f} | {cold[0]['kernels']} | "
              f"{median(cold, 'compile'):.2f} | "
              f"{median(warm, 'compile'):.2f} |", flush=True)


if __name__ == "__main__":
    main()
