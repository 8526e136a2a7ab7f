#!/usr/bin/env python3
"""A planar arm from URDF sweeps its paddle across a table and pushes a
soft box along it, with friction, by its shoulder's drive.

The arm (`urdf/pusher.urdf`: shoulder and elbow about z, a paddle welded
to the forearm) is an articulated body in joint coordinates; the box a
stable Neo-Hookean tet mesh resting on the table (a half-space). (An
affine box in the same contact UNION would make each contact pair's
Hessian 48 x 48 and projected in full, since the arm's positions are not
linear in its coordinates: its kernel exceeds the compiler's budget.) The shoulder's drive
turns the arm 0.9 rad over 1.5 s while the elbow's holds it straight; the
paddle meets the box after a third of the sweep and pushes it round.

    python3 examples/articulated/pusher.py [--frames 160] [--output DIR]
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Dict

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "python"))

import yasps  # noqa: E402
from yasps.articulated import (ArticulatedBody, JointDrives,  # noqa: E402
                               JointLimits, add_articulated_body,
                               add_joint_drives, add_joint_limits, read_urdf)
from yasps.contact import Contact, surface_of  # noqa: E402
from yasps.sim import (Body, FreeVertices, ImplicitEuler,  # noqa: E402
                       add_elastic_tets, add_free_vertices, box_tet_mesh,
                       contact_union, lame, lumped_masses, simulate)

DT = 0.01
GRAVITY = np.array([0.0, 0.0, -9.81])
BOX = 0.06            # m, the box's side
DENSITY = 300.0       # kg/m^3: 65 g
YOUNG, POISSON = 2e5, 0.4
RADIUS = 0.56         # m, the paddle's centre from the shoulder
START = 0.35          # rad, where the box sits round from the arm
SWEEP, SECONDS = 0.9, 1.5


@dataclass
class Pushing:
    """The scene and what a run reads."""
    scene: yasps.Scene
    stepper: ImplicitEuler
    contact: Contact
    robot: ArticulatedBody
    drives: JointDrives
    limits: JointLimits
    box: FreeVertices
    bodies: Dict[str, Body]
    faces: np.ndarray


def schedule(t: float) -> Dict[str, Dict[str, float]]:
    """The shoulder's targets: a sweep at a constant rate, then rest."""
    share = min(t / SECONDS, 1.0)
    rate = SWEEP / SECONDS if share < 1.0 else 0.0
    return {"positions": {"shoulder": SWEEP * share, "elbow": 0.0},
            "velocities": {"shoulder": rate, "elbow": 0.0}}


def build() -> Pushing:
    s = yasps.scene("pusher")
    robot = add_articulated_body(s, read_urdf(HERE / "urdf" / "pusher.urdf"),
                                 name="arm")
    verts, tets = box_tet_mesh(2, BOX)
    verts = verts - [BOX / 2, BOX / 2, 0.0] + [
        RADIUS * np.cos(START), RADIUS * np.sin(START), 1e-3]
    masses = lumped_masses(verts, tets, DENSITY)
    box_mesh = s.addMesh("box")
    box = add_free_vertices(box_mesh, verts, masses)
    add_elastic_tets(box_mesh, box.x, verts, tets, *lame(YOUNG, POISSON),
                     scale=DT * DT)
    box_faces = surface_of(tets)
    union, faces = contact_union(s, robot.surfaces + [(box.primitive,
                                                       box_faces)])
    contact = Contact(s, union, faces=faces, dhat=1e-3, friction=0.3,
                      halfspaces=[((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))],
                      average_mass=float(masses.mean()))
    targets = robot.targets + [box.x]
    s.addMinimizeTarget(targets)
    limits = add_joint_limits(s, robot)
    drives = add_joint_drives(s, robot, DT, stiffness=300.0, damping=30.0)
    drives.schedule = schedule
    stepper = ImplicitEuler(
        s, targets=targets,
        predicted=[None] * len(robot.targets) + [box.x_hat],
        dt=DT, gravity=[None] * len(robot.targets) + [GRAVITY],
        world=robot.world, contact=contact, velocity_tolerance=1e-3)
    drives.attach(stepper)
    robot_faces = sum(len(f) for _, f in robot.surfaces)
    bodies = {"arm": Body(union["position"], faces[:robot_faces],
                          (0.55, 0.6, 0.7)),
              "box": Body(box.x, box_faces,
                          (0.9, 0.45, 0.35))}
    return Pushing(s, stepper, contact, robot, drives, limits, box, bodies,
                   faces)


def box_angle(pushing: Pushing) -> float:
    """The box's centre's angle round the shoulder (rad)."""
    centre = np.asarray(pushing.box.x.value, float)[:, :, 0].mean(axis=0)
    return float(np.arctan2(centre[1], centre[0]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=160)
    parser.add_argument("--output", type=Path,
                        default=Path("out/articulated/pusher"))
    args = parser.parse_args()
    pushing = build()
    summary = simulate(pushing.stepper, pushing.bodies, args.frames,
                       args.output, contact=pushing.contact,
                       bounds=((-0.1, -0.1, 0.0), (0.7, 0.7, 0.15)))
    print(summary.line())
    print(f"the box went round from {START:.3f} to {box_angle(pushing):.3f} "
          f"rad; the shoulder at {pushing.robot.joint_positions()[0]:.3f}")
    if summary.intersections:
        sys.exit(1)


if __name__ == "__main__":
    main()
