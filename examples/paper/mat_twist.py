#!/usr/bin/env python3
"""Mat twist (paper appendix E.1, Fig. 32).

A square cloth is held at its left and right edges, which turn about the
cloth's axis in opposite directions at 5 rad/s: the cloth twists into a rope
in heavy self-contact. The edges' motion is prescribed
(``stepper.prescribe``): each time step turns them by 5 rad/s * dt (at
most as far as CCD allows, the rest carried to the next step), and Newton
keeps them fixed. The paper uses
dt = 0.001 s for 2 s; the small scale takes dt = 0.004 s.

    python3 examples/paper/mat_twist.py [--frames 100] [--scale small|paper]
        [--output DIR]
"""

from __future__ import annotations

import sys

import numpy as np

from common import CLOTH_CELLS, arguments, run  # noqa: E402

import yasps  # noqa: E402
from yasps.contact import Contact  # noqa: E402
from yasps.sim import (Body, ImplicitEuler, add_cloth,  # noqa: E402
                       add_free_vertices, cloth_grid, lumped_masses)

SPEED = 5.0                      # rad/s, each edge, opposite directions
DT = {"small": 0.004, "paper": 0.001}
CLOTH = dict(stretch=2e3, shear=2e2, bending=1e-3)
DENSITY = 0.2


def rotation_x(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


class TwistedEdges:
    """The held edges (``held``: a mask of the cloth's vertices, ``sides``
    +1 or -1 per vertex) turning about the x axis at SPEED, in opposite
    directions: the motion the stepper is told to follow."""

    def __init__(self, stepper, held: np.ndarray, sides: np.ndarray):
        self.stepper, self.held, self.sides = stepper, held, sides
        self.x = stepper.targets[0]
        self.rest = self.x.value[held, :, 0].copy()

    def positions(self, time: float) -> np.ndarray:
        """The held vertices at ``time``."""
        out = np.empty_like(self.rest)
        for side in (-1.0, 1.0):
            rows = self.sides[self.held] == side
            out[rows] = self.rest[rows] @ rotation_x(side * SPEED * time).T
        return out

    @property
    def wanted(self) -> float:
        """The angle each edge should have turned by now."""
        return SPEED * self.stepper.time

    @property
    def angle(self) -> float:
        """The angle the right edge has turned (CCD may hold it back)."""
        right = self.sides[self.held] > 0
        now = self.x.value[self.held, :, 0][right]
        turned = np.arctan2(now[:, 2], now[:, 1]) - \
            np.arctan2(self.rest[right, 2], self.rest[right, 1])
        wrapped = np.angle(np.exp(1j * (turned - self.wanted)))
        return float(self.wanted + np.median(wrapped))


def build(scale: str):
    """The scene: (stepper, contact, {body: Body}, the twisted edges)."""
    dt = DT[scale]
    n = CLOTH_CELLS[scale]
    verts, faces = cloth_grid(n, size=1.0)
    # The cloth along x, its plane vertical-ish: the twist axis is x.
    s = yasps.scene("mat_twist")
    mesh = s.addMesh("cloth")
    cloth = add_free_vertices(mesh, verts, lumped_masses(verts, faces, DENSITY))
    add_cloth(mesh, cloth.x, verts, faces, scale=dt * dt, **CLOTH)
    edge = np.abs(np.abs(verts[:, 0]) - 0.5) < 1e-9
    sides = np.sign(verts[:, 0])
    contact = Contact(s, cloth.primitive, faces=faces, dhat=1e-3,
                      average_mass=DENSITY / (n + 1) ** 2)
    s.addMinimizeTarget(cloth.x)
    stepper = ImplicitEuler(s, cloth.x, cloth.x_hat, dt=dt, gravity=(0, 0, 0),
                            contact=contact)
    edges = TwistedEdges(stepper, edge, sides)
    stepper.prescribe(cloth.x, edges.positions, mask=edge)
    bodies = {"cloth": Body(cloth.x, faces, (0.85, 0.75, 0.55))}
    return stepper, contact, bodies, edges


def main() -> None:
    args = arguments(__doc__.split("\n")[0], frames=100)
    stepper, contact, bodies, edges = build(args.scale)
    summary = run("mat_twist", args, stepper, bodies, contact,
                  bounds=((-0.6, -0.6, -0.6), (0.6, 0.6, 0.6)))
    print(f"mat_twist: edges turned {edges.angle:.2f} rad each "
          f"(prescribed {edges.wanted:.2f})")
    sys.exit(1 if summary.intersections else 0)


if __name__ == "__main__":
    main()
