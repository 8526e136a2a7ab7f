"""A closed genus-0 surface mapped onto the unit sphere, and back: the
parameterisation of the paper's repulsive curve on the bunny (9.5).

:func:`smooth_to_sphere` smooths the surface continuously until it is a
sphere (Laplacian smoothing of its vertices on the sphere, re-centred each
step, which untangles the radial projection of a non-convex surface);
:class:`SphereMap` locates points of the sphere in its triangles, maps them
back onto the surface through the same barycentric coordinates, and gives
each vertex the density of the surface over the sphere."""

from __future__ import annotations

from typing import Optional, Tuple

import numpy as np

from ..contact.surface import edges_of
from ..frontend.errors import ArgumentError


def triangle_orientations(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Six times the signed volume of each triangle's tet with the origin:
    positive where a triangle of the sphere faces outwards."""
    T = np.asarray(points, float)[np.asarray(faces)]
    return np.einsum("ij,ij->i", T[:, 0], np.cross(T[:, 1], T[:, 2]))


def triangle_areas(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    T = np.asarray(points, float)[np.asarray(faces)]
    return 0.5 * np.linalg.norm(np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]),
                                axis=1)


def smooth_to_sphere(verts: np.ndarray, faces: np.ndarray,
                     max_iterations: Optional[int] = None) -> np.ndarray:
    """Unit-sphere positions (N, 3) for the vertices of the closed, outward
    oriented genus-0 surface (``verts``, ``faces``): the vertices projected
    from their centroid onto the sphere, then smoothed (each moves half way
    to its neighbours' mean, back onto the sphere, the whole re-centred)
    until no triangle faces inwards, and as many iterations again to even
    them out. Raises ValueError if ``max_iterations`` (by default 20 per
    vertex: smoothing spreads over the mesh in about as many iterations as
    its diameter in edges squared) do not untangle it."""
    verts = np.asarray(verts, float)
    faces = np.asarray(faces, np.int64)
    edges = edges_of(faces).astype(np.int64)
    degree = np.bincount(edges.ravel(), minlength=len(verts))[:, None]
    X = verts - verts.mean(axis=0)
    X /= np.linalg.norm(X, axis=1, keepdims=True)
    if max_iterations is None:
        max_iterations = 20 * len(verts)
    untangled = None
    for iteration in range(max_iterations):
        neighbours = np.zeros_like(X)
        np.add.at(neighbours, edges[:, 0], X[edges[:, 1]])
        np.add.at(neighbours, edges[:, 1], X[edges[:, 0]])
        X = 0.5 * X + 0.5 * neighbours / degree
        X -= X.mean(axis=0)
        X /= np.linalg.norm(X, axis=1, keepdims=True)
        if untangled is None and (triangle_orientations(X, faces) > 0).all():
            untangled = iteration
        if untangled is not None and iteration >= 2 * untangled + 1:
            return X
    raise ArgumentError(f"smooth_to_sphere: {max_iterations} iterations left "
                        f"{int((triangle_orientations(X, faces) <= 0).sum())} "
                        f"triangles facing inwards (is the surface genus 0 and "
                        f"oriented outwards?)")


class SphereMap:
    """The map between a surface (``surface`` (N, 3), ``faces``) and its
    triangulation of the unit sphere (``sphere`` (N, 3), same faces, every
    triangle facing outwards)."""

    def __init__(self, sphere: np.ndarray, faces: np.ndarray,
                 surface: np.ndarray):
        self.sphere = np.asarray(sphere, float)
        self.faces = np.asarray(faces, np.int64)
        self.surface = np.asarray(surface, float)
        if (triangle_orientations(self.sphere, self.faces) <= 0).any():
            raise ArgumentError("SphereMap: some triangles of the sphere face "
                                "inwards: not a one-to-one map")

    def locate(self, points: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """For points (M, 3) (their directions from the origin): the
        triangle each lies in and its barycentric coordinates there,
        ((M,), (M, 3)), from the triangle whose cone holds the direction."""
        P = np.asarray(points, float).reshape(-1, 3)
        T = self.sphere[self.faces]                          # (F, 3, 3)
        # Solve P = T^T w per triangle; inside where all w >= 0.
        inverse = np.linalg.inv(np.transpose(T, (0, 2, 1)))  # (F, 3, 3)
        weights = np.einsum("fij,mj->mfi", inverse, P)       # (M, F, 3)
        inside = (weights >= -1e-12).all(axis=2)
        score = np.where(inside, weights.min(axis=2), -np.inf)
        triangle = np.argmax(score, axis=1)
        w = weights[np.arange(len(P)), triangle]
        return triangle, w / w.sum(axis=1, keepdims=True)

    def to_surface(self, points: np.ndarray) -> np.ndarray:
        """Points of the sphere mapped onto the surface, (M, 3)."""
        triangle, w = self.locate(points)
        return np.einsum("mk,mkd->md", w, self.surface[self.faces[triangle]])

    def vertex_density(self) -> np.ndarray:
        """The surface's area over the sphere's, per triangle (the paper's
        rho = A_bunny / A_sphere), averaged at each vertex over the
        triangles around it, (N,)."""
        rho = triangle_areas(self.surface, self.faces) / \
            triangle_areas(self.sphere, self.faces)
        total = np.zeros(len(self.sphere))
        count = np.zeros(len(self.sphere))
        np.add.at(total, self.faces.ravel(), np.repeat(rho, 3))
        np.add.at(count, self.faces.ravel(), 1.0)
        return total / count

    def density_at(self, points: np.ndarray) -> np.ndarray:
        """The vertex density interpolated at points of the sphere, (M,)."""
        triangle, w = self.locate(points)
        return np.einsum("mk,mk->m", w, self.vertex_density()[
            self.faces[triangle]])
