#!/usr/bin/env python3
"""Contact against ipctk: the barrier's derivatives over a collision set,
and one Newton iteration of a contact scene split by stage.

Two soft boxes of ``--cells``^3 cells x 6 tets, the upper one turned and
pressed into the barrier's range of the lower (many pairs of every type).

1. Contact derivatives, one thread each: yasps' local barrier gradients and
   PSD-projected Hessians of every pair, assembled into its block-sparse
   system (``assemble`` on a scene with only the barrier energies), against
   ipctk's ``BarrierPotential.gradient`` and ``hessian`` with per-collision
   PSD projection (clamp) into a SciPy sparse matrix, on the same collision
   set; the gradients and projected Hessians are checked to agree first.
2. One Newton iteration of the boxes with stable Neo-Hookean and inertia
   (implicit Euler, dt 0.01): collision detection, the Newton direction by
   its stages (derivatives, indices, assembly, PCG), CCD.

    python3 bench/contact.py [--cells 6] [--repeat 5]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("YASPS_CACHE_DIR", tempfile.mkdtemp(prefix="yasps-bench-"))
HERE = Path(__file__).resolve().parent
import benchlib  # noqa: E402

benchlib.use_this_checkout()

import ipctk  # noqa: E402
import numpy as np  # noqa: E402

import yasps  # noqa: E402
from benchlib.timing import median  # noqa: E402
from yasps import energies as E  # noqa: E402
from yasps.contact import Contact, surface_of  # noqa: E402
from yasps.runtime import cpu_backend  # noqa: E402
from yasps.sim import add_elastic_tets, box_tet_mesh  # noqa: E402
from yasps.solve import assemble  # noqa: E402

DHAT = 0.02


def turned(points: np.ndarray, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    return (points - 0.25) @ R.T + 0.25


def boxes(cells: int, elastic: bool):
    """The two boxes in one scene, with contact; returns the scene, the
    contact and the targets."""
    verts, tets = box_tet_mesh(cells, 0.5)
    faces = surface_of(tets)
    s = yasps.scene("boxes")
    targets, prims = [], []
    upper = turned(verts, 0.3) + [0.0, 0.0, 0.5 + 0.6 * DHAT]
    for name, start in (("lower", verts), ("upper", upper)):
        mesh = s.addMesh(name)
        v = mesh.addPrimitive("v", numInstances=len(verts))
        x = v.addAttribute("position", rows=3)
        x.updateValue(start)
        if elastic:
            add_elastic_tets(mesh, x, verts, tets, 1e5, 4e5, scale=1e-4)
            hat = v.addConstant("x_hat", rows=3)
            hat.updateValue(start + [0.0, 0.0, -1e-3])
            s.addEnergy(v.addAttribute("inertia", computed_attribute=
                                       E.inertia(x, hat, 1e-2)))
        targets.append(x)
        prims.append(v)
    union = s.addMesh("world").addPrimitiveUnion("v", prims)
    union.addAttribute("position")
    contact = Contact(s, union, faces=np.concatenate([faces, faces + len(verts)]),
                      dhat=DHAT, kappa=1.0)
    s.addMinimizeTarget(targets)
    return s, contact


def derivatives(cells: int, repeat: int) -> None:
    s, contact = boxes(cells, elastic=False)
    counts = contact.update()
    V = contact.world()
    potential = ipctk.BarrierPotential(DHAT, 1.0)
    clamp = ipctk.PSDProjectionMethod.CLAMP
    system = assemble(s, cpu_backend(), threads=1).system
    g = np.empty(system.size)
    H = np.empty((system.size, system.size))
    system.gradient(g)
    system.dense(H)
    want_g = potential.gradient(contact.collisions, contact.mesh, V)
    want_H = potential.hessian(contact.collisions, contact.mesh, V,
                               project_hessian_to_psd=clamp).toarray()
    err_g = np.abs(g - want_g).max() / np.abs(want_g).max()
    err_H = np.abs(H - want_H).max() / np.abs(want_H).max()
    assert err_g < 1e-9 and err_H < 1e-9, (err_g, err_H)

    ipctk.set_num_threads(1)
    yasps.config.num_threads = 1

    def ipctk_run():
        potential.gradient(contact.collisions, contact.mesh, V)
        potential.hessian(contact.collisions, contact.mesh, V,
                          project_hessian_to_psd=clamp)

    ours = median(lambda: assemble(s, cpu_backend(), threads=1), repeat)
    theirs = median(ipctk_run, repeat)
    pairs = sum(counts.values())
    print(f"contact derivatives, {pairs} pairs "
          f"({', '.join(f'{k} {n}' for k, n in counts.items())}), one thread; "
          f"agreement: gradient {err_g:.1e}, projected Hessian {err_H:.1e}")
    print(f"  yasps (local derivatives, projection, block-sparse assembly): "
          f"{1e3 * ours:.2f} ms ({1e9 * ours / pairs:.0f} ns/pair)")
    print(f"  ipctk (gradient, projected Hessian, sparse assembly):        "
          f"{1e3 * theirs:.2f} ms ({1e9 * theirs / pairs:.0f} ns/pair)")
    print(f"  ipctk / yasps: {theirs / ours:.2f}x")


def newton_iteration(cells: int) -> None:
    s, contact = boxes(cells, elastic=True)
    contact.update()
    s.minimizeEnergy(tolerance=1e-4)  # compile and build the structure
    start = time.perf_counter()
    counts = contact.update()
    detection = time.perf_counter() - start
    steps = [-dx for dx in s.minimizeEnergy(tolerance=1e-4)]
    stages = s.lastSolve["seconds"]
    start = time.perf_counter()
    bound = contact.step_bound(steps)
    ccd = time.perf_counter() - start
    total = detection + sum(stages.values()) + ccd
    print(f"\none Newton iteration, {sum(counts.values())} pairs, "
          f"{s.lastSolve['iterations']} PCG iterations, step bound {bound:.3f}:")
    for name, seconds in [("collision detection", detection)] + \
            list(stages.items()) + [("CCD", ccd)]:
        print(f"  {name:20} {1e3 * seconds:8.2f} ms  {100 * seconds / total:5.1f}%")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cells", type=int, default=6)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    derivatives(args.cells, args.repeat)
    newton_iteration(args.cells)


if __name__ == "__main__":
    main()
