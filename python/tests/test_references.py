"""Compiled derivatives against independent references: JAX autodiff of the
same formulas, and ipctk's distance and barrier derivatives."""

import numpy as np
import pytest

import yasps
from yasps import energies as E

import ipctk  # noqa: E402  (installed by scripts/setup.sh)
import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)
jnp = jax.numpy

rng = np.random.default_rng(11)
COUNT = 3


def elements(arity, values):
    s = yasps.scene("ref")
    m = s.addMesh("m")
    v = m.addPrimitive("v", numInstances=COUNT * arity)
    e = m.addPrimitive("e", numInstances=COUNT)
    x = v.addAttribute("x", rows=3, cols=1)
    x.updateValue(values.reshape(-1, 3))
    conn = e.addConnectivity("e2v", v, np.arange(COUNT * arity).reshape(COUNT, arity), arity)
    return s, e, x, e.addAttribute("c", through=conn, source=x)


def derivatives(s, e, energy):
    s.addEnergy(e.addAttribute("energy", computed_attribute=energy))
    s.addMinimizeTarget([s.m.v["x"]])
    return s.energyDerivatives(s.m.e["energy"])


def assert_close(got, want, rtol=1e-10):
    scale = np.abs(want).max()
    assert np.abs(got - want).max() <= rtol * scale, np.abs(got - want).max() / scale


def test_stable_neo_hookean_against_jax():
    base = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    rest = base[None] + rng.normal(scale=0.05, size=(COUNT, 4, 3))
    cur = rest @ (np.eye(3) + rng.normal(scale=0.3, size=(COUNT, 3, 3)))
    dm_inv = np.linalg.inv(np.stack([rest[:, k] - rest[:, 0] for k in (1, 2, 3)], axis=2))
    mu, lam = 1.7, 9.0
    s, e, x, c = elements(4, cur)
    inv = e.addConstant("inv", rows=3, cols=3)
    inv.updateValue(dm_inv)
    d = derivatives(s, e, E.stable_neo_hookean(E.deformation_gradient(c, inv), mu, lam, 1.0))

    def psi(flat, dinv):
        p = flat.reshape(4, 3)
        F = jnp.stack([p[k] - p[0] for k in (1, 2, 3)], axis=1) @ dinv
        ic = jnp.sum(F * F)
        J = jnp.linalg.det(F)
        alpha = 1 + 0.75 * mu / lam
        return 0.5 * mu * (ic - 3) - 0.5 * mu * jnp.log(ic + 1) + 0.5 * lam * (J - alpha) ** 2

    for i in range(COUNT):
        args = (jnp.array(cur[i].reshape(-1)), jnp.array(dm_inv[i]))
        assert_close(d.gradient[i], np.array(jax.grad(psi)(*args)))
        assert_close(d.hessian[i], np.array(jax.hessian(psi)(*args)))


def test_ipc_neo_hookean_against_jax():
    """IPC's Neo-Hookean (log J terms) at deformations with J > 0: energy,
    gradient and Hessian of JAX's autodiff of the same formula."""
    base = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    rest = base[None] + rng.normal(scale=0.05, size=(COUNT, 4, 3))
    cur = rest @ (np.eye(3) + rng.normal(scale=0.2, size=(COUNT, 3, 3)))
    dm_inv = np.linalg.inv(np.stack([rest[:, k] - rest[:, 0]
                                     for k in (1, 2, 3)], axis=2))
    mu, lam = 1.7, 9.0
    s, e, x, c = elements(4, cur)
    inv = e.addConstant("inv", rows=3, cols=3)
    inv.updateValue(dm_inv)
    energy = E.neo_hookean(E.deformation_gradient(c, inv), mu, lam, 1.0)
    d = derivatives(s, e, energy)

    def psi(flat, dinv):
        p = flat.reshape(4, 3)
        F = jnp.stack([p[k] - p[0] for k in (1, 2, 3)], axis=1) @ dinv
        log_j = jnp.log(jnp.linalg.det(F))
        return 0.5 * mu * (jnp.sum(F * F) - 3) - mu * log_j \
            + 0.5 * lam * log_j ** 2

    values = s.m.e["energy"].compute().value.reshape(-1)
    for i in range(COUNT):
        args = (jnp.array(cur[i].reshape(-1)), jnp.array(dm_inv[i]))
        assert values[i] == pytest.approx(float(psi(*args)), rel=1e-12)
        assert_close(d.gradient[i], np.array(jax.grad(psi)(*args)))
        assert_close(d.hessian[i], np.array(jax.hessian(psi)(*args)))


