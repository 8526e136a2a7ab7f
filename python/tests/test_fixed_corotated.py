"""Fixed corotated elasticity and the sum of signed singular values it needs:
values against NumPy's SVD, derivatives against central differences and
against JAX differentiating its own SVD, rotations at zero energy, and a
body that starts with tets turned inside out recovering in simulation."""

import ipctk
import numpy as np
import pytest

import yasps
from yasps import energies as E
from yasps.contact.surface import surface_of
from yasps.sim import (ImplicitEuler, add_elastic_tets, add_free_vertices,
                       box_tet_mesh, lame, lumped_masses, signed_tet_volumes)

from test_differentiation import check_derivatives, elements_scene

rng = np.random.default_rng(11)


def rotations(count: int, n: int) -> np.ndarray:
    """Random proper rotations (count, n, n)."""
    q, r = np.linalg.qr(rng.standard_normal((count, n, n)))
    q = q * np.sign(np.diagonal(r, axis1=1, axis2=2))[:, None, :]
    flip = np.linalg.det(q) < 0
    q[flip, :, 0] *= -1.0
    return q


def matrices(n: int, count: int) -> np.ndarray:
    """Random n x n matrices of four kinds: near the identity, stretched by
    singular values over e^-4..e^4, with a negative determinant (the
    smallest signed singular value negative, at most 0.9 of the middle
    one), and rotations."""
    near = np.eye(n) + 0.3 * rng.standard_normal((count, n, n))
    sigma = np.sort(np.exp(rng.uniform(-4, 4, (count, n))), axis=1)[:, ::-1]
    stretched = rotations(count, n) @ (sigma[:, :, None] * rotations(count, n))
    inverted_sigma = sigma.copy()
    if n > 1:
        inverted_sigma[:, -1] = -rng.uniform(0.0, 0.9, count) * sigma[:, -2]
    else:
        inverted_sigma[:, -1] *= -1.0
    inverted = rotations(count, n) @ (inverted_sigma[:, :, None]
                                      * rotations(count, n))
    return np.concatenate([near, stretched, inverted, rotations(count, n)])


def signed_sum(F: np.ndarray) -> np.ndarray:
    """tr(S) of F = R S, R a rotation, from NumPy's SVD."""
    U, S, Vt = np.linalg.svd(F)
    S[:, -1] *= np.sign(np.linalg.det(U) * np.linalg.det(Vt))
    return S.sum(axis=1)


@pytest.mark.parametrize("n", [1, 2, 3])
def test_the_sum_of_signed_singular_values_is_numpys(n):
    values = matrices(n, 50)
    s = yasps.scene(f"svs{n}")
    p = s.addMesh("m").addPrimitive("p", numInstances=len(values))
    a = p.addAttribute("a", rows=n, cols=n)
    a.updateValue(values)
    got = a.singularValueSum().compute().value.reshape(-1)
    want = signed_sum(values)
    np.testing.assert_allclose(got, want, rtol=1e-11, atol=1e-14)
    np.testing.assert_allclose(got[-50:], n, rtol=1e-14)


def test_only_square_matrices_of_at_most_3x3():
    s = yasps.scene("svs_shapes")
    p = s.addMesh("m").addPrimitive("p", numInstances=1)
    with pytest.raises(yasps.ShapeError, match="square"):
        p.addAttribute("a", rows=3, cols=2).singularValueSum()
    with pytest.raises(yasps.ShapeError, match="at most 3x3"):
        p.addAttribute("b", rows=4, cols=4).singularValueSum()


def deformation_gradients(count: int) -> np.ndarray:
    """Deformation gradients with distinct singular values, a quarter of
    them inverted: the derivative of tr(S) is singular where two signed
    singular values sum to zero, and central differences are only accurate
    away from it."""
    F = np.eye(3) + 0.4 * rng.standard_normal((count, 3, 3))
    F[::4] = F[::4] @ np.diag([1.0, 1.0, -0.4])
    return F


def psi_numpy(F: np.ndarray, mu: float, lam: float) -> np.ndarray:
    distance = (F * F).sum(axis=(1, 2)) - 2.0 * signed_sum(F) + 3.0
    return mu * distance + 0.5 * lam * (np.linalg.det(F) - 1.0) ** 2


def corotated_on_F(F: np.ndarray, mu: float, lam: float):
    s = yasps.scene("corotated_F")
    t = s.addMesh("m").addPrimitive("t", numInstances=len(F))
    x = t.addAttribute("F", rows=3, cols=3)
    x.updateValue(F)
    energy = t.addAttribute("psi", computed_attribute=E.fixed_corotated(
        x, mu, lam, 1.0))
    s.addEnergy(energy)
    s.addMinimizeTarget([x])
    return s, energy


