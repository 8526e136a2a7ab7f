#!/usr/bin/env python3
"""Cloths on bunny on cloth (paper 9.1, Fig. 14, Table 1).

A soft bunny (stable Neo-Hookean, Young's modulus 10,259 Pa, Poisson 0.205,
1 kg, 1 m across its bounding box, its centre 1 m up) falls onto a 5 m cloth
pinned at its four corners; one to three cloth layers (3.75 m, from 2 m up)
drop onto it one after the other. The sizes, masses and cloth are those of
the paper's own script for this scene (YASPS' supplementary code): 1 kg per
cloth, Baraff-Witkin stretch 335,570 (the text's 33,570 drops a digit) and
shear 100,607 times a thickness of 1 mm, in an energy without add_cloth's
1/2, and dihedral bending 0.055. dt = 0.01 s; Newton stops when the largest
displacement over dt is below 1e-2 m/s; CG stops as the paper's does, once
r^T M^-1 r <= 1e-4 b^T M^-1 b (``cg_stopping="preconditioned"`` at 1e-2).

    python3 examples/paper/cloths_on_bunny.py [--frames 60] [--layers 1]
        [--scale small|paper] [--output DIR]
"""

from __future__ import annotations

import sys

import numpy as np

from common import (CLOTH_CELLS, DT, GRAVITY, arguments, bunny, lame,  # noqa: E402
                    pinned_cloth, run)

import yasps  # noqa: E402
from yasps.contact import Contact  # noqa: E402
from yasps.sim import (Body, ImplicitEuler, NewtonSettings,  # noqa: E402
                       add_cloth, add_elastic_tets, add_free_vertices,
                       cloth_grid, lumped_masses)

# The paper's script: stiffness times thickness, its energy without the
# 1/2 of add_cloth's (hence the factor 2).
THICKNESS = 1e-3          # m
CLOTH = dict(stretch=2 * 335570.47 * THICKNESS,
             shear=2 * 100607.11 * THICKNESS, bending=0.055)
CLOTH_SIZE = 5.0          # m, five times the bunny's diagonal
CLOTH_MASS = 1.0          # kg per cloth
LAYER_SIZE = 0.75 * CLOTH_SIZE
BUNNY_DIAGONAL = 1.0      # m
BUNNY_CENTRE = 1.0        # m above the cloth
LAYER_HEIGHT = 2.0        # m, and 2 m more per layer
COLORS = [(0.85, 0.75, 0.55), (0.6, 0.8, 0.55), (0.8, 0.55, 0.75),
          (0.55, 0.7, 0.85)]


def build(scale: str, layers: int):
    """The scene: (stepper, contact, {body: Body})."""
    s = yasps.scene("cloths_on_bunny")
    parts, faces, bodies, targets, hats, fixed = [], [], {}, [], [], []
    offset = 0

    def add_surface(name, free, F, color, mask=None):
        nonlocal offset
        parts.append(free.primitive)
        faces.append(F + offset)
        offset += free.primitive.numInstances
        bodies[name] = Body(free.x, F, color)
        targets.append(free.x)
        hats.append(free.x_hat)
        fixed.append(mask)

    n = CLOTH_CELLS[scale]
    c, cf, pinned = pinned_cloth(s, scale, CLOTH, CLOTH_MASS / CLOTH_SIZE ** 2,
                                 size=CLOTH_SIZE)
    add_surface("cloth", c, cf, COLORS[0], pinned)

    bv, bt, bf = bunny(scale, 1.0)
    bv = bv * (BUNNY_DIAGONAL / np.linalg.norm(np.ptp(bv, axis=0)))
    bv[:, 2] += BUNNY_CENTRE - 0.5 * bv[:, 2].max()
    masses = lumped_masses(bv, bt, 1.0)
    mesh = s.addMesh("bunny")
    b = add_free_vertices(mesh, bv, masses / masses.sum())  # 1 kg
    mu, lam = lame(10259.0, 0.205)
    # Stable Neo-Hookean's own Lame parameters (Smith et al. 2018, 3.4), as
    # the paper's script sets them: its linearisation then matches E, nu.
    add_elastic_tets(mesh, b.x, bv, bt, 4.0 * mu / 3.0, lam + 5.0 * mu / 6.0,
                     scale=DT * DT)
    add_surface("bunny", b, bf, (0.35, 0.6, 0.9))

    for k in range(layers):
        # The paper's layers are cloths like the bottom one (10,201
        # vertices); the small ones are smaller.
        cells = n if scale == "paper" else max(n * 3 // 5, 4)
        lv, lf = cloth_grid(cells, size=LAYER_SIZE,
                            height=LAYER_HEIGHT * (k + 1))
        mesh = s.addMesh(f"layer{k}")
        layer = add_free_vertices(mesh, lv, lumped_masses(
            lv, lf, CLOTH_MASS / LAYER_SIZE ** 2))
        add_cloth(mesh, layer.x, lv, lf, scale=DT * DT, **CLOTH)
        add_surface(f"layer{k}", layer, lf, COLORS[1 + k % 3])

    union = s.addMesh("all").addPrimitiveUnion("v", parts)
    union.addAttribute("position")
    contact = Contact(s, union, faces=np.concatenate(faces), dhat=1e-3,
                      average_mass=CLOTH_MASS / (n + 1) ** 2)
    s.addMinimizeTarget(targets)
    stepper = ImplicitEuler(s, targets, hats, dt=DT,
                            gravity=[GRAVITY] * len(targets), fixed=fixed,
                            contact=contact, velocity_tolerance=1e-2,
                            settings=NewtonSettings(
                                cg_tolerance=1e-2,
                                cg_stopping="preconditioned"))
    return stepper, contact, bodies


def main() -> None:
    args = arguments(__doc__.split("\n")[0], frames=60, extra=lambda p:
                     p.add_argument("--layers", type=int, default=1,
                                    choices=(1, 2, 3)))
    stepper, contact, bodies = build(args.scale, args.layers)
    summary = run("cloths_on_bunny", args, stepper, bodies, contact,
                  bounds=((-2.6, -2.6, -1.6), (2.6, 2.6, 2.2)))
    sys.exit(1 if summary.intersections else 0)


if __name__ == "__main__":
    main()