def test_bending_and_cloth_against_jax():
    hinge = np.array([[0, 0, 0], [1, 0, 0], [0.3, 1, 0], [0.6, -1, 0.4]], float)[None] \
        + rng.normal(scale=0.05, size=(COUNT, 4, 3))
    s, e, x, c = elements(4, hinge)
    d = derivatives(s, e, E.dihedral_bending(c, 0.7, 2.0))

    def bend(flat):
        x0, x1, x2, x3 = flat.reshape(4, 3)
        n1 = jnp.cross(x1 - x0, x2 - x0)
        n2 = jnp.cross(x3 - x0, x1 - x0)
        diff = n1 / jnp.linalg.norm(n1) - n2 / jnp.linalg.norm(n2)
        return 2.0 * 0.7 * jnp.sum(diff * diff)

    for i in range(COUNT):
        assert_close(d.hessian[i], np.array(jax.hessian(bend)(jnp.array(hinge[i].reshape(-1)))))


@pytest.mark.parametrize("kind", ["pp", "pe", "pt", "ee"])
def test_distances_against_ipctk(kind):
    arity = {"pp": 2, "pe": 3, "pt": 4, "ee": 4}[kind]
    pts = rng.normal(size=(COUNT, arity, 3))
    s, e, x, c = elements(arity, pts)
    rows = [c.row(i).T for i in range(arity)]
    fn = {"pp": E.point_point_distance2, "pe": E.point_edge_distance2,
          "pt": E.point_triangle_distance2, "ee": E.edge_edge_distance2}[kind]
    d = derivatives(s, e, fn(*rows))
    ref = {"pp": ("point_point_distance", 2), "pe": ("point_line_distance", 3),
           "pt": ("point_plane_distance", 4), "ee": ("line_line_distance", 4)}[kind][0]
    for i in range(COUNT):
        p = [pts[i, k] for k in range(arity)]
        assert_close(d.value[i:i + 1], np.array([getattr(ipctk, ref)(*p)]), 1e-12)
        assert_close(d.gradient[i], getattr(ipctk, ref + "_gradient")(*p))
        assert_close(d.hessian[i], getattr(ipctk, ref + "_hessian")(*p))


def test_barrier_chain_rule_against_ipctk():
    pts = rng.normal(scale=0.01, size=(COUNT, 2, 3))
    s, e, x, c = elements(2, pts)
    d2 = E.point_point_distance2(c.row(0), c.row(1))
    dhat = 2.0 * max(ipctk.point_point_distance(a, b) for a, b in pts)
    d = derivatives(s, e, E.ipc_standard_barrier(d2, dhat))
    for i in range(COUNT):
        a, b = pts[i]
        dist = ipctk.point_point_distance(a, b)
        assert dist < dhat
        g_d = ipctk.point_point_distance_gradient(a, b)
        h_d = ipctk.point_point_distance_hessian(a, b)
        b1 = ipctk.barrier_first_derivative(dist, dhat)
        b2 = ipctk.barrier_second_derivative(dist, dhat)
        assert_close(d.value[i:i + 1], np.array([ipctk.barrier(dist, dhat)]), 1e-12)
        assert_close(d.gradient[i], b1 * g_d)
        assert_close(d.hessian[i], b2 * np.outer(g_d, g_d) + b1 * h_d)


