"""The simulation helpers keep material parameters and time-step scales as
stored values of the body's mesh, not numbers in the IR: a scene rebuilt
with other values compiles no kernel, and the energies equal NumPy's
formulas at the values stored now (stable Neo-Hookean, ABD's
orthogonality) or scale with them (cloth)."""

import numpy as np

import yasps
from yasps.compiler.cpu import kernels_compiled
from yasps.sim import (add_affine_body, add_cloth, add_elastic_tets,
                       box_tet_mesh, cloth_grid)

RNG = np.random.default_rng(7)
VERTS, TETS = box_tet_mesh(1, 0.2)
DEFORMED = VERTS @ (np.eye(3) + 0.1 * RNG.standard_normal((3, 3))).T


def stable_neo_hookean(mu: float, lam: float, scale: float) -> float:
    """The soft box's energy in NumPy (Smith et al. 2018)."""
    def edges(p):
        c = p[TETS]
        return np.stack([c[:, k] - c[:, 0] for k in (1, 2, 3)], axis=2)
    rest = edges(VERTS)
    F = edges(DEFORMED) @ np.linalg.inv(rest)
    ic = (F * F).sum(axis=(1, 2))
    J = np.linalg.det(F)
    alpha = 1 + 0.75 * mu / lam
    psi = 0.5 * mu * (ic - 3) - 0.5 * mu * np.log(ic + 1) \
        + 0.5 * lam * (J - alpha) ** 2
    return scale * float((np.abs(np.linalg.det(rest)) / 6 * psi).sum())


def soft_box(mu: float, lam: float, scale: float):
    """A deformed soft box with the helper's elasticity: (scene, mesh)."""
    s = yasps.scene("materials")
    mesh = s.addMesh("box")
    v = mesh.addPrimitive("v", numInstances=len(VERTS))
    x = v.addAttribute("x", rows=3)
    x.updateValue(DEFORMED)
    add_elastic_tets(mesh, x, VERTS, TETS, mu, lam, scale=scale)
    s.addMinimizeTarget(x)
    return s, mesh


def cloth(stretch: float, shear: float, bending: float):
    """A crumpled 3x3 cloth with the helper's energies: the scene."""
    verts, faces = cloth_grid(3, 0.3)
    s = yasps.scene("cloth_materials")
    mesh = s.addMesh("cloth")
    v = mesh.addPrimitive("v", numInstances=len(verts))
    x = v.addAttribute("x", rows=3)
    x.updateValue(verts + 0.02 * np.random.default_rng(1).standard_normal(
        verts.shape))
    add_cloth(mesh, x, verts, faces, stretch, shear, bending, scale=1e-4)
    s.addMinimizeTarget(x)
    return s


def affine_box(stiffness: float, scale: float):
    """An affine box with A off a rotation: (scene, A)."""
    s = yasps.scene("abd_materials")
    body = add_affine_body(s.addMesh("rigid"), VERTS, np.full(len(VERTS), 0.1),
                           stiffness, scale=scale)
    body.A.updateValue(np.eye(3) + 0.05 * RNG.standard_normal((3, 3)))
    s.addMinimizeTarget([body.A, body.t])
    return s, body.A


def test_elastic_tets_with_other_materials_compile_nothing():
    s, _ = soft_box(1e3, 4e3, 1e-4)
    want = stable_neo_hookean(1e3, 4e3, 1e-4)
    assert abs(s.evaluateEnergy() - want) <= 1e-12 * abs(want)
    s.minimizeEnergy()
    compiled = kernels_compiled()
    s, mesh = soft_box(5e5, 2e6, 4e-4)
    want = stable_neo_hookean(5e5, 2e6, 4e-4)
    assert abs(s.evaluateEnergy() - want) <= 1e-12 * abs(want)
    s.minimizeEnergy()
    assert kernels_compiled() == compiled
    # In place: a stored value changes without rebuilding the scene.
    mesh["t_mu"].updateValue([2e5])
    want = stable_neo_hookean(2e5, 2e6, 4e-4)
    assert abs(s.evaluateEnergy() - want) <= 1e-12 * abs(want)
    assert kernels_compiled() == compiled


def test_cloth_with_other_materials_compiles_nothing():
    s = cloth(100.0, 50.0, 0.1)
    base = s.evaluateEnergy()
    s.minimizeEnergy()
    compiled = kernels_compiled()
    s = cloth(300.0, 150.0, 0.3)
    assert abs(s.evaluateEnergy() - 3 * base) <= 1e-12 * 3 * base
    s.minimizeEnergy()
    assert kernels_compiled() == compiled


def test_affine_body_with_another_stiffness_compiles_nothing():
    s, A = affine_box(1e4, 1e-4)
    s.evaluateEnergy()
    s.minimizeEnergy()
    compiled = kernels_compiled()
    s, A = affine_box(3e6, 4e-4)
    a = A.value[0]
    # Inertia about A_hat = I, t = t_hat, plus the orthogonality energy.
    dA = a - np.eye(3)
    want = 0.5 * np.trace(dA @ (0.1 * VERTS.T @ VERTS) @ dA.T) + \
        0.5 * 3e6 * 4e-4 * float(np.sum((a.T @ a - np.eye(3)) ** 2))
    assert abs(s.evaluateEnergy() - want) <= 1e-12 * want
    s.minimizeEnergy()
    assert kernels_compiled() == compiled