def test_fixed_corotated_value_and_gradient_are_the_formula():
    F = deformation_gradients(8)
    mu, lam = 1.3, 4.1
    s, energy = corotated_on_F(F, mu, lam)
    d = check_derivatives(s, energy)
    np.testing.assert_allclose(d.value, psi_numpy(F, mu, lam), rtol=1e-12)
    # dPsi/dF = 2 mu (F - R) + lam (J - 1) cof F, R = U diag(1, 1, +-1) V^T.
    U, _, Vt = np.linalg.svd(F)
    D = np.tile(np.eye(3), (len(F), 1, 1))
    D[:, 2, 2] = np.sign(np.linalg.det(U) * np.linalg.det(Vt))
    R = U @ D @ Vt
    J = np.linalg.det(F)
    cof = J[:, None, None] * np.transpose(np.linalg.inv(F), (0, 2, 1))
    P = 2 * mu * (F - R) + lam * (J - 1)[:, None, None] * cof
    np.testing.assert_allclose(d.gradient,
                               np.transpose(P, (0, 2, 1)).reshape(len(F), 9),
                               rtol=1e-10, atol=1e-10 * np.abs(P).max())


def test_fixed_corotated_hessian_is_jaxs():
    jax = pytest.importorskip("jax")
    jax.config.update("jax_enable_x64", True)
    jnp = jax.numpy
    mu, lam = 2.0, 7.0

    def psi(f):
        F = f.reshape(3, 3).T  # column-major, as yasps' parameters
        U, S, Vt = jnp.linalg.svd(F)
        S = S.at[2].multiply(jnp.sign(jnp.linalg.det(U) * jnp.linalg.det(Vt)))
        J = jnp.linalg.det(F)
        return mu * (jnp.sum(F * F) - 2 * jnp.sum(S) + 3) \
            + 0.5 * lam * (J - 1) ** 2

    F = deformation_gradients(8)
    s, energy = corotated_on_F(F, mu, lam)
    d = s.energyDerivatives(energy)
    for k, f in enumerate(F):
        want = np.asarray(jax.hessian(psi)(jnp.asarray(f.T.reshape(-1))))
        np.testing.assert_allclose(d.hessian[k], want, rtol=1e-9,
                                   atol=1e-9 * np.abs(want).max())


def test_fixed_corotated_through_tet_corners_matches_differences():
    base = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    count = 4
    current = base[None] @ deformation_gradients(count).transpose(0, 2, 1) \
        + rng.normal(size=(count, 1, 3))
    s, m, v, e, x, corners = elements_scene(4, current)
    inv = e.addConstant("DmInv", rows=3, cols=3)
    inv.updateValue(np.tile(np.eye(3), (count, 1, 1)))
    F = E.deformation_gradient(corners, inv)
    energy = e.addAttribute("fc", computed_attribute=E.fixed_corotated(
        F, 1.0, 3.0, 1.0 / 6.0))
    s.addEnergy(energy)
    s.addMinimizeTarget([x])
    d = check_derivatives(s, energy)
    assert d.gradient.shape == (count, 12)


def test_rotated_bodies_have_no_energy():
    F = rotations(6, 3)
    s, energy = corotated_on_F(F, 1.0, 5.0)
    d = s.energyDerivatives(energy)
    assert np.abs(d.value).max() < 1e-13
    assert np.abs(d.gradient).max() < 1e-12


def test_a_box_turned_inside_out_recovers():
    """A soft box's middle vertex starts pushed out through a face, so that
    the tets around it are inverted: fixed corotated, defined for inverted
    tets, pulls it back, and the box comes to rest with every tet positive,
    its vertices where they started and its surface free of intersections
    (ipctk)."""
    verts, tets = box_tet_mesh(2, size=0.1)
    middle = int(np.argmin(np.linalg.norm(verts - 0.05, axis=1)))
    start = verts.copy()
    start[middle, 0] = 0.14
    assert (signed_tet_volumes(start, tets) < 0).sum() >= 4
    s = yasps.scene("corotated_recovery")
    m = s.addMesh("box")
    soft = add_free_vertices(m, start, lumped_masses(verts, tets, 1000.0))
    mu, lam = lame(1e4, 0.3)
    add_elastic_tets(m, soft.x, verts, tets, mu, lam, scale=0.02 ** 2,
                     material="fixed_corotated")
    s.addMinimizeTarget(soft.x)
    fixed = (verts[:, 2] == 0) & np.isin(verts[:, 0], (0.0, 0.1)) \
        & np.isin(verts[:, 1], (0.0, 0.1))
    assert fixed.sum() == 4
    stepper = ImplicitEuler(s, soft.x, soft.x_hat, 0.02, fixed=fixed,
                            gravity=None)
    for _ in range(40):
        assert stepper.step().converged
    x = soft.x.value[:, :, 0]
    assert (signed_tet_volumes(x, tets) > 0).all()
    np.testing.assert_allclose(x, verts, atol=2e-3)
    faces = surface_of(tets)
    edges = ipctk.edges(faces)
    mesh = ipctk.CollisionMesh(verts, edges, faces)
    assert not ipctk.has_intersections(mesh, x)