def jax_check(d, f, inputs, rtol=1e-10):
    """Gradient and Hessian of every instance against jax.grad / hessian."""
    for i in range(len(d.value)):
        args = [jnp.array(a[i]) for a in inputs]
        assert_close(d.value[i:i + 1], np.array([f(*args)]), 1e-12)
        assert_close(d.gradient[i], np.array(jax.grad(f)(*args)), rtol)
        assert_close(d.hessian[i], np.array(jax.hessian(f)(*args)), rtol)


def test_inertia_gravity_and_spring_against_jax():
    s = yasps.scene("v")
    v = s.addMesh("m").addPrimitive("v", numInstances=COUNT)
    x = v.addAttribute("x", rows=3)
    X = rng.normal(size=(COUNT, 3))
    x.updateValue(X)
    xh = v.addConstant("xh", rows=3)
    XH = rng.normal(size=(COUNT, 3))
    xh.updateValue(XH)
    g = np.array([0.0, -9.81, 0.0])
    e = v.addAttribute("e", computed_attribute=E.inertia(x, xh, 2.0) + E.gravity(x, 2.0, g))
    s.addEnergy(e)
    s.addMinimizeTarget([x])
    jax_check(s.energyDerivatives(e),
              lambda p, q: 1.0 * jnp.sum((p - q) ** 2) - 2.0 * jnp.dot(g, p), [X, XH])

    ends = rng.normal(size=(COUNT, 2, 3))
    s2, e2, x2, c2 = elements(2, ends)
    d = derivatives(s2, e2, E.mass_spring(c2, 0.8, 5.0))
    jax_check(d, lambda p: 2.5 * (jnp.linalg.norm(p[3:] - p[:3]) - 0.8) ** 2,
              [ends.reshape(COUNT, 6)])


def test_cloth_abd_and_deformation_gradient_energy_against_jax():
    rest = np.array([[0, 0], [1, 0], [0, 1]], float)[None] + rng.normal(scale=0.05, size=(COUNT, 3, 2))
    cur = np.concatenate([rest, np.zeros((COUNT, 3, 1))], axis=2) @ (np.eye(3) + rng.normal(scale=0.2, size=(COUNT, 3, 3)))
    inv = np.linalg.inv(np.stack([rest[:, k] - rest[:, 0] for k in (1, 2)], axis=2))
    s, e, x, c = elements(3, cur)
    duv = e.addConstant("inv", rows=2, cols=2)
    duv.updateValue(inv)
    d = derivatives(s, e, E.baraff_witkin(c, duv, 0.5, 30.0, 10.0))

    def bw(p, dinv):
        q = p.reshape(3, 3)
        W = jnp.stack([q[1] - q[0], q[2] - q[0]], axis=1) @ dinv
        su, sv = jnp.linalg.norm(W[:, 0]) - 1, jnp.linalg.norm(W[:, 1]) - 1
        return 0.5 * (15.0 * (su ** 2 + sv ** 2) + 5.0 * jnp.dot(W[:, 0], W[:, 1]) ** 2)
    jax_check(d, bw, [cur.reshape(COUNT, 9), inv])

    s3 = yasps.scene("abd")
    b = s3.addMesh("m").addPrimitive("b", numInstances=COUNT)
    A = b.addAttribute("A", rows=3, cols=3)
    AV = np.eye(3) + rng.normal(scale=0.2, size=(COUNT, 3, 3))
    A.updateValue(AV)
    orth = b.addAttribute("orth", computed_attribute=E.abd_orthogonality(A, 3.0))
    F = b.addAttribute("F", rows=3, cols=3)
    F.updateValue(AV + 0.1)
    snh = b.addAttribute("snh", computed_attribute=E.stable_neo_hookean(F, 1.0, 7.0, 2.0))
    s3.addEnergy(orth)
    s3.addEnergy(snh)
    s3.addMinimizeTarget([A, F])
    colmajor = np.transpose(AV, (0, 2, 1)).reshape(COUNT, 9)

    def orth_f(p):
        M = p.reshape(3, 3).T
        return 1.5 * jnp.sum((M.T @ M - jnp.eye(3)) ** 2)

    def snh_f(p):
        M = p.reshape(3, 3).T
        ic, J = jnp.sum(M * M), jnp.linalg.det(M)
        return 2.0 * (0.5 * (ic - 3) - 0.5 * jnp.log(ic + 1) + 3.5 * (J - 1 - 0.75 / 7.0) ** 2)
    jax_check(s3.energyDerivatives(orth), orth_f, [colmajor])
    jax_check(s3.energyDerivatives(snh), snh_f,
              [np.transpose(AV + 0.1, (0, 2, 1)).reshape(COUNT, 9)])


