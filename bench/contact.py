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

Part 1 runs for each ``--cells`` (table ``derivatives``, and the pair
counts and agreement in ``collisions``), part 2 for the largest (table
``newton_iteration``); the tables also go to ``--json``
(bench/results/contact.json).

    python3 bench/contact.py [--cells 4 10] [--repeat 5]
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
from benchlib.results import Results, add_json_argument  # noqa: E402
from benchlib.timing import median  # noqa: E402
from yasps import energies as E  # noqa: E402
from yasps.contact import Contact, surface_of  # noqa: E402
from yasps.runtime import cpu_backend  # noqa: E402
from yasps.sim import add_elastic_tets, box_tet_mesh  # noqa: E402
from yasps.solve import assemble  # noqa: E402

DHAT = 0.02

#: A time in the derivatives table: ms, and per pair.
TIME = "{0[ms]:.2f} ms ({0[us_per_pair]:.1f} us/pair)"


def turned(points: np.ndarray, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    return (points - 0.25) @ R.T + 0.25


def boxes(cells: int, elastic: bool, detection: str = "runtime"):
    """The two boxes in one scene, with contact (its collision detection
    ``detection``); returns the scene and the contact."""
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
                      dhat=DHAT, kappa=1.0, detection=detection)
    s.addMinimizeTarget(targets)
    return s, contact


def derivatives(cells: int, repeat: int) -> tuple:
    """Times part 1 on boxes of ``cells``^3 cells; returns its row of the
    ``derivatives`` table, the pair counts by type and the agreement."""
    # Project each pair's whole local Hessian, as ipctk does: projected in
    # the linear map's entries (the default) it differs where the barrier's
    # Hessian is indefinite (yasps.config.linear_map_projection).
    linear_map_projection = yasps.config.linear_map_projection
    yasps.config.linear_map_projection = False
    try:
        return _derivatives(cells, repeat)
    finally:
        yasps.config.linear_map_projection = linear_map_projection


def _derivatives(cells: int, repeat: int) -> tuple:
    # ipctk's detection: the pairs are its collision set's, with its
    # distance types (where a closest point is a tie between types, as for
    # the vertex on the turned box's axis at an even --cells, the types
    # decide the Hessian; the runtime's detection may choose otherwise).
    s, contact = boxes(cells, elastic=False, detection="ipctk")
    counts = contact.update()
    V = contact.world()
    collisions = contact.detection.collisions
    potential = ipctk.BarrierPotential(DHAT, 1.0)
    clamp = ipctk.PSDProjectionMethod.CLAMP
    system = assemble(s, cpu_backend(), threads=1).system
    g = np.empty(system.size)
    H = np.empty((system.size, system.size))
    system.gradient(g)
    system.dense(H)
    want_g = potential.gradient(collisions, contact.mesh, V)
    want_H = potential.hessian(collisions, contact.mesh, V,
                               project_hessian_to_psd=clamp).toarray()
    err_g = np.abs(g - want_g).max() / np.abs(want_g).max()
    err_H = np.abs(H - want_H).max() / np.abs(want_H).max()
    assert err_g < 1e-9 and err_H < 1e-9, (err_g, err_H)

    ipctk.set_num_threads(1)
    yasps.config.num_threads = 1

    def ipctk_run():
        potential.gradient(collisions, contact.mesh, V)
        potential.hessian(collisions, contact.mesh, V,
                          project_hessian_to_psd=clamp)

    def yasps_run():
        # The same positions as a new value: assemble reuses the local
        # derivatives of the point it assembled last, which is not timed.
        for x in s.minimizeTargets:
            x.updateValue(x.value)
        assemble(s, cpu_backend(), threads=1)

    ours = median(yasps_run, repeat)
    theirs = median(ipctk_run, repeat)
    pairs = sum(counts.values())
    row = [cells, pairs, {"ms": 1e3 * ours, "us_per_pair": 1e6 * ours / pairs},
           {"ms": 1e3 * theirs, "us_per_pair": 1e6 * theirs / pairs},
           theirs / ours]
    _, _, yasps_time, ipctk_time, ratio = row
    print(f"contact derivatives, {cells}^3 cells each, {pairs} pairs "
          f"({', '.join(f'{k} {n}' for k, n in counts.items())}), one thread; "
          f"agreement: gradient {err_g:.1e}, projected Hessian {err_H:.1e}")
    print(f"  yasps (local derivatives, projection, block-sparse assembly): "
          f"{TIME.format(yasps_time)}")
    print(f"  ipctk (gradient, projected Hessian, sparse assembly):        "
          f"{TIME.format(ipctk_time)}")
    print(f"  ipctk / yasps: {ratio:.2f}x")
    return row, dict(counts), (float(err_g), float(err_H))


def newton_iteration(cells: int, results: Results) -> None:
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
    pairs, iterations = sum(counts.values()), s.lastSolve["iterations"]
    results.values["newton_iteration"] = {
        "cells": cells, "pairs": pairs, "pcg_iterations": iterations,
        "step_bound": bound}
    rows = [[name, 1e3 * seconds, 100 * seconds / total]
            for name, seconds in [("collision detection", detection)] +
            list(stages.items()) + [("CCD", ccd)]]
    results.table(
        "newton_iteration", ["stage", "ms", "share"], rows,
        ["", "{:.2f}", "{:.1f}%"],
        f"One Newton iteration of the {cells}^3-cell boxes with stable "
        f"Neo-Hookean and inertia: {pairs:,} pairs, {iterations} PCG "
        f"iterations, step bound {bound:.3f}.")
    print(f"\none Newton iteration, {cells}^3 cells each, {pairs} pairs, "
          f"{iterations} PCG iterations, step bound {bound:.3f}:")
    for name, ms, share in rows:
        print(f"  {name:20} {ms:8.2f} ms  {share:5.1f}%")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cells", type=int, nargs="+", default=[4, 10],
                        help="box sizes of the derivatives table; the "
                        "Newton iteration runs on the largest")
    parser.add_argument("--repeat", type=int, default=5)
    add_json_argument(parser, "contact")
    args = parser.parse_args()
    results = Results("contact")
    rows, collisions = [], []
    for cells in args.cells:
        row, counts, errors = derivatives(cells, args.repeat)
        rows.append(row)
        collisions.append((cells, counts, errors))
    results.table(
        "derivatives",
        ["boxes", "pairs", "yasps", "ipctk", "ipctk / yasps"],
        rows, ["{}^3 cells each", "{:,}", TIME, TIME, "{:.2f}x"])
    kinds = list(dict.fromkeys(k for _, counts, _ in collisions
                               for k in counts))
    results.table(
        "collisions",
        ["boxes", *kinds, "gradient agreement",
         "projected Hessian agreement"],
        [[cells, *[counts.get(k, 0) for k in kinds], *errors]
         for cells, counts, errors in collisions],
        ["{}^3 cells each", *["{:,}"] * len(kinds), "{:.1e}", "{:.1e}"],
        "Pairs by type in ipctk's collision set, and the largest difference "
        "between yasps' and ipctk's gradients and projected Hessians "
        "(relative to the largest entry).")
    newton_iteration(max(args.cells), results)
    path = results.write(args.json)
    print(f"results: {path}")


if __name__ == "__main__":
    main()
