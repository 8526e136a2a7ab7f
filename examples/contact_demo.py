#!/usr/bin/env python3
"""A soft box and an affine box fall onto a cloth pinned at its corners.

Three parameterisations in one contact: free cloth vertices (Baraff-Witkin
stretch and shear, dihedral bending), free soft-body vertices (stable
Neo-Hookean) and the vertices of an affine body (A rest + t, ABD's
orthogonality energy), all in one UNION whose world positions
`yasps.contact.Contact` hands to ipctk. IPC's barrier with its adaptive
stiffness and lagged friction act on every pair; implicit Euler takes
Newton steps over the four targets (cloth, soft, A, t) with CCD step bounds.

    python3 examples/contact_demo.py [--frames 50] [--cloth 40] [--output out/contact]

Writes a ParaView series per body (`<output>/<body>.pvd`), a picture of
chosen frames (`frames.png`), a video (`contact.mp4`, or a GIF without
ffmpeg), and prints a progress bar and the time per stage.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))

import yasps  # noqa: E402
from yasps.contact import Contact, surface_of  # noqa: E402
from yasps.sim import (Body, ImplicitEuler, add_affine_body,  # noqa: E402
                       add_cloth, add_elastic_tets, add_free_vertices,
                       box_tet_mesh, cloth_corners, cloth_grid, lumped_masses,
                       simulate)

DT = 0.01
DENSITY = 200.0  # of both boxes, kg/m^3: 1.6 kg each
GRAVITY = np.array([0.0, 0.0, -9.81])


def build(cloth_cells: int, box_cells: int):
    """The scene: (scene, stepper, contact, {body: Body})."""
    s = yasps.scene("contact_demo")
    # Cloth: 1 m square at z = 0, 0.5 kg/m^2, pinned at its four corners.
    cv, cf = cloth_grid(cloth_cells, size=1.0)
    cloth_masses = lumped_masses(cv, cf, 0.5)
    cloth = s.addMesh("cloth")
    c = add_free_vertices(cloth, cv, cloth_masses)
    add_cloth(cloth, c.x, cv, cf, stretch=2e3, shear=2e2, bending=1e-3,
              scale=DT * DT)
    pinned = np.zeros(len(cv), dtype=bool)
    pinned[cloth_corners(cloth_cells)] = True
    # Soft box: 20 cm, Young's modulus 5e4, Poisson 0.4.
    bv, bt = box_tet_mesh(box_cells, size=0.2)
    faces = surface_of(bt)
    young, poisson = 5e4, 0.4
    mu = young / (2 * (1 + poisson))
    lam = young * poisson / ((1 + poisson) * (1 - 2 * poisson))
    soft = s.addMesh("soft")
    soft_start = bv + [-0.3, -0.1, 0.05]
    b = add_free_vertices(soft, soft_start, lumped_masses(bv, bt, DENSITY))
    add_elastic_tets(soft, b.x, soft_start, bt, mu, lam, scale=DT * DT)
    # Affine box: the same mesh, its vertices A (rest) + t.
    rigid = s.addMesh("rigid")
    body = add_affine_body(rigid, bv - 0.1, lumped_masses(bv, bt, DENSITY),
                           stiffness=1e5 * 0.2 ** 3, scale=DT * DT,
                           translation=(0.2, 0.1, 0.2))
    union = s.addMesh("all").addPrimitiveUnion(
        "v", [c.primitive, b.primitive, body.vertices])
    union.addAttribute("position")
    n_c, n_b = len(cv), len(bv)
    contact = Contact(s, union, faces=np.concatenate(
        [cf, faces + n_c, faces + n_c + n_b]), dhat=2e-3,
        average_mass=float(np.mean(cloth_masses)), friction=0.2)
    targets = [c.x, b.x, body.A, body.t]
    s.addMinimizeTarget(targets)
    stepper = ImplicitEuler(s, targets=targets,
                            predicted=[c.x_hat, b.x_hat, body.A_hat,
                                       body.t_hat], dt=DT,
                            gravity=[GRAVITY, GRAVITY, None, GRAVITY],
                            fixed=[pinned, None, None, None], contact=contact)
    bodies = {"cloth": Body(c.x, cf, (0.85, 0.75, 0.55)),
              "soft": Body(b.x, faces, (0.35, 0.6, 0.9)),
              "rigid": Body(body.vertices["position"], faces, (0.9, 0.45, 0.35))}
    return s, stepper, contact, bodies


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=50)
    parser.add_argument("--cloth", type=int, default=40,
                        help="cloth cells per side")
    parser.add_argument("--box", type=int, default=4, help="box cells per side")
    parser.add_argument("--output", type=Path, default=Path("out/contact"))
    args = parser.parse_args()

    start = time.perf_counter()
    s, stepper, contact, bodies = build(args.cloth, args.box)
    print(f"built the scene in {time.perf_counter() - start:.2f} s")
    # Every kernel compiled (or loaded from the disk cache) up front, with a
    # progress bar, the contact's force queries included; the time steps
    # then compile nothing.
    summary = yasps.compile(s, also=[contact.positions,
                                     bodies["rigid"].positions],
                            contact=contact)
    if not summary.compiled:  # else yasps.compile printed it
        print(summary.line())
    count = sum(len(b.now()) for b in bodies.values())
    print(f"{count} vertices: cloth {args.cloth}x{args.cloth} cells, a soft and "
          f"an affine box of {args.box}^3 cells; dt = {DT} s")
    summary = simulate(stepper, bodies, args.frames, args.output,
                       contact=contact,
                       bounds=((-0.55, -0.55, -0.35), (0.55, 0.55, 0.45)))
    print(summary.line())
    print(summary.stages())
    print(f"wrote {args.output}/*.pvd (ParaView), frame_*.png and "
          f"{summary.files['video'].name}")
    if summary.intersections:
        sys.exit(1)


if __name__ == "__main__":
    main()
