"""Kinematic trees from URDF files, read with ``yourdfpy``.

What is read: links with their ``<inertial>`` (mass, centre of mass and
inertia tensor) and ``<collision>`` geometry (boxes, cylinders, spheres and
meshes, as surfaces for contact); joints of kind revolute, continuous,
prismatic and fixed with their origin, axis and limits. ``<visual>``,
``<material>``, ``<transmission>`` and ``<gazebo>`` do not change the
physics and are passed over. Anything that would change it and yasps does
not model (planar or floating joints, mimic joints, joint damping or
friction, a geometry of another kind) raises :class:`ModelFileError`
naming the element, rather than being dropped.
"""

from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from os import PathLike
from pathlib import Path
from typing import Dict, List, Union

import numpy as np

from ..errors import ModelFileError
from ..sim.meshes import read_surface_mesh
from ..sim.shapes import sphere_surface
from .tree import Joint, KinematicTree, Link, Surface, transform

#: Sides of the polygon a cylinder's surface is made of.
CYLINDER_SIDES = 16
#: Elements that carry no physics yasps reads; everything else it reads or
#: refuses.
PASSED_OVER = {"visual", "material", "transmission", "gazebo"}
#: The elements read, by their parent's tag.
READ = {
    "robot": {"link", "joint"},
    "link": {"inertial", "collision"},
    "inertial": {"origin", "mass", "inertia"},
    "collision": {"origin", "geometry"},
    "geometry": {"box", "cylinder", "sphere", "mesh"},
    "joint": {"origin", "parent", "child", "axis", "limit", "dynamics",
              "safety_controller", "calibration", "mimic"},
}


