"""A kinematic tree as scene structure: joint coordinates as targets, each
body's world transform a computed attribute JOINed from its parent's.

Bodies (links welded by fixed joints, :func:`.tree.moving_bodies`) are
grouped by depth, the number of moving joints above them, so that one
primitive holds every joint of a depth and one expression serves them all:

    R = R_parent  R_origin  (E + sin(turn q) K + (1 - cos(turn q)) K^2)
    p = p_parent + R_parent (p_origin + R_origin slide q a)

with ``a`` the joint's axis, ``K`` its cross-product matrix and ``turn``,
``slide`` 1 or 0 by the joint's kind (per-instance constants, so revolute
and prismatic joints share the kernels). ``R_parent``, ``p_parent`` come
through a JOIN from the depth above: the compiler differentiates a link's
vertices through every joint of its chain, and no derivative is written
here. The links' inertia is six points each (:mod:`.inertia_points`) with
implicit Euler's world inertia, exact for rigid links; their surfaces are
vertices with a computed ``position`` for contact.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Mapping, Optional, Sequence, Tuple, Union, cast

import numpy as np

from ..frontend.attribute import Attribute, constant
from ..frontend.errors import SceneError
from ..frontend.scene import Mesh, Primitive, Scene
from ..sim.rotation import rotate, rotation_matrices
from ..sim.world import WorldInertia, add_world_inertia
from .inertia_points import inertia_points
from .tree import Joint, KinematicTree, MovingBody, moving_bodies


def _cross_matrix(axis: np.ndarray) -> np.ndarray:
    x, y, z = axis
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def _homogeneous(points: np.ndarray, frame: np.ndarray) -> np.ndarray:
    return points @ frame[:3, :3].T + frame[:3, 3]


@dataclass
class Depth:
    """The bodies that share a depth: their primitive of transforms and,
    where they have them, their inertia points and surface vertices."""
    bodies: List[int]
    #: one instance per body: ``R`` (3x3) and ``p`` (3x1), world
    frames: Primitive
    #: the joint coordinates (n, 1): a target; None at the base
    q: Optional[Attribute] = None
    points: Optional[Primitive] = None
    inertia: Optional[WorldInertia] = None
    surface: Optional[Primitive] = None
    #: the surface's triangles, numbered within ``surface``
    faces: np.ndarray = field(default_factory=lambda: np.zeros((0, 3),
                                                             np.int64))


@dataclass
class ArticulatedBody:
    """A kinematic tree in a scene (:func:`add_articulated_body`)."""
    tree: KinematicTree
    bodies: List[MovingBody]
    #: depth 0 is the base, depth d the bodies behind d moving joints
    depths: List[Depth]
    #: a floating base's rotation vector and translation, else None
    base_w: Optional[Attribute] = None
    base_t: Optional[Attribute] = None
    #: the base's placement (4x4) at w = t = 0
    placement: np.ndarray = field(default_factory=lambda: np.eye(4))

    @property
    def joints(self) -> List[Joint]:
        """The moving joints in the order of the coordinates."""
        return [cast(Joint, self.bodies[b].joint) for d in self.depths[1:]
                for b in d.bodies]

    def _coordinates(self) -> List[Attribute]:
        """Each depth's joint coordinates (every depth but the base's has
        them)."""
        return [cast(Attribute, d.q) for d in self.depths[1:]]

    @property
    def joint_names(self) -> List[str]:
        return [j.name for j in self.joints]

    @property
    def targets(self) -> List[Attribute]:
        """The minimisation targets: a floating base's ``w`` and ``t``,
        then the joint coordinates depth by depth."""
        base = [] if self.base_w is None or self.base_t is None else \
            [self.base_w, self.base_t]
        return base + self._coordinates()

    @property
    def world(self) -> List[WorldInertia]:
        """The world inertias, for ImplicitEuler's ``world=[...]``."""
        return [d.inertia for d in self.depths if d.inertia is not None]

    @property
    def surfaces(self) -> List[Tuple[Primitive, np.ndarray]]:
        """``(primitive, faces)`` of every depth with surfaces, for
        :func:`yasps.sim.contact_union`."""
        return [(d.surface, d.faces) for d in self.depths
                if d.surface is not None]

    def joint_positions(self) -> np.ndarray:
        """The joint coordinates (n,), in the order of ``joint_names``."""
        if len(self.depths) == 1:
            return np.zeros(0)
        return np.concatenate([np.asarray(q.value, float).reshape(-1)
                               for q in self._coordinates()])

    def set_joint_positions(
            self, values: Union[Sequence[float], Mapping[str, float]]
    ) -> None:
        """Sets the joint coordinates: all of them (in the order of
        ``joint_names``) or some by name."""
        names = self.joint_names
        current = self.joint_positions()
        if isinstance(values, Mapping):
            for name, value in values.items():
                if name not in names:
                    raise SceneError(f"set_joint_positions: no moving joint "
                                     f"named {name!r}; the joints are "
                                     f"{names}")
                current[names.index(name)] = float(value)
        else:
            given = np.asarray(values, dtype=float).reshape(-1)
            if given.shape != current.shape:
                raise SceneError(f"set_joint_positions: give {len(names)} "
                                 f"coordinates, got {given.size}")
            current = given.copy()
        start = 0
        for q in self._coordinates():
            n = int(np.asarray(q.value).shape[0])
            q.updateValue(current[start:start + n].reshape(n, 1, 1))
            start += n

    def base_transform(self) -> np.ndarray:
        """The world transform (4x4) that a floating base's ``w`` and ``t``
        make of the base frame; the identity for a fixed base, whose
        placement is in its bodies' transforms."""
        if self.base_w is None or self.base_t is None:
            return np.eye(4)
        T = np.eye(4)
        T[:3, :3] = rotation_matrices(self.base_w.value)[0]
        T[:3, 3] = np.asarray(self.base_t.value, float).reshape(3)
        return T @ self.placement

    def body_transforms(self) -> List[np.ndarray]:
        """Each body's world transform (4x4), in the order of ``bodies``."""
        out: List[np.ndarray] = [np.eye(4)] * len(self.bodies)
        base = self.base_transform()
        for d in self.depths:
            R = np.asarray(d.frames["R"].compute().value, float)
            p = np.asarray(d.frames["p"].compute().value, float)
            for k, b in enumerate(d.bodies):
                T = np.eye(4)
                T[:3, :3], T[:3, 3] = R[k], p[k, :, 0]
                out[b] = base @ T
        return out

    def link_transforms(self) -> Dict[str, np.ndarray]:
        """Every link's world transform (4x4): forward kinematics."""
        out = {}
        for body, T in zip(self.bodies, self.body_transforms()):
            for link, frame in body.frames.items():
                out[link] = T @ frame
        return out