@pytest.mark.parametrize("kind", ["pp", "pe", "pt", "ee"])
def test_paper_barrier_against_jax(kind):
    arity = {"pp": 2, "pe": 3, "pt": 4, "ee": 4}[kind]
    pts = rng.normal(scale=0.3, size=(COUNT, arity, 3))
    s, e, x, c = elements(arity, pts)
    rows = [c.row(i).T for i in range(arity)]
    fn = {"pp": E.point_point_distance2, "pe": E.point_edge_distance2,
          "pt": E.point_triangle_distance2, "ee": E.edge_edge_distance2}[kind]
    dist = e.addAttribute("d2", computed_attribute=fn(*rows))
    dhat = float(dist.compute().value.max()) * 1.5
    d = derivatives(s, e, E.ipc_barrier(dist, dhat, 100.0))

    def distance(p):
        q = p.reshape(arity, 3)
        if kind == "pp":
            return jnp.sum((q[1] - q[0]) ** 2)
        if kind == "pe":
            u = q[2] - q[1]
            return jnp.sum(jnp.cross(u, q[0] - q[1]) ** 2) / jnp.sum(u * u)
        n = jnp.cross(q[2] - q[1], q[3] - q[1]) if kind == "pt" else \
            jnp.cross(q[1] - q[0], q[3] - q[2])
        r = (q[0] - q[1]) if kind == "pt" else (q[2] - q[0])
        return jnp.dot(r, n) ** 2 / jnp.sum(n * n)

    def barrier(p):
        dd = distance(p)
        return 100.0 * (dd - dhat) ** 2 * jnp.log(dd / dhat) ** 2
    jax_check(d, barrier, [pts.reshape(COUNT, -1)], rtol=1e-9)


def test_pendulum_against_jax():
    s = yasps.scene("pendulum")
    p = s.addMesh("m").addPrimitive("bob", numInstances=COUNT)
    theta = p.addAttribute("theta", rows=2, cols=1)
    TH = rng.uniform(-1, 1, size=(COUNT, 2))
    theta.updateValue(TH)
    a, b = theta[0], theta[1]
    pos = p.addAttribute("position", computed_attribute=yasps.vstack(
        [a.sin() + b.sin(), -(a.cos() + b.cos())]))
    energy = p.addAttribute("e", computed_attribute=9.81 * pos[1] + (pos - np.array([0.3, -1.0])).squaredNorm())
    s.addEnergy(energy)
    s.addMinimizeTarget([theta])

    def f(t):
        x = jnp.array([jnp.sin(t[0]) + jnp.sin(t[1]), -(jnp.cos(t[0]) + jnp.cos(t[1]))])
        return 9.81 * x[1] + jnp.sum((x - jnp.array([0.3, -1.0])) ** 2)
    jax_check(s.energyDerivatives(energy), f, [TH])


def _clamp(h, method):
    w, V = np.linalg.eigh(h)
    f = np.maximum(w, 0) if method == "clamp" else np.abs(w)
    return (V * f) @ V.T


