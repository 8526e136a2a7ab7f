"""IPC's lagged, smoothed friction as yasps energies on dynamic pair
primitives.

Per time step (the "lag"), ipctk's tangential collision set at the step's
start positions x^t gives each pair its vertices, closest-point
coefficients c_k (relative motion ``sum_k c_k x_k``), tangent basis T (3x2)
and normal-force magnitude N. The energy of a pair is then ipctk's
FrictionPotential on displacements,

    D = weight * mu * N * f0(|u|),   u = T^T sum_k c_k (x_k - x_k^t),

with f0 IPC's smoothed |u| (C1 at |u| = eps_u, eps_u = eps_v dt). Everything
lagged is a stored value of the pair, and u is written over the pair's
world positions, so the compiler differentiates friction through any
parameterisation of the vertices, like the barrier.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List

import numpy as np

from ..frontend.attribute import Attribute, select
from ..frontend.scene import Mesh, Primitive

#: Stencil sizes of friction pairs: a vertex against a half-space, two
#: vertices, vertex-edge, and vertex-triangle or edge-edge.
ARITIES = (1, 2, 3, 4)

#: Below this fraction of eps_u the cubic term of f0 is dropped: it is
#: below 1e-12 of the quadratic one, and |u|^3 written with a square root
#: has no derivative to evaluate at u = 0, where every pair starts a step.
_TINY = 1e-12


def smoothed_norm(u: Attribute, eps: Attribute) -> Attribute:
    """IPC's f0(|u|): |u| from eps on, ``-|u|^3/(3 eps^2) + |u|^2/eps +
    eps/3`` below (C1 at eps, and smooth at u = 0)."""
    s = u.squaredNorm()
    y = s.sqrt()
    eps2 = eps * eps
    quadratic = s / eps + eps / 3.0
    cubic = quadratic - s * y / (3.0 * eps2)
    tiny = eps2 * (_TINY * _TINY)
    return select(s < tiny, quadratic, select(s < eps2, cubic, y))


def friction_energy(gathered: Attribute, coef: Attribute, basis: Attribute,
                    lagged: Attribute, scale: Attribute,
                    eps: Attribute) -> Attribute:
    """``scale * f0(|T^T G^T c - u^t|)`` over a pair's gathered world
    positions G (arity x 3), coefficients c (arity x 1), tangent basis T
    (3x2) and lagged tangential position u^t (2x1); ``scale`` is weight *
    mu * N."""
    u = basis.T * (gathered.T * coef) - lagged
    return scale * smoothed_norm(u, eps)


@dataclass
class FrictionPairs:
    """Lagged friction pairs of one stencil size, gathered at a lag: the
    rows the primitive receives."""
    arity: int
    vertices: List[List[int]] = field(default_factory=list)
    coef: List[np.ndarray] = field(default_factory=list)
    basis: List[np.ndarray] = field(default_factory=list)
    lagged: List[np.ndarray] = field(default_factory=list)
    scale: List[float] = field(default_factory=list)

    def add(self, ids, coef: np.ndarray, basis: np.ndarray,
            start: np.ndarray, scale: float) -> None:
        """One pair: its vertex ids, coefficients, basis (3x2), the
        positions of its vertices at the lag (arity x 3) and weight*mu*N."""
        coef = np.asarray(coef, float).reshape(self.arity)
        self.vertices.append([int(i) for i in ids])
        self.coef.append(coef)
        self.basis.append(np.asarray(basis, float).reshape(3, 2))
        self.lagged.append(self.basis[-1].T @ (np.asarray(start).T @ coef))
        self.scale.append(float(scale))

    def sort(self) -> None:
        """Orders the pairs by their vertex ids: ipctk builds its sets on
        several threads, in an order that varies from run to run, and the
        pairs' order is the order their terms are summed in."""
        order = sorted(range(len(self.vertices)),
                       key=lambda k: self.vertices[k])
        for name in ("vertices", "coef", "basis", "lagged", "scale"):
            values = getattr(self, name)
            setattr(self, name, [values[k] for k in order])

    def store(self, p: Primitive) -> None:
        """Writes the pairs into their dynamic primitive."""
        n, k = len(self.vertices), self.arity
        p.updateNumInstances(n)
        p.connectivities["v"].updateConnectivity(
            np.asarray(self.vertices, dtype=np.int64).reshape(n, k))
        p["coef"].updateValue(np.asarray(self.coef).reshape(n, k, 1))
        p["basis"].updateValue(np.asarray(self.basis).reshape(n, 3, 2))
        p["lagged"].updateValue(np.asarray(self.lagged).reshape(n, 2, 1))
        p["scale"].updateValue(np.asarray(self.scale).reshape(n, 1))


def add_friction_primitives(mesh: Mesh, vertices, positions: Attribute,
                            eps: Attribute,
                            projection: str) -> Dict[int, Primitive]:
    """One dynamic friction primitive per stencil size on ``mesh``, joined
    to ``vertices`` (whose world positions are ``positions``), each with its
    friction energy registered; initially empty."""
    primitives: Dict[int, Primitive] = {}
    for arity in ARITIES:
        p = mesh.addPrimitive(f"friction{arity}", numInstances=0,
                              isDynamic=True)
        link = p.addConnectivity("v", vertices,
                                 np.zeros((0, arity), np.int64), arity)
        gathered = p.addAttribute("x", through=link, source=positions)
        energy = friction_energy(gathered, p.addConstant("coef", rows=arity),
                                 p.addConstant("basis", rows=3, cols=2),
                                 p.addConstant("lagged", rows=2),
                                 p.addConstant("scale", rows=1), eps)
        mesh.scene.addEnergy(p.addAttribute("friction",
                                            computed_attribute=energy),
                             dynamic_instances=True, projection=projection)
        FrictionPairs(arity).store(p)  # no pairs until the first lag
        primitives[arity] = p
    return primitives


def tangential_pairs(collisions, mesh, V: np.ndarray, start: np.ndarray,
                     pairs: Dict[int, FrictionPairs]) -> None:
    """Adds every collision of ipctk's tangential set ``collisions`` (built
    on ``mesh`` at positions ``V``) to ``pairs`` by its stencil size, with
    ipctk's coefficients (the relative-velocity Jacobian's blocks), basis,
    weight, mu and normal force, and the positions ``start`` that
    tangential motion is measured from."""
    edges, faces = mesh.edges, mesh.faces
    for group in (collisions.vv_collisions, collisions.ev_collisions,
                  collisions.ee_collisions, collisions.fv_collisions):
        for collision in group:
            arity = collision.num_vertices()
            ids = collision.vertex_ids(edges, faces)[:arity]
            # Gamma = [c_0 I, c_1 I, ...]: its first row holds the c_k.
            coef = collision.relative_velocity_jacobian()[0, ::3]
            scale = (collision.weight * collision.mu_k
                     * collision.normal_force_magnitude)
            pairs[arity].add(ids, coef, collision.tangent_basis,
                             start[ids], scale)