def _base(mesh: Mesh, floating: bool, placement: np.ndarray):
    """The base's primitive. Its ``R``, ``p`` are the frame every body's
    transform is composed in: the world placement of a fixed base, the
    identity for a floating one, whose targets ``w`` (rotation vector) and
    ``t`` (translation) move every vertex last (:func:`_vertices`), so that
    the joints' kernels do not carry them."""
    frames = mesh.addPrimitive("base", numInstances=1)
    frame = np.eye(4) if floating else placement
    frames.addConstant("R", rows=3, cols=3).updateValue(frame[None, :3, :3])
    frames.addConstant("p", rows=3).updateValue(frame[None, :3, 3:])
    if not floating:
        return frames, None, None
    w = frames.addAttribute("w", rows=3)
    w.updateValue(np.zeros((1, 3, 1)))
    t = frames.addAttribute("t", rows=3)
    t.updateValue(np.zeros((1, 3, 1)))
    return frames, w, t


def _joint_level(mesh: Mesh, depth: int, bodies: List[MovingBody],
                 members: List[int], parents: Primitive,
                 parent_index: Dict[int, int]) -> Tuple[Primitive, Attribute]:
    """The primitive of the joints at ``depth`` (one per body of
    ``members``) with their coordinates ``q`` and computed ``R``, ``p``."""
    n = len(members)
    frames = mesh.addPrimitive(f"joints{depth}", numInstances=n)
    joints = [cast(Joint, bodies[b].joint) for b in members]
    start = np.array([np.clip(0.0, j.lower if j.lower is not None else -np.inf,
                              j.upper if j.upper is not None else np.inf)
                      for j in joints])
    q = frames.addAttribute("q", rows=1)
    q.updateValue(start.reshape(n, 1, 1))
    axes = np.array([j.axis for j in joints], dtype=float)
    origins = np.array([bodies[b].origin for b in members])
    turning = [j.kind != "prismatic" for j in joints]

    def stored(name: str, values: np.ndarray, rows: int, cols: int = 1):
        attr = frames.addConstant(name, rows=rows, cols=cols)
        attr.updateValue(values.reshape(n, rows, cols))
        return attr

    R0 = stored("origin_R", origins[:, :3, :3], 3, 3)
    p0 = stored("origin_p", origins[:, :3, 3], 3)
    a = stored("axis", axes, 3)
    K = stored("K", np.array([_cross_matrix(x) for x in axes]), 3, 3)
    K2 = stored("K2", np.array([_cross_matrix(x) @ _cross_matrix(x)
                                for x in axes]), 3, 3)
    turn = stored("turn", np.array(turning, dtype=float), 1)
    slide = stored("slide", 1.0 - np.array(turning, dtype=float), 1)
    link = frames.addConnectivity(
        "parent", parents, np.array([[parent_index[bodies[b].parent]]
                                     for b in members], np.int64), 1)
    R_parent = frames.addAttribute("R_parent", through=link,
                                   source=parents["R"]).resize(3, 3)
    p_parent = frames.addAttribute("p_parent", through=link,
                                   source=parents["p"]).T
    angle = turn * q
    motion = constant(np.eye(3)) + angle.sin() * K + (1.0 - angle.cos()) * K2
    frames.addAttribute("R", computed_attribute=R_parent @ (R0 @ motion))
    frames.addAttribute("p", computed_attribute=p_parent + R_parent @ (
        p0 + R0 @ ((slide * q) * a)))
    return frames, q


