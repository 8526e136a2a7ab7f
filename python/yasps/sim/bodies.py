"""Bodies for simulations: a soft tet mesh with stable Neo-Hookean
elasticity on its vertices' positions, and an affine body's inertia."""

from __future__ import annotations

import numpy as np

from ..frontend import energies as E
from ..frontend.attribute import Attribute
from ..frontend.scene import Mesh


def add_elastic_tets(mesh: Mesh, positions: Attribute, rest: np.ndarray,
                     tets: np.ndarray, mu: float, lam: float,
                     scale: float = 1.0, name: str = "t") -> Attribute:
    """Adds a primitive ``name`` of the tets (M, 4) of the vertices that
    ``positions`` belongs to, with their rest shape (the inverse of the rest
    edge matrix and the volume, from ``rest`` (N, 3)) and registers
    ``scale`` times stable Neo-Hookean (``mu``, ``lam``, per unit volume) on
    them as an energy (``scale``: dt^2 for implicit Euler). Returns it."""
    tets = np.asarray(tets, dtype=np.int64).reshape(-1, 4)
    corners = np.asarray(rest, dtype=float)[tets]
    edges = np.stack([corners[:, k] - corners[:, 0] for k in (1, 2, 3)], axis=2)
    t = mesh.addPrimitive(name, numInstances=len(tets))
    t.addConstant("inv", rows=3, cols=3).updateValue(np.linalg.inv(edges))
    t.addConstant("vol", rows=1).updateValue(
        np.abs(np.linalg.det(edges))[:, None] / 6)
    gathered = t.addAttribute("c", through=t.addConnectivity(
        "t2v", positions.owner, tets, 4), source=positions)
    energy = t.addAttribute("elastic", computed_attribute=scale *
                            E.stable_neo_hookean(E.deformation_gradient(
                                gathered, t["inv"]), mu, lam, t["vol"]))
    mesh.scene.addEnergy(energy)
    return energy


def add_affine_inertia(body, A: Attribute, t: Attribute, A_hat: Attribute,
                       t_hat: Attribute, rest: np.ndarray,
                       masses: np.ndarray, name: str = "inertia") -> Attribute:
    """Registers the implicit-Euler inertia of an affine body (one instance
    of ``body``, world positions A r + t of vertices at rest ``rest`` (N, 3)
    with ``masses`` (N,)): the vertices' ``sum m_i/2 |dA r_i + dt|^2`` with
    dA = A - A_hat, dt = t - t_hat, written with the body's mass moments
    (sum m r r^T, sum m r, sum m) so that it costs one instance, not N.
    Returns the energy."""
    rest = np.asarray(rest, dtype=float).reshape(-1, 3)
    masses = np.asarray(masses, dtype=float).reshape(-1)
    if masses.shape != (len(rest),):
        raise ValueError(f"add_affine_inertia: {len(masses)} masses for "
                         f"{len(rest)} vertices")
    second = body.addConstant(name + "_second_moment", rows=3, cols=3)
    second.updateValue(np.einsum("i,ij,ik->jk", masses, rest, rest))
    first = body.addConstant(name + "_first_moment", rows=3)
    first.updateValue(masses @ rest)
    total = float(masses.sum())
    dA, dt = A - A_hat, t - t_hat
    energy = body.addAttribute(name, computed_attribute=
                               0.5 * (dA * second * dA.T).trace()
                               + (dA * first).dot(dt)
                               + 0.5 * total * dt.squaredNorm())
    body.scene.addEnergy(energy)
    return energy
