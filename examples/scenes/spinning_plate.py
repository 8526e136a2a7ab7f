#!/usr/bin/env python3
"""A cloth dragged round by a spinning plate: a motor turns an affine plate
at a set rate (prescribed motion) and friction takes the cloth lying on it
along. Written with the package's helpers only.

    python3 examples/scenes/spinning_plate.py [--frames 100] [--cells 24]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "python"))

import yasps  # noqa: E402
from yasps.contact import Contact, surface_of  # noqa: E402
from yasps.sim import (Body, ImplicitEuler, add_affine_body,  # noqa: E402
                       add_cloth, add_free_vertices, box_tet_mesh, cloth_grid,
                       contact_union, lumped_masses, rotation_matrices,
                       simulate)

DT, RATE = 0.01, 2.0     # s, rad/s


def build(cells: int = 24):
    """(stepper, contact, bodies)."""
    s = yasps.scene("spinning_plate")
    pv, pt = box_tet_mesh(4, 0.6)
    pv = pv * [1.0, 1.0, 0.1] - [0.3, 0.3, 0.06]         # top face at z = 0
    plate = add_affine_body(s.addMesh("plate"), pv,
                            lumped_masses(pv, pt, 1000.0), 1e5, scale=DT * DT)
    cv, cf = cloth_grid(cells, size=0.8, height=2e-3)   # hangs over
    cloth_mesh = s.addMesh("cloth")
    cloth = add_free_vertices(cloth_mesh, cv, lumped_masses(cv, cf, 0.2))
    add_cloth(cloth_mesh, cloth.x, cv, cf, stretch=2e3, shear=2e2,
              bending=1e-3, scale=DT * DT)
    union, faces = contact_union(s, [(plate.vertices, surface_of(pt)),
                                     (cloth.primitive, cf)])
    contact = Contact(s, union, faces=faces, dhat=1e-3, friction=0.5)
    targets = [plate.A, plate.t, cloth.x]
    s.addMinimizeTarget(targets)
    stepper = ImplicitEuler(
        s, targets=targets, predicted=[plate.A_hat, plate.t_hat, cloth.x_hat],
        dt=DT, gravity=[None, None, (0, 0, -9.81)],
        fixed=[None, np.ones(1, bool), None], contact=contact)
    A0 = plate.A.value[0].copy()
    stepper.prescribe(plate.A, lambda time: rotation_matrices(
        [0.0, 0.0, RATE * time])[0] @ A0)                 # the motor
    bodies = {"plate": Body(plate.vertices["position"], surface_of(pt),
                            (0.5, 0.55, 0.6)),
              "cloth": Body(cloth.x, cf, (0.85, 0.45, 0.35))}
    return stepper, contact, bodies


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--cells", type=int, default=24)
    parser.add_argument("--output", type=Path,
                        default=Path("out/scenes/spinning_plate"))
    args = parser.parse_args()
    stepper, contact, bodies = build(args.cells)
    summary = simulate(stepper, bodies, args.frames, args.output,
                       contact=contact, view=(35.0, -60.0))
    print(summary.line())
    sys.exit(1 if summary.intersections else 0)


if __name__ == "__main__":
    main()
