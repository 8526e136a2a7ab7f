"""Half-space obstacles (a ground plane, a slope): vertices against planes.

The distance of a vertex to a plane is one dot product, so the broad
phase, the CCD and the closest-point data are closed forms here rather
than ipctk queries (ipctk 1.6's Python planes give no barrier values and
are ignored by its CCD). The barrier is the same IPC barrier as the mesh
pairs', on a dynamic primitive of (vertex, plane) pairs whose plane is a
stored value, so adding pairs or planes compiles nothing.
"""

from __future__ import annotations

from typing import List, Optional, Sequence, Tuple

import numpy as np

from ..frontend import energies as E
from ..frontend.attribute import Attribute
from ..frontend.errors import SceneError
from ..frontend.scene import Mesh, Primitive

#: IPC's conservative rescaling of a time of impact: a step goes at most
#: this fraction of the way to the plane.
CONSERVATIVE_RESCALING = 0.8


def tangent_basis(normal: np.ndarray) -> np.ndarray:
    """An orthonormal 3x2 basis of the plane orthogonal to ``normal``."""
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    helper = np.eye(3)[int(np.argmin(np.abs(n)))]
    t0 = np.cross(n, helper)
    t0 /= np.linalg.norm(t0)
    return np.stack([t0, np.cross(n, t0)], axis=1)


class HalfSpaces:
    """Planes ``n . x >= n . o`` (given as (origin, normal) pairs) that the
    vertices stay above, with the pair primitive ``plane`` on ``mesh``."""

    def __init__(self, mesh: Mesh, vertices, positions: Attribute,
                 planes: Sequence[Tuple[Sequence[float], Sequence[float]]],
                 dhat: float, kappa: Attribute, projection: str):
        normals, offsets = [], []
        for origin, direction in planes:
            n = np.asarray(direction, float).reshape(3)
            if not np.linalg.norm(n) > 0:
                raise SceneError(f"Contact: a half-space needs a non-zero "
                                 f"normal, got {list(n)}")
            n = n / np.linalg.norm(n)
            normals.append(n)
            offsets.append(float(n @ np.asarray(origin, float).reshape(3)))
        self.normals = np.asarray(normals).reshape(-1, 3)
        self.offsets = np.asarray(offsets)
        self.dhat = dhat
        self.primitive: Optional[Primitive] = None
        if not len(self.offsets):
            return
        p = mesh.addPrimitive("plane", numInstances=0, isDynamic=True)
        link = p.addConnectivity("v", vertices, np.zeros((0, 1), np.int64), 1)
        x = p.addAttribute("x", through=link, source=positions).T
        normal = p.addConstant("normal", rows=3)
        offset = p.addConstant("offset", rows=1)
        gap = normal.dot(x) - offset
        energy = E.ipc_standard_barrier(gap * gap, dhat * dhat, 1.0) * kappa
        mesh.scene.addEnergy(p.addAttribute("barrier", computed_attribute=energy),
                             dynamic_instances=True, projection=projection)
        self.primitive = p
        self.update(np.zeros((0, 3)))  # no pairs until the first update

    def planes(self) -> List[Tuple[np.ndarray, np.ndarray]]:
        """The planes as (origin, unit normal) pairs, origins nearest the
        world origin: what ``Contact(halfspaces=...)`` and pictures
        take."""
        return [(n * o, n) for n, o in zip(self.normals, self.offsets)]

    def signed_distances(self, V: np.ndarray) -> np.ndarray:
        """(N, planes): each vertex's signed distance to each plane."""
        return V @ self.normals.T - self.offsets

    def close_pairs(self, V: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """(vertex, plane) index arrays of the vertices within dhat above a
        plane."""
        vertex, plane = np.nonzero(self.signed_distances(V) < self.dhat)
        return vertex, plane

    def update(self, V: np.ndarray) -> int:
        """Sets the pairs to the vertices within dhat of a plane now;
        returns their number."""
        if self.primitive is None:
            return 0
        vertex, plane = self.close_pairs(V)
        p = self.primitive
        p.updateNumInstances(len(vertex))
        p.connectivities["v"].updateConnectivity(vertex.reshape(-1, 1))
        p["normal"].updateValue(self.normals[plane].reshape(-1, 3, 1))
        p["offset"].updateValue(self.offsets[plane].reshape(-1, 1))
        return len(vertex)

    def step_bound(self, V0: np.ndarray, V1: np.ndarray,
                   margin: float = 0.0) -> float:
        """The largest fraction of the straight motion V0 -> V1 that keeps
        every vertex ``margin`` above every plane, with IPC's conservative
        rescaling (the first contact is never reached)."""
        if not len(self.offsets):
            return 1.0
        s0 = self.signed_distances(V0) - margin
        s1 = self.signed_distances(V1) - margin
        crossing = (s0 > 0) & (s1 <= 0)
        if not crossing.any():
            return 1.0
        impact = s0[crossing] / (s0[crossing] - s1[crossing])
        return float(CONSERVATIVE_RESCALING * impact.min())

    def min_distance(self, V: np.ndarray) -> float:
        """The smallest distance of a vertex above a plane (inf if none)."""
        if not len(self.offsets):
            return float("inf")
        return float(self.signed_distances(V).min())

    def lowest(self, V: np.ndarray) -> Tuple[int, int, float]:
        """The vertex closest to (or furthest below) a plane: (vertex,
        plane, signed distance); (-1, -1, inf) without planes."""
        if not len(self.offsets) or not len(V):
            return -1, -1, float("inf")
        distances = self.signed_distances(V)
        vertex, plane = np.unravel_index(int(np.argmin(distances)),
                                         distances.shape)
        return int(vertex), int(plane), float(distances[vertex, plane])

    def lowest_apart(self, V: np.ndarray) -> bool:
        """Whether every vertex lies above every plane (a vertex on or
        below one is where the barrier is infinite, or, below, blind: its
        squared gap may exceed dhat^2)."""
        return not len(self.offsets) or not len(V) or \
            bool((self.signed_distances(V) > 0.0).all())

    def intersecting(self, V: np.ndarray) -> bool:
        """Whether some vertex lies below a plane."""
        return bool(len(self.offsets)) and bool(
            (self.signed_distances(V) < 0).any())

    def friction_pairs(self, V: np.ndarray, start: np.ndarray, barrier,
                       mu: float, pairs) -> np.ndarray:
        """Adds the lagged friction data of the vertices close to a plane
        now to ``pairs`` (a :class:`.friction.FrictionPairs` of arity 1):
        the plane's tangent basis and ipctk's normal-force magnitude of
        ``barrier`` (a BarrierPotential) at the vertex's distance, with
        tangential motion measured from ``start``. Returns the plane of
        each pair added, in order."""
        vertex, plane = self.close_pairs(V)
        gaps = self.signed_distances(V)[vertex, plane]
        for v, k, gap in zip(vertex, plane, gaps):
            force = barrier.force_magnitude(float(gap * gap), 0.0)
            pairs.add([v], [1.0], tangent_basis(self.normals[k]), start[[v]],
                      mu * force)
        return plane
