"""Bodies for simulations: a soft tet mesh with stable Neo-Hookean
elasticity on its vertices' positions."""

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