def box_surface(size) -> Surface:
    """A box of edge lengths ``size`` centred at the origin: 8 vertices,
    12 triangles, faces outwards."""
    half = 0.5 * np.asarray(size, dtype=float).reshape(3)
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1)
                        for z in (-1, 1)], dtype=float) * half
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5],
                      [0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6],
                      [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return Surface(corners, faces)


def cylinder_surface(radius: float, length: float,
                     sides: int = CYLINDER_SIDES) -> Surface:
    """A cylinder about z, centred at the origin, as a prism of ``sides``
    sides with its two caps fanned from their centres."""
    angle = 2 * np.pi * np.arange(sides) / sides
    ring = np.stack([radius * np.cos(angle), radius * np.sin(angle)], 1)
    h = 0.5 * length
    vertices = np.concatenate([np.c_[ring, np.full(sides, -h)],
                               np.c_[ring, np.full(sides, h)],
                               [[0, 0, -h], [0, 0, h]]])
    k = np.arange(sides)
    n = (k + 1) % sides
    bottom, top = 2 * sides, 2 * sides + 1
    faces = np.concatenate([
        np.stack([k, n, sides + n], 1), np.stack([k, sides + n, sides + k], 1),
        np.stack([np.full(sides, bottom), n, k], 1),
        np.stack([np.full(sides, top), sides + k, sides + n], 1)])
    return Surface(vertices, faces)


def _check_elements(path: Path) -> None:
    """Raises ModelFileError for an element that neither READ nor
    PASSED_OVER names, with the link or joint it is in."""
    try:
        root = ElementTree.parse(path).getroot()
    except (ElementTree.ParseError, OSError) as err:
        raise ModelFileError(f"{path}: not a readable URDF file: {err}") \
            from err
    if root.tag != "robot":
        raise ModelFileError(f"{path}: the root element is <{root.tag}>, "
                             f"not <robot>")

    def visit(element, where: str) -> None:
        for child in element:
            if child.tag in PASSED_OVER:
                continue
            if child.tag not in READ.get(element.tag, set()) and \
                    element.tag in READ:
                raise ModelFileError(
                    f"{path}: <{child.tag}> in <{element.tag}> of {where} is "
                    f"not supported by yasps")
            inner = where
            if child.tag in ("link", "joint"):
                inner = f"{child.tag} {child.get('name')!r}"
            visit(child, inner)

    visit(root, "the robot")


def _surface(geometry, origin: np.ndarray, base: Path, where: str) -> Surface:
    if geometry.box is not None:
        surface = box_surface(geometry.box.size)
    elif geometry.cylinder is not None:
        surface = cylinder_surface(geometry.cylinder.radius,
                                   geometry.cylinder.length)
    elif geometry.sphere is not None:
        vertices, faces = sphere_surface(geometry.sphere.radius, 2)
        surface = Surface(vertices, faces)
    elif geometry.mesh is not None:
        file = Path(geometry.mesh.filename.replace("file://", ""))
        if geometry.mesh.filename.startswith("package://"):
            raise ModelFileError(f"{where}: mesh {geometry.mesh.filename!r}: "
                                 f"package:// paths are not supported; give "
                                 f"a path relative to the URDF file")
        vertices, faces = read_surface_mesh(base / file)
        scale = 1.0 if geometry.mesh.scale is None else \
            np.asarray(geometry.mesh.scale, dtype=float)
        surface = Surface(np.asarray(vertices, float) * scale, faces)
    else:
        raise ModelFileError(f"{where}: a <geometry> with no shape")
    R, p = origin[:3, :3], origin[:3, 3]
    return Surface(surface.vertices @ R.T + p,
                   np.asarray(surface.faces, np.int64))


def _link(link, base: Path) -> Link:
    out = Link(link.name)
    inertial = link.inertial
    if inertial is not None and inertial.mass:
        origin = np.eye(4) if inertial.origin is None else inertial.origin
        R = origin[:3, :3]
        out.mass = float(inertial.mass)
        out.com = origin[:3, 3].copy()
        out.inertia = R @ np.asarray(inertial.inertia, float) @ R.T
    for k, collision in enumerate(link.collisions):
        origin = np.eye(4) if collision.origin is None else collision.origin
        out.surfaces.append(_surface(collision.geometry, origin, base,
                                     f"link {link.name!r}, collision {k}"))
    return out


def _joint(joint) -> Joint:
    where = f"joint {joint.name!r}"
    if joint.type not in ("revolute", "continuous", "prismatic", "fixed"):
        raise ModelFileError(f"{where}: type {joint.type!r} is not supported "
                             f"by yasps (revolute, continuous, prismatic and "
                             f"fixed are)")
    if joint.mimic is not None:
        raise ModelFileError(f"{where}: <mimic> is not supported by yasps")
    dynamics = joint.dynamics
    if dynamics is not None and (dynamics.damping or dynamics.friction):
        raise ModelFileError(f"{where}: <dynamics> with damping or friction "
                             f"is not supported by yasps")
    axis = np.array([1.0, 0.0, 0.0]) if joint.axis is None else \
        np.asarray(joint.axis, float)
    lower = upper = None
    if joint.type in ("revolute", "prismatic") and joint.limit is not None:
        lower, upper = joint.limit.lower, joint.limit.upper
    origin = transform() if joint.origin is None else joint.origin
    return Joint(joint.name, joint.type, joint.parent, joint.child,
                 np.asarray(origin, float), axis / np.linalg.norm(axis),
                 lower, upper)


def read_urdf(path: Union[str, PathLike]) -> KinematicTree:
    """The kinematic tree of the URDF file ``path`` (see the module
    docstring for what is read). Raises ModelFileError naming an element
    yasps does not support."""
    import yourdfpy

    path = Path(path)
    _check_elements(path)
    urdf = yourdfpy.URDF.load(str(path), build_scene_graph=False,
                              build_collision_scene_graph=False,
                              load_meshes=False, load_collision_meshes=False)
    robot = urdf.robot
    links: Dict[str, Link] = {link.name: _link(link, path.parent)
                              for link in robot.links}
    joints: List[Joint] = [_joint(joint) for joint in robot.joints]
    return KinematicTree(links, joints)