@pytest.mark.parametrize("method", ["clamp", "abs"])
def test_projection_through_linear_maps_against_jax(method):
    """With ``linear_map_projection`` (the default) a tet's stable
    Neo-Hookean Hessian is projected in F's 9 entries and a spring's in its
    edge vector's 3: J^T P(d2E/du2) J with u = F or x1 - x0, J = du/dx,
    every factor from JAX. The tets are compressed, so d2E/dF2 is
    indefinite and the result differs from projecting the 12x12 Hessian."""
    base = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    rest = base[None] + rng.normal(scale=0.05, size=(COUNT, 4, 3))
    cur = 0.5 * rest + rng.normal(scale=0.05, size=rest.shape)
    dm_inv = np.linalg.inv(np.stack([rest[:, k] - rest[:, 0] for k in (1, 2, 3)], axis=2))
    mu, lam = 1.0, 20.0
    s, e, x, c = elements(4, cur)
    inv = e.addConstant("inv", rows=3, cols=3)
    inv.updateValue(dm_inv)
    s.addEnergy(e.addAttribute("energy", computed_attribute=E.stable_neo_hookean(
        E.deformation_gradient(c, inv), mu, lam, 1.0)), projection=method)
    s.addMinimizeTarget([x])
    d = s.energyDerivatives(s.m.e["energy"])

    def F_of(flat, dinv):
        p = flat.reshape(4, 3)
        return (jnp.stack([p[k] - p[0] for k in (1, 2, 3)], axis=1) @ dinv).reshape(-1)

    def psi(f):
        F = f.reshape(3, 3)
        ic = jnp.sum(F * F)
        alpha = 1 + 0.75 * mu / lam
        return 0.5 * mu * (ic - 3) - 0.5 * mu * jnp.log(ic + 1) \
            + 0.5 * lam * (jnp.linalg.det(F) - alpha) ** 2

    indefinite = 0
    for i in range(COUNT):
        flat, dinv = jnp.array(cur[i].reshape(-1)), jnp.array(dm_inv[i])
        J = np.array(jax.jacobian(F_of)(flat, dinv))
        HF = np.array(jax.hessian(psi)(F_of(flat, dinv)))
        indefinite += np.linalg.eigvalsh(HF).min() < 0
        want = J.T @ _clamp(HF, method) @ J
        assert_close(d.projectedHessian[i], want)
        full = _clamp(np.array(jax.hessian(lambda q: psi(F_of(q, dinv)))(flat)), method)
        if np.linalg.eigvalsh(HF).min() < 0:
            assert np.abs(full - want).max() > 1e-3 * np.abs(want).max()
    assert indefinite > 0, "the test needs indefinite Hessians in F"

    ends = rng.normal(size=(COUNT, 2, 3))
    s2, e2, x2, c2 = elements(2, ends)
    s2.addEnergy(e2.addAttribute("energy", computed_attribute=E.mass_spring(
        c2, 10.0, 5.0)), projection=method)
    s2.addMinimizeTarget([x2])
    d2 = s2.energyDerivatives(s2.m.e["energy"])
    spring = lambda u: 2.5 * (jnp.linalg.norm(u) - 10.0) ** 2  # noqa: E731
    for i in range(COUNT):
        u = jnp.array(ends[i, 1] - ends[i, 0])
        J = np.hstack([-np.eye(3), np.eye(3)])
        want = J.T @ _clamp(np.array(jax.hessian(spring)(u)), method) @ J
        assert_close(d2.projectedHessian[i], want)


def test_projection_in_the_leaves_without_linear_maps(monkeypatch):
    """``linear_map_projection = False`` projects a tet's full 12x12
    Hessian, as before: the clamp of JAX's Hessian in the positions."""
    monkeypatch.setattr(yasps.config, "linear_map_projection", False)
    base = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    rest = base[None] + rng.normal(scale=0.05, size=(COUNT, 4, 3))
    cur = 0.5 * rest + rng.normal(scale=0.05, size=rest.shape)
    dm_inv = np.linalg.inv(np.stack([rest[:, k] - rest[:, 0] for k in (1, 2, 3)], axis=2))
    s, e, x, c = elements(4, cur)
    inv = e.addConstant("inv", rows=3, cols=3)
    inv.updateValue(dm_inv)
    d = derivatives(s, e, E.stable_neo_hookean(E.deformation_gradient(c, inv), 1.0, 20.0, 1.0))
    for i in range(COUNT):
        assert_close(d.projectedHessian[i], _clamp(d.hessian[i], "clamp"))
