#!/usr/bin/env python3
"""A rigid box parameterised by a rotation vector and a translation (six
parameters, a non-linear map) thrown tumbling into a bowl. Its inertia
lives in world space; the compiler differentiates the rotation, so nothing
is differentiated or stepped by hand. Written with the package's helpers
only.

    python3 examples/scenes/box_in_bowl.py [--frames 120]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "python"))

import yasps  # noqa: E402
from yasps.contact import Contact, surface_of  # noqa: E402
from yasps.sim import (Body, ImplicitEuler, add_obstacle,  # noqa: E402
                       add_rotation_vector_body, bowl_surface, box_tet_mesh,
                       contact_union, lumped_masses, simulate,
                       wrap_rotation_vectors)

DT = 0.01


def build(subdivisions: int = 3):
    """(stepper, contact, bodies)."""
    s = yasps.scene("box_in_bowl")
    wv, wf = bowl_surface(0.3, subdivisions)
    bowl = add_obstacle(s.addMesh("bowl"), wv)
    bv, bt = box_tet_mesh(1, 0.1)
    box = add_rotation_vector_body(s.addMesh("box"), bv + [-0.15, -0.05, 0.0],
                                   lumped_masses(bv, bt, 500.0))
    union, faces = contact_union(s, [(bowl, wf), (box.vertices, surface_of(bt))])
    contact = Contact(s, union, faces=faces, dhat=1e-3, friction=0.2)
    s.addMinimizeTarget(box.targets)
    stepper = ImplicitEuler(
        s, targets=box.targets, dt=DT, world=[box.inertia],
        world_velocities=[box.world_velocity(angular=(3.0, -5.0, 2.0),
                                             linear=(1.0, 0.3, 0.0))],
        normalize=[wrap_rotation_vectors, None], contact=contact)
    bodies = {"bowl": Body(bowl["position"], wf, (0.8, 0.8, 0.75)),
              "box": Body(box.positions, surface_of(bt), (0.9, 0.45, 0.35))}
    return stepper, contact, bodies


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=120)
    parser.add_argument("--output", type=Path,
                        default=Path("out/scenes/box_in_bowl"))
    args = parser.parse_args()
    stepper, contact, bodies = build()
    summary = simulate(stepper, bodies, args.frames, args.output,
                       contact=contact, view=(40.0, -60.0))
    print(summary.line())
    sys.exit(1 if summary.intersections else 0)


if __name__ == "__main__":
    main()
