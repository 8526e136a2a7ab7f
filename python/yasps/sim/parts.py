"""Parts of contact scenes that every user would otherwise wire by hand:
static obstacles, the UNION of the bodies' surfaces that a Contact takes,
and a body embedded in a cage.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence, Tuple

import numpy as np

from ..frontend.attribute import Attribute
from ..frontend.errors import SceneError
from ..frontend.scene import Mesh, Primitive, PrimitiveUnion, Scene
from .bodies import (FreeVertices, add_caged_surface, add_elastic_tets,
                     add_free_vertices, add_hex8_neo_hookean)
from .meshes import Cage, cage_grid, hex_tets


def add_obstacle(mesh: Mesh, vertices: np.ndarray,
                 name: str = "v") -> Primitive:
    """A primitive ``name`` of static vertices at ``vertices`` (N, 3): their
    ``position`` is a stored constant, so contact meets them and nothing
    moves them (a floor mesh, a bowl, a plate with a hole)."""
    vertices = np.asarray(vertices, dtype=float).reshape(-1, 3)
    p = mesh.addPrimitive(name, numInstances=len(vertices))
    p.addConstant("position", rows=3).updateValue(vertices)
    return p


def contact_union(scene: Scene, parts: Sequence[Tuple[Primitive, np.ndarray]],
                  name: str = "all") -> Tuple[PrimitiveUnion, np.ndarray]:
    """The UNION of the primitives of ``parts`` (``(primitive, faces)``, the
    faces (M, 3) or edges (M, 2) numbered within each primitive, or None),
    with its ``position``, and all faces renumbered into it: ``(union,
    faces)`` for ``Contact(scene, union, faces=faces)``. A mesh ``name``
    holds the UNION."""
    members, faces, offset = [], [], 0
    for primitive, F in parts:
        if "position" not in primitive:
            raise SceneError(f"contact_union: {primitive.describe()} has no "
                             f"'position' (its world positions)")
        members.append(primitive)
        if F is not None:
            faces.append(np.asarray(F, dtype=np.int64).reshape(-1, 3)
                         + offset)
        offset += primitive.numInstances
    union = scene.addMesh(name).addPrimitiveUnion("v", members)
    union.addAttribute("position")
    return union, (np.concatenate(faces) if faces
                   else np.zeros((0, 3), np.int64))


@dataclass
class CagedBody:
    """A body embedded in a cage (:func:`add_caged_body`)."""
    #: the cage's corners: free vertices with their inertia
    corners: FreeVertices
    #: the cage
    cage: Cage
    #: the embedded surface points, with a computed ``position``
    points: Primitive
    #: the surface's triangles, numbered within ``points``
    faces: np.ndarray

    @property
    def positions(self) -> Attribute:
        return self.points["position"]


def add_caged_body(mesh: Mesh, vertices: np.ndarray, faces: np.ndarray,
                   masses: np.ndarray, cells: int, mu: float, lam: float,
                   scale: float = 1.0,
                   discretization: str = "tet4") -> CagedBody:
    """A body of ``vertices`` (N, 3) with surface ``faces`` (M, 3) and
    vertex ``masses`` moved by a cage of ``cells`` cells along its longest
    side (paper 9.3): the cage's corners are free vertices carrying the
    body's mass (each point's mass shared by its cell's corners by its
    trilinear weights), with Neo-Hookean elasticity of (``mu``, ``lam``)
    on the cage (``discretization``: "tet4", five tets per cell, or
    "hex8", 2x2x2 Gauss points); only the surface's vertices are embedded
    (they are what contact sees). Add ``body.corners.x`` to the targets
    (prediction ``body.corners.x_hat``)."""
    if discretization not in ("tet4", "hex8"):
        raise SceneError(f"add_caged_body: discretization must be 'tet4' or "
                         f"'hex8', got {discretization!r}")
    vertices = np.asarray(vertices, dtype=float).reshape(-1, 3)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    cage = cage_grid(vertices, cells)
    corner_masses = np.zeros(len(cage.vertices))
    np.add.at(corner_masses, cage.corners_of_points().reshape(-1),
              (cage.weights * np.broadcast_to(
                  np.asarray(masses, float).reshape(-1), (len(vertices),)
              )[:, None]).reshape(-1))
    corners = add_free_vertices(mesh, cage.vertices, corner_masses,
                                name="cage")
    if discretization == "tet4":
        add_elastic_tets(mesh, corners.x, cage.vertices, hex_tets(cage.hexes),
                         mu, lam, scale=scale)
    else:
        add_hex8_neo_hookean(mesh, corners.x, cage.vertices, cage.hexes, mu,
                             lam, scale=scale)
    on_surface = np.unique(faces)
    renumber = np.full(len(vertices), -1, dtype=np.int64)
    renumber[on_surface] = np.arange(len(on_surface))
    surface = Cage(cage.vertices, cage.hexes, cage.cell_of[on_surface],
                   cage.weights[on_surface])
    points = add_caged_surface(mesh, corners.x, surface)
    return CagedBody(corners, cage, points, renumber[faces])
