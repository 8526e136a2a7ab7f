#!/usr/bin/env python3
"""A gripper from URDF closes on a soft cube with friction, lifts it and
holds it, moved only by its joint drives.

The gripper (`urdf/gripper.urdf`: a palm on a vertical prismatic lift, two
fingers sliding towards each other) is an articulated body in joint
coordinates (`yasps.articulated`): its links' surfaces are computed from
three joint coordinates, in IPC contact (with friction 0.5) with a soft
stable Neo-Hookean cube and the ground. PD drives close the fingers past
the cube's faces, so that they squeeze it, then raise the lift; the
fingers' limits are barriers never crossed. The lift drive's force, read
each frame, carries the palm, the fingers and the cube.

    python3 examples/articulated/gripper.py [--frames 110] [--output DIR]
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
                               add_joint_drives, add_joint_limits, read_urdf,
                               transform)
from yasps.contact import Contact, surface_of  # noqa: E402
from yasps.sim import (Body, FreeVertices, ImplicitEuler,  # noqa: E402
                       add_elastic_tets, add_free_vertices, box_tet_mesh,
                       contact_union, lame, lumped_masses, simulate)

DT = 0.01
GRAVITY = np.array([0.0, 0.0, -9.81])
CUBE = 0.05            # m, the cube's side
DENSITY = 500.0        # kg/m^3: 62.5 g
YOUNG, POISSON = 1e5, 0.4
FRICTION = 0.5
MOUNT = 0.085          # m: the palm's underside, the fingers' tips 3 mm up
SQUEEZE = 0.031        # finger travel: its inner face 6 mm into the cube
LIFT = 0.05            # m raised
#: frames of each phase: close, lift, hold
CLOSE, RAISE = 30, 40


@dataclass
class Gripping:
    """The scene and what a run reads."""
    scene: yasps.Scene
    stepper: ImplicitEuler
    contact: Contact
    robot: ArticulatedBody
    drives: JointDrives
    limits: JointLimits
    cube: FreeVertices
    cube_mass: float
    bodies: Dict[str, Body]
    #: the contact's triangles, numbered within its union of vertices
    faces: np.ndarray


def schedule(t: float) -> Dict[str, Dict[str, float]]:
    """The drives' targets at time t: fingers close over CLOSE frames, then
    the lift rises over RAISE frames and stays."""
    close = min(t / (CLOSE * DT), 1.0)
    rise = min(max(t / DT - CLOSE, 0.0) / RAISE, 1.0)
    speed = LIFT / (RAISE * DT) if 0.0 < rise < 1.0 else 0.0
    return {"positions": {"left_slide": SQUEEZE * close,
                          "right_slide": SQUEEZE * close, "lift": LIFT * rise},
            "velocities": {"lift": speed}}


def build() -> Gripping:
    s = yasps.scene("gripper")
    robot = add_articulated_body(s, read_urdf(HERE / "urdf" / "gripper.urdf"),
                                 name="gripper",
                                 base=transform(translation=[0, 0, MOUNT]))
    verts, tets = box_tet_mesh(3, CUBE)
    verts = verts - [CUBE / 2, CUBE / 2, 0.0] + [0.0, 0.0, 1e-3]
    masses = lumped_masses(verts, tets, DENSITY)
    cube_mesh = s.addMesh("cube")
    cube = add_free_vertices(cube_mesh, verts, masses)
    mu, lam = lame(YOUNG, POISSON)
    add_elastic_tets(cube_mesh, cube.x, verts, tets, mu, lam, scale=DT * DT)
    cube_faces = surface_of(tets)
    union, faces = contact_union(s, robot.surfaces + [(cube.primitive,
                                                       cube_faces)])
    contact = Contact(s, union, faces=faces, dhat=1e-3, friction=FRICTION,
                      halfspaces=[((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))],
                      average_mass=float(masses.mean()))
    targets = robot.targets + [cube.x]
    s.addMinimizeTarget(targets)
    limits = add_joint_limits(s, robot)
    drives = add_joint_drives(s, robot, DT,
                              stiffness={"lift": 3000.0, "left_slide": 300.0,
                                         "right_slide": 300.0},
                              damping={"lift": 60.0, "left_slide": 6.0,
                                       "right_slide": 6.0})
    drives.schedule = schedule
    stepper = ImplicitEuler(
        s, targets=targets, predicted=[None] * len(robot.targets)
        + [cube.x_hat], dt=DT, gravity=[None] * len(robot.targets)
        + [GRAVITY], world=robot.world, contact=contact,
        velocity_tolerance=1e-3)
    drives.attach(stepper)
    bodies = {"gripper": Body(union["position"], faces[:_robot_faces(robot)],
                              (0.55, 0.6, 0.7)),
              "cube": Body(cube.x, cube_faces, (0.9, 0.45, 0.35))}
    return Gripping(s, stepper, contact, robot, drives, limits, cube,
                    float(masses.sum()), bodies, faces)


def _robot_faces(robot: ArticulatedBody) -> int:
    return sum(len(faces) for _, faces in robot.surfaces)


def carried_mass(gripping: Gripping) -> float:
    """The mass the lift carries: the palm, the fingers and the cube."""
    links = gripping.robot.tree.links
    return sum(links[name].mass for name in
               ("palm", "finger_left", "finger_right")) + gripping.cube_mass


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=110)
    parser.add_argument("--output", type=Path,
                        default=Path("out/articulated/gripper"))
    args = parser.parse_args()
    gripping = build()
    lift = gripping.robot.joint_names.index("lift")

    def report(frame: int, _) -> None:
        if frame % 10 == 9:
            height = gripping.robot.joint_positions()[lift] * 1e3
            bottom = gripping.cube.x.value[:, 2, 0].min() * 1e3
            force = gripping.drives.torques()[lift]
            print(f"frame {frame + 1}: lift {height:.1f} mm, cube bottom "
                  f"{bottom:.1f} mm, lift force {force:.3f} N")

    summary = simulate(gripping.stepper, gripping.bodies, args.frames,
                       args.output, contact=gripping.contact,
                       bounds=((-0.1, -0.1, 0.0), (0.1, 0.1, 0.2)),
                       on_frame=report)
    print(summary.line())
    weight = carried_mass(gripping) * 9.81
    print(f"lift force {gripping.drives.torques()[lift]:.4f} N, weight "
          f"carried {weight:.4f} N")
    if summary.intersections:
        sys.exit(1)


if __name__ == "__main__":
    main()
