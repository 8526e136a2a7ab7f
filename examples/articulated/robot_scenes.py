"""What the articulated examples share: a soft box on the table, and a
robot in IPC contact with it and the table (z = 0), stepped with its joint
limits and scheduled drives."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Dict, Tuple

import numpy as np

import yasps
from yasps.articulated import (ArticulatedBody, JointDrives, JointLimits,
                               add_joint_drives, add_joint_limits)
from yasps.contact import Contact, surface_of
from yasps.sim import (Body, FreeVertices, ImplicitEuler, add_elastic_tets,
                       add_free_vertices, box_tet_mesh, contact_union, lame,
                       lumped_masses)

DT = 0.01
GRAVITY = np.array([0.0, 0.0, -9.81])
TABLE = ((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))


@dataclass
class SoftBox:
    """A stable Neo-Hookean box: its vertices, surface and mass."""
    body: FreeVertices
    faces: np.ndarray
    mass: float
    masses: np.ndarray


def add_soft_box(scene: yasps.Scene, name: str, cells: int, size: float,
                 centre_bottom, density: float, young: float,
                 poisson: float) -> SoftBox:
    """A box of side ``size`` in ``cells``^3 cells whose bottom face is
    centred at ``centre_bottom``."""
    verts, tets = box_tet_mesh(cells, size)
    verts = verts - [size / 2, size / 2, 0.0] + np.asarray(centre_bottom)
    masses = lumped_masses(verts, tets, density)
    mesh = scene.addMesh(name)
    body = add_free_vertices(mesh, verts, masses)
    add_elastic_tets(mesh, body.x, verts, tets, *lame(young, poisson),
                     scale=DT * DT)
    return SoftBox(body, surface_of(tets), float(masses.sum()), masses)


@dataclass
class RobotRun:
    """A robot and a soft box in contact: the scene and what a run reads."""
    scene: yasps.Scene
    stepper: ImplicitEuler
    contact: Contact
    robot: ArticulatedBody
    drives: JointDrives
    limits: JointLimits
    box: SoftBox
    bodies: Dict[str, Body]
    #: the contact's triangles, numbered within its union of vertices
    faces: np.ndarray


def robot_and_box(scene: yasps.Scene, robot: ArticulatedBody, box: SoftBox,
                  friction: float, stiffness, damping,
                  schedule: Callable[[float], Dict],
                  names: Tuple[str, str]) -> RobotRun:
    """IPC contact (dhat 1 mm, ``friction``) among the robot's links, the
    box and the table; the robot's limits and PD drives (``stiffness``,
    ``damping``) following ``schedule``; implicit Euler over the joint
    coordinates and the box. ``names``: the robot's and the box's in
    pictures."""
    union, faces = contact_union(scene, robot.surfaces + [
        (box.body.primitive, box.faces)])
    contact = Contact(scene, union, faces=faces, dhat=1e-3,
                      friction=friction, halfspaces=[TABLE],
                      average_mass=float(box.masses.mean()))
    targets = robot.targets + [box.body.x]
    scene.addMinimizeTarget(targets)
    limits = add_joint_limits(scene, robot)
    drives = add_joint_drives(scene, robot, DT, stiffness=stiffness,
                              damping=damping)
    drives.schedule = schedule
    free = [None] * len(robot.targets)
    stepper = ImplicitEuler(
        scene, targets=targets, predicted=free + [box.body.x_hat], dt=DT,
        gravity=free + [GRAVITY], world=robot.world, contact=contact,
        velocity_tolerance=1e-3)
    drives.attach(stepper)
    robot_faces = sum(len(f) for _, f in robot.surfaces)
    bodies = {names[0]: Body(union["position"], faces[:robot_faces],
                             (0.55, 0.6, 0.7)),
              names[1]: Body(box.body.x, box.faces, (0.9, 0.45, 0.35))}
    return RobotRun(scene, stepper, contact, robot, drives, limits, box,
                    bodies, faces)