@dataclass
class _Floating:
    """A floating base: its primitive, targets and placement at w = t = 0."""
    base: Primitive
    w: Attribute
    t: Attribute
    placement: np.ndarray


def _vertices(mesh: Mesh, name: str, frames: Primitive, local: np.ndarray,
              owner: np.ndarray, floating: Optional[_Floating]) -> Primitive:
    """Vertices at ``local`` (N, 3) in the frames of ``owner`` (N,),
    instances of ``frames``, with their world ``position``: ``R local +
    p``, then for a floating base ``R(w) (R_0 y + p_0) + t``."""
    vertices = mesh.addPrimitive(name, numInstances=len(local))
    offset = vertices.addConstant("local", rows=3)
    offset.updateValue(local.reshape(-1, 3, 1))
    link = vertices.addConnectivity("body", frames,
                                    owner.reshape(-1, 1).astype(np.int64), 1)
    R = vertices.addAttribute("R", through=link, source=frames["R"])
    p = vertices.addAttribute("p", through=link, source=frames["p"])
    position = R.resize(3, 3) @ offset + p.T
    if floating is not None:
        whole = vertices.addConnectivity(
            "base", floating.base, np.zeros((len(local), 1), np.int64), 1)
        w = vertices.addAttribute("w", through=whole, source=floating.w).T
        t = vertices.addAttribute("t", through=whole, source=floating.t).T
        P = floating.placement
        position = rotate(w, constant(P[:3, :3]) @ position + P[:3, 3:]) + t
    vertices.addAttribute("position", computed_attribute=position)
    return vertices


def _static_vertices(mesh: Mesh, name: str, world: np.ndarray) -> Primitive:
    vertices = mesh.addPrimitive(name, numInstances=len(world))
    vertices.addConstant("position", rows=3).updateValue(
        world.reshape(-1, 3, 1))
    return vertices


