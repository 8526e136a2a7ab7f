"""Stable Neo-Hookean tets plus inertia, minimised over the vertex
positions: the elastic scene the Newton, preconditioner, precision and GPU
benches time, on the bunny or on boxes."""

from __future__ import annotations

import numpy as np

import yasps
from benchlib.meshes import bunny
from yasps import energies as E

#: Lame parameters (Pa), mass per vertex (kg) and the positions' noise (m).
MU, LAM, MASS, NOISE = 1e4, 4e4, 1e-3, 1e-3


def snh_scene(name: str, verts: np.ndarray, tets: np.ndarray, dt2: float,
              mass: float = MASS, mesh: str = "m") -> "yasps.Scene":
    """Stable Neo-Hookean (scaled by dt^2 = ``dt2``) + inertia (``mass``
    per vertex) on (verts, tets), the positions perturbed by NOISE (seed 0)
    from the rest shape."""
    rest = verts[tets]
    dm = np.stack([rest[:, k] - rest[:, 0] for k in (1, 2, 3)], axis=2)
    rng = np.random.default_rng(0)
    s = yasps.scene(name)
    m = s.addMesh(mesh)
    v = m.addPrimitive("v", numInstances=len(verts))
    t = m.addPrimitive("t", numInstances=len(tets))
    x = v.addAttribute("x", rows=3)
    x.updateValue(verts + rng.normal(scale=NOISE, size=verts.shape))
    v.addConstant("x_hat", rows=3).updateValue(verts)
    t.addConstant("inv", rows=3, cols=3).updateValue(np.linalg.inv(dm))
    t.addConstant("vol", rows=1).updateValue(
        np.abs(np.linalg.det(dm))[:, None] / 6)
    c = t.addAttribute("c", through=t.addConnectivity("t2v", v, tets, 4),
                       source=x)
    s.addEnergy(t.addAttribute("elastic", computed_attribute=dt2 * E.stable_neo_hookean(
        E.deformation_gradient(c, t["inv"]), MU, LAM, t["vol"])))
    s.addEnergy(v.addAttribute("inertia", computed_attribute=E.inertia(
        x, v["x_hat"], mass)))
    s.addMinimizeTarget([x])
    return s


def bunny_snh() -> "yasps.Scene":
    """snh_scene on the 19k-vertex bunny at dt^2 = 1e-4."""
    verts, tets = bunny("19k")
    return snh_scene("bunny", verts, tets, 1e-4, mesh="bunny")


def bunny_snh_inputs():
    """Current positions (N, 12) and inverse rest shapes (N, 9) of the
    bunny's tets, positions perturbed: the kernel inputs bench/gpu.py and
    bench/gpu_kit.py give stable Neo-Hookean."""
    verts, tets = bunny("19k")
    rng = np.random.default_rng(0)
    rest = verts[tets]
    cur = rest + rng.normal(scale=1e-3 * np.abs(verts).max(), size=rest.shape)
    dm_inv = np.linalg.inv(np.stack([rest[:, k] - rest[:, 0]
                                     for k in (1, 2, 3)], axis=2))
    return cur.reshape(-1, 12), dm_inv.reshape(-1, 9)
