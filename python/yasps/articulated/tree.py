"""A kinematic tree: links (rigid, with mass, inertia and surfaces) joined
by joints (revolute, continuous, prismatic, fixed) from a root, the base.

This is a plain description, as URDF holds it (:mod:`.urdf` reads one):
nothing here is yasps IR. :func:`moving_bodies` groups the links that no
moving joint separates (fixed joints weld a link to its parent), which is
what :mod:`.build` turns into the scene's primitives.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

import numpy as np

from ..frontend.errors import SceneError

#: The joint kinds with one coordinate each, and the welded one.
MOVING_KINDS = ("revolute", "continuous", "prismatic")
JOINT_KINDS = MOVING_KINDS + ("fixed",)


def transform(rotation=None, translation=None) -> np.ndarray:
    """A 4x4 homogeneous transform from a 3x3 rotation and a translation."""
    T = np.eye(4)
    if rotation is not None:
        T[:3, :3] = np.asarray(rotation, dtype=float)
    if translation is not None:
        T[:3, 3] = np.asarray(translation, dtype=float).reshape(3)
    return T


@dataclass
class Surface:
    """A closed triangle surface in its link's frame, for contact and
    pictures."""
    vertices: np.ndarray  # (N, 3)
    faces: np.ndarray     # (M, 3), numbered within vertices


@dataclass
class Link:
    """A rigid link: its mass, centre of mass and inertia tensor about the
    centre of mass (both in the link's frame; mass 0 for a frame without
    inertia) and its collision surfaces in the link's frame."""
    name: str
    mass: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    surfaces: List[Surface] = field(default_factory=list)


@dataclass
class Joint:
    """A joint from ``parent`` to ``child`` (link names). ``origin`` is the
    child's frame in the parent's at coordinate 0 (4x4); a revolute or
    continuous joint turns the child about ``axis`` (a unit vector in the
    child's frame) by its coordinate, a prismatic one slides it along
    ``axis``. ``lower``/``upper`` bound the coordinate (None: unbounded)."""
    name: str
    kind: str
    parent: str
    child: str
    origin: np.ndarray = field(default_factory=lambda: np.eye(4))
    axis: np.ndarray = field(default_factory=lambda: np.array([1.0, 0, 0]))
    lower: Optional[float] = None
    upper: Optional[float] = None


@dataclass
class KinematicTree:
    """Links joined by joints into a tree; ``root`` is the link no joint
    moves (the base)."""
    links: Dict[str, Link]
    joints: List[Joint]
    root: str = ""

    def __post_init__(self) -> None:
        self._check()

    def _check(self) -> None:
        children = set()
        for joint in self.joints:
            where = f"KinematicTree: joint {joint.name!r}"
            if joint.kind not in JOINT_KINDS:
                raise SceneError(f"{where}: kind {joint.kind!r} is not one "
                                 f"of {', '.join(JOINT_KINDS)}")
            for end in (joint.parent, joint.child):
                if end not in self.links:
                    raise SceneError(f"{where}: no link named {end!r}")
            if joint.child in children:
                raise SceneError(f"{where}: link {joint.child!r} has a "
                                 f"second parent")
            children.add(joint.child)
            origin = np.asarray(joint.origin, dtype=float)
            R = origin[:3, :3] if origin.shape == (4, 4) else None
            if R is None or not np.allclose(R @ R.T, np.eye(3), atol=1e-9):
                raise SceneError(f"{where}: origin must be a rigid 4x4 "
                                 f"transform")
            if joint.kind in MOVING_KINDS:
                axis = np.asarray(joint.axis, dtype=float).reshape(3)
                if not np.isclose(np.linalg.norm(axis), 1.0, atol=1e-9):
                    raise SceneError(f"{where}: axis {axis} is not a unit "
                                     f"vector")
            if joint.lower is not None and joint.upper is not None and \
                    not joint.lower < joint.upper:
                raise SceneError(f"{where}: lower limit {joint.lower} is not "
                                 f"below upper {joint.upper}")
        roots = [name for name in self.links if name not in children]
        if len(roots) != 1:
            raise SceneError(f"KinematicTree: needs exactly one root link "
                             f"(one that no joint moves), found "
                             f"{len(roots)}: {roots}")
        if self.root and self.root != roots[0]:
            raise SceneError(f"KinematicTree: root {self.root!r} is moved "
                             f"by a joint; the root is {roots[0]!r}")
        self.root = roots[0]
        for link in self.links.values():
            if not link.mass >= 0:
                raise SceneError(f"KinematicTree: link {link.name!r} has "
                                 f"mass {link.mass}")
        # Every link reached from the root: a cycle would leave some out.
        if len(self.order()) != len(self.links):
            raise SceneError("KinematicTree: the joints form a cycle")

    def children(self, link: str) -> List[Joint]:
        """The joints whose parent is ``link``, in the file's order."""
        return [j for j in self.joints if j.parent == link]

    def order(self) -> List[str]:
        """Link names from the root, every parent before its children."""
        out, pending = [], [self.root]
        while pending:
            link = pending.pop(0)
            out.append(link)
            pending += [j.child for j in self.children(link)]
        return out

    @property
    def moving_joints(self) -> List[Joint]:
        """The joints with a coordinate, parents before children: the
        order of the joint coordinates everywhere in yasps."""
        by_child = {j.child: j for j in self.joints}
        return [by_child[link] for link in self.order()[1:]
                if by_child[link].kind in MOVING_KINDS]

    def subtree_mass(self, link: str) -> float:
        """The mass of ``link`` and everything below it."""
        return self.links[link].mass + sum(
            self.subtree_mass(j.child) for j in self.children(link))


@dataclass
class MovingBody:
    """Links that move together: the root's, or those behind one moving
    joint up to the next ones. ``frames`` holds each link's frame in the
    body's (the frame of the joint that moves it, or the root link's);
    ``origin`` the joint's frame at coordinate 0 in the parent body's."""
    joint: Optional[Joint]
    parent: int          # index of the parent body, -1 for the root's
    depth: int           # moving joints between it and the root
    frames: Dict[str, np.ndarray]
    origin: np.ndarray = field(default_factory=lambda: np.eye(4))


def moving_bodies(tree: KinematicTree) -> List[MovingBody]:
    """The tree's links grouped by the fixed joints that weld them, parents
    before children; every moving joint starts a body of its own."""
    bodies = [MovingBody(None, -1, 0, {tree.root: np.eye(4)})]
    home: Dict[str, Tuple[int, np.ndarray]] = {tree.root: (0, np.eye(4))}
    by_child = {j.child: j for j in tree.joints}
    for link in tree.order()[1:]:
        joint = by_child[link]
        parent, frame = home[joint.parent]
        if joint.kind == "fixed":
            home[link] = (parent, frame @ joint.origin)
            bodies[parent].frames[link] = home[link][1]
        else:
            bodies.append(MovingBody(joint, parent, bodies[parent].depth + 1,
                                     {link: np.eye(4)}, frame @ joint.origin))
            home[link] = (len(bodies) - 1, np.eye(4))
    return bodies