def _depth_contents(tree: KinematicTree, bodies: List[MovingBody],
                    members: List[int]):
    """The inertia points (local, masses, owner) and surfaces (local,
    faces, owner) of the bodies ``members``, in their bodies' frames."""
    points, masses, point_owner = [], [], []
    verts, faces, vert_owner, offset = [], [], [], 0
    for k, b in enumerate(members):
        for name, frame in bodies[b].frames.items():
            link = tree.links[name]
            at, m = inertia_points(link.mass, link.com, link.inertia, name)
            points.append(_homogeneous(at, frame))
            masses.append(m)
            point_owner += [k] * len(m)
            for surface in link.surfaces:
                verts.append(_homogeneous(surface.vertices, frame))
                faces.append(np.asarray(surface.faces, np.int64) + offset)
                vert_owner += [k] * len(surface.vertices)
                offset += len(surface.vertices)
    cat = (lambda xs, shape: np.concatenate(xs) if xs else np.zeros(shape))
    return ((cat(points, (0, 3)), cat(masses, (0,)), np.array(point_owner)),
            (cat(verts, (0, 3)), cat(faces, (0, 3)).astype(np.int64),
             np.array(vert_owner)))


def add_articulated_body(scene: Scene, tree: KinematicTree,
                         name: str = "robot", floating: bool = False,
                         base=None) -> ArticulatedBody:
    """Adds ``tree`` to ``scene`` as a mesh ``name``: joint coordinates (and
    a ``floating`` base's rotation vector and translation) as stored
    attributes, every link's world transform computed from them, six
    inertia points per link with mass under implicit Euler's world
    inertia, and the links' surfaces as vertices with a computed
    ``position``. ``base`` places the root (4x4, default identity). Add
    ``body.targets`` to the scene's minimisation targets and pass
    ``body.world`` to ImplicitEuler's ``world=``.

    Raises SceneError for a moving joint that moves no mass (its
    coordinate would have no inertia and Newton no step)."""
    placement = np.eye(4) if base is None else np.asarray(base, float)
    bodies = moving_bodies(tree)
    for joint in [cast(Joint, body.joint) for body in bodies[1:]]:
        if tree.subtree_mass(joint.child) == 0:
            raise SceneError(f"add_articulated_body: joint {joint.name!r} "
                             f"moves no mass: give the links behind it a "
                             f"mass (URDF <inertial>), or make it fixed")
    if floating and sum(link.mass for link in tree.links.values()) == 0:
        raise SceneError("add_articulated_body: a floating base needs mass")
    mesh = scene.addMesh(name)
    frames, w, t = _base(mesh, floating, placement)
    free = None if w is None or t is None else \
        _Floating(frames, w, t, placement)
    depths = [Depth([0], frames)]
    index = {0: 0}
    for depth in range(1, max(b.depth for b in bodies) + 1):
        members = [i for i, b in enumerate(bodies) if b.depth == depth]
        level, q = _joint_level(mesh, depth, bodies, members,
                                depths[-1].frames, index)
        index = {b: k for k, b in enumerate(members)}
        depths.append(Depth(members, level, q))
    for depth, entry in enumerate(depths):
        (points, masses, owner), (verts, faces, vert_owner) = \
            _depth_contents(tree, bodies, entry.bodies)
        moves = depth > 0 or floating
        if len(points) and moves:
            entry.points = _vertices(mesh, f"points{depth}", entry.frames,
                                     points, owner, free)
            entry.inertia = add_world_inertia(entry.points["position"],
                                              masses)
        if len(verts):
            entry.surface = _vertices(
                mesh, f"surface{depth}", entry.frames, verts, vert_owner,
                free) \
                if moves else _static_vertices(
                    mesh, f"surface{depth}", _homogeneous(verts, placement))
            entry.faces = faces
    return ArticulatedBody(tree, bodies, depths, w, t, placement)
