#!/usr/bin/env python3
"""A stack on the ground: a soft box, an affine box on it and a caged soft
ball on top, three parameterisations in one contact, settling under
gravity. Written with the package's helpers only.

    python3 examples/scenes/stack.py [--frames 100] [--cells 3]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "python"))

import yasps  # noqa: E402
from yasps.contact import Contact, surface_of  # noqa: E402
from yasps.sim import (Body, ImplicitEuler, add_affine_body,  # noqa: E402
                       add_caged_body, add_elastic_tets, add_free_vertices,
                       box_tet_mesh, contact_union, lame, lumped_masses,
                       simulate, sphere_surface, tetrahedralize)

DT, G = 0.01, (0.0, 0.0, -9.81)


def build(cells: int = 3):
    """(stepper, contact, bodies)."""
    s = yasps.scene("stack")
    bv, bt = box_tet_mesh(cells, 0.2)
    soft_start = bv + [-0.1, -0.1, 1e-3]
    soft_mesh = s.addMesh("soft")
    soft = add_free_vertices(soft_mesh, soft_start,
                             lumped_masses(bv, bt, 500.0))
    add_elastic_tets(soft_mesh, soft.x, soft_start, bt, *lame(1e5, 0.4),
                     scale=DT * DT)
    rigid = add_affine_body(s.addMesh("rigid"), bv * 0.8 + [-0.08, -0.06, 0.21],
                            lumped_masses(bv * 0.8, bt, 500.0), 1e5,
                            scale=DT * DT)
    sv, sf = sphere_surface(0.07, 2, centre=(0.01, 0.0, 0.45))
    tv, tt = tetrahedralize(sv, sf)
    ball = add_caged_body(s.addMesh("ball"), tv, sf, lumped_masses(tv, tt,
                          300.0), cells=2, mu=2e4, lam=5e4, scale=DT * DT)
    union, faces = contact_union(s, [(soft.primitive, surface_of(bt)),
                                     (rigid.vertices, surface_of(bt)),
                                     (ball.points, ball.faces)])
    contact = Contact(s, union, faces=faces, dhat=1e-3, friction=0.3,
                      halfspaces=[((0, 0, 0), (0, 0, 1))])
    targets = [soft.x, rigid.A, rigid.t, ball.corners.x]
    s.addMinimizeTarget(targets)
    stepper = ImplicitEuler(
        s, targets=targets, predicted=[soft.x_hat, rigid.A_hat, rigid.t_hat,
                                       ball.corners.x_hat],
        dt=DT, gravity=[G, None, G, G], contact=contact)
    bodies = {"soft": Body(soft.x, surface_of(bt), (0.35, 0.6, 0.9)),
              "rigid": Body(rigid.vertices["position"], surface_of(bt),
                            (0.9, 0.45, 0.35)),
              "ball": Body(ball.positions, ball.faces, (0.55, 0.8, 0.5))}
    return stepper, contact, bodies


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--cells", type=int, default=3)
    parser.add_argument("--output", type=Path, default=Path("out/scenes/stack"))
    args = parser.parse_args()
    stepper, contact, bodies = build(args.cells)
    summary = simulate(stepper, bodies, args.frames, args.output,
                       contact=contact)
    print(summary.line())
    sys.exit(1 if summary.intersections else 0)


if __name__ == "__main__":
    main()
