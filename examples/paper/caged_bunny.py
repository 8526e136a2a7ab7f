#!/usr/bin/env python3
"""Caged bunny (paper 9.3, Fig. 16, appendix G).

A surface bunny whose every vertex is trilinear in the 8 corners of the
cage cell around it falls onto a cloth pinned at its corners. The cage's
corners are the targets (with the bunny's mass moved onto them through the
same weights); stable Neo-Hookean acts on the cage, as 6 tets per cell
(`--cage tet4`) or with 8 Gauss points per cell (`--cage hex8`). Only the
bunny's surface collides: the cage deforms to keep it out of the cloth.

    python3 examples/paper/caged_bunny.py [--frames 60] [--cage tet4|hex8]
        [--cells 6] [--scale small|paper] [--output DIR]
"""

from __future__ import annotations

import sys

import numpy as np

from common import (CLOTH_CELLS, DT, GRAVITY, arguments, bunny, lame,  # noqa: E402
                    pinned_cloth, run)

import yasps  # noqa: E402
from yasps.contact import Contact  # noqa: E402
from yasps.sim import (Body, Cage, ImplicitEuler, add_caged_surface,  # noqa: E402
                       add_elastic_tets, add_free_vertices,
                       add_hex8_neo_hookean, cage_grid, hex_tets,
                       lumped_masses)

CLOTH = dict(stretch=3.55e3, shear=1.0e3, bending=0.055)
CLOTH_DENSITY = 0.2
HEIGHT = 0.3


def build(scale: str, discretization: str, cells: int):
    """The scene: (stepper, contact, {body: Body}, cage)."""
    s = yasps.scene(f"caged_bunny_{discretization}")
    n = CLOTH_CELLS[scale]
    cloth, cf, pinned = pinned_cloth(s, scale, CLOTH, CLOTH_DENSITY)

    verts, tets, faces = bunny(scale, HEIGHT)
    verts = verts + [0.0, 0.0, 0.02]
    cage = cage_grid(verts, cells)
    masses = lumped_masses(verts, tets, 1.0)
    masses /= masses.sum()                               # 1 kg, Table 5
    cage_masses = np.zeros(len(cage.vertices))
    np.add.at(cage_masses, cage.corners_of_points().reshape(-1),
              (cage.weights * masses[:, None]).reshape(-1))
    mesh = s.addMesh("cage")
    corners = add_free_vertices(mesh, cage.vertices, cage_masses)
    mu, lam = lame(31.7e3, 0.226)
    if discretization == "tet4":
        add_elastic_tets(mesh, corners.x, cage.vertices, hex_tets(cage.hexes),
                         mu, lam, scale=DT * DT)
    else:
        add_hex8_neo_hookean(mesh, corners.x, cage.vertices, cage.hexes, mu,
                             lam, scale=DT * DT)
    # Only the bunny's surface vertices are embedded and collide.
    on_surface = np.unique(faces)
    renumber = np.full(len(verts), -1, dtype=np.int64)
    renumber[on_surface] = np.arange(len(on_surface))
    surface = Cage(cage.vertices, cage.hexes, cage.cell_of[on_surface],
                   cage.weights[on_surface])
    points = add_caged_surface(s.addMesh("bunny"), corners.x, surface)

    union = s.addMesh("all").addPrimitiveUnion("v", [cloth.primitive, points])
    union.addAttribute("position")
    contact = Contact(s, union, faces=np.concatenate(
        [cf, renumber[faces] + cloth.primitive.numInstances]), dhat=1e-3,
        average_mass=CLOTH_DENSITY / (n + 1) ** 2)
    targets = [cloth.x, corners.x]
    s.addMinimizeTarget(targets)
    stepper = ImplicitEuler(s, targets, [cloth.x_hat, corners.x_hat], dt=DT,
                            gravity=[GRAVITY, GRAVITY], fixed=[pinned, None],
                            contact=contact)
    bodies = {"cloth": Body(cloth.x, cf, (0.85, 0.75, 0.55)),
              "bunny": Body(points["position"], renumber[faces],
                            (0.55, 0.8, 0.5))}
    return stepper, contact, bodies, cage


def main() -> None:
    def extra(parser):
        parser.add_argument("--cage", choices=("tet4", "hex8"), default="tet4")
        parser.add_argument("--cells", type=int, default=6,
                            help="cage cells along the bunny's longest side")

    args = arguments(__doc__.split("\n")[0], frames=60, extra=extra)
    stepper, contact, bodies, _ = build(args.scale, args.cage, args.cells)
    summary = run(f"caged_bunny_{args.cage}", args, stepper, bodies, contact,
                  bounds=((-0.55, -0.55, -0.35), (0.55, 0.55, 0.65)))
    sys.exit(1 if summary.intersections else 0)


if __name__ == "__main__":
    main()
