#!/usr/bin/env python3
"""Mat twist (paper appendix E.1, Fig. 32).

A square cloth is held at its left and right edges, which turn about the
cloth's axis in opposite directions at 5 rad/s: the cloth twists into a rope
in heavy self-contact. The edges' motion is prescribed: before each time
step they turn by 5 rad/s * dt (at most as far as ipctk's CCD allows, the
rest carried to the next step), and Newton keeps them fixed. The paper uses
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


class Twister:
    """Turns the held edges (``held``: a mask of the cloth's vertices, with
    ``sides`` +1 or -1 per vertex) about the x axis, limited by CCD."""

    def __init__(self, x, held: np.ndarray, sides: np.ndarray, contact,
                 dt: float):
        self.x, self.held, self.sides = x, held, sides
        self.contact, self.dt = contact, dt
        self.rest = x.value[held, :, 0].copy()
        self.angle = 0.0       # the angle the edges have reached
        self.wanted = 0.0      # the angle they should have

    def positions(self, angle: float) -> np.ndarray:
        out = np.empty_like(self.rest)
        for side in (-1.0, 1.0):
            rows = self.sides[self.held] == side
            out[rows] = self.rest[rows] @ rotation_x(side * angle).T
        return out

    def advance(self) -> None:
        """Turns the edges towards the prescribed angle, as far as no
        surface primitives cross (IPC's CCD, times 0.9)."""
        self.wanted += SPEED * self.dt
        step = np.zeros_like(self.x.value)
        step[self.held, :, 0] = self.positions(self.wanted) - \
            self.x.value[self.held, :, 0]
        bound = self.contact.stepBound([step])
        fraction = 1.0 if bound >= 1.0 else 0.9 * bound
        value = self.x.value
        value[self.held] += fraction * step[self.held]
        self.x.updateValue(value)
        self.angle += fraction * (self.wanted - self.angle)


def build(scale: str):
    """The scene: (stepper, contact, {body: Body}, twister)."""
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
                            fixed=edge, contact=contact)
    twister = Twister(cloth.x, edge, sides, contact, dt)
    bodies = {"cloth": Body(cloth.x, faces, (0.85, 0.75, 0.55))}
    return stepper, contact, bodies, twister


def main() -> None:
    args = arguments(__doc__.split("\n")[0], frames=100)
    stepper, contact, bodies, twister = build(args.scale)
    # The edges turn before every step (the callback runs after a step).
    twister.advance()
    summary = run("mat_twist", args, stepper, bodies, contact,
                  on_frame=lambda frame, report: twister.advance(),
                  bounds=((-0.6, -0.6, -0.6), (0.6, 0.6, 0.6)))
    print(f"mat_twist: edges turned {twister.angle:.2f} rad each "
          f"(prescribed {twister.wanted:.2f})")
    sys.exit(1 if summary.intersections else 0)


if __name__ == "__main__":
    main()
