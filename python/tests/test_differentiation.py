"""Local gradients and Hessians from yasps-differentiate against central
finite differences, for the energies of yasps.energies."""

import numpy as np
import pytest

import yasps
from yasps import energies as E

rng = np.random.default_rng(7)
COUNT = 4  # independent instances per test


def elements_scene(arity, vertex_values):
    """COUNT disjoint elements of `arity` vertices each: no vertex is shared,
    so one perturbation per local parameter covers all instances at once."""
    s = yasps.scene("elements")
    m = s.addMesh("m")
    v = m.addPrimitive("v", numInstances=COUNT * arity)
    e = m.addPrimitive("e", numInstances=COUNT)
    x = v.addAttribute("x", rows=3, cols=1)
    x.updateValue(vertex_values.reshape(-1, 3))
    conn = e.addConnectivity("e2v", v, np.arange(COUNT * arity).reshape(COUNT, arity), arity)
    corners = e.addAttribute("corners", through=conn, source=x)
    return s, m, v, e, x, corners


def check_derivatives(scene, energy, rtol=1e-6):
    """Compares gradient and Hessian with central differences of the energy
    and of the gradient, perturbing every instance's k-th parameter at once."""
    d = scene.energyDerivatives(energy)
    n = d.gradient.shape[1]
    locations = [d.locations(i) for i in range(len(d.value))]
    targets = {id(l[0]): l[0] for loc in locations for l in loc if l is not None}
    base = {k: t.value.copy() for k, t in targets.items()}

    def evaluate(k, delta):
        for key, t in targets.items():
            values = base[key].copy()
            for loc, pad in zip(locations, padding):
                target, inst, entry = loc[k]
                if target is t and not pad[k]:
                    values[inst, entry % t.rows, entry // t.rows] += delta
            t.updateValue(values)
        r = scene.energyDerivatives(energy)
        for key, t in targets.items():
            t.updateValue(base[key])
        return r

    g_fd = np.zeros_like(d.gradient)
    h_fd = np.zeros_like(d.hessian)
    # UNION padding: no parameter behind it, derivatives exactly zero.
    padding = np.array([[loc[k] is None for k in range(n)] for loc in locations])
    assert (d.gradient[padding] == 0).all()
    assert (np.transpose(d.hessian, (0, 2, 1))[padding] == 0).all()
    locations = [[loc[k] if loc[k] is not None else loc[0] for k in range(n)]
                 for loc in locations]
    for k in range(n):
        scale = max(1.0, max(abs(base[id(loc[k][0])][loc[k][1]].reshape(-1, order="F")[loc[k][2]])
                             for loc in locations))
        h = 1e-6 * scale
        plus, minus = evaluate(k, h), evaluate(k, -h)
        g_fd[:, k] = (plus.value - minus.value) / (2 * h)
        h_fd[:, :, k] = (plus.gradient - minus.gradient) / (2 * h)
    g_fd[padding] = 0.0
    h_fd = np.where(padding[:, None, :] | padding[:, :, None], 0.0, h_fd)
    g_scale = np.abs(d.gradient).max() + 1e-300
    h_scale = np.abs(d.hessian).max() + 1e-300
    assert np.abs(d.gradient - g_fd).max() / g_scale < rtol, \
        f"gradient: {np.abs(d.gradient - g_fd).max() / g_scale:.2e}"
    assert np.abs(d.hessian - h_fd).max() / h_scale < rtol, \
        f"Hessian: {np.abs(d.hessian - h_fd).max() / h_scale:.2e}"
    np.testing.assert_allclose(d.hessian, np.transpose(d.hessian, (0, 2, 1)),
                               rtol=1e-12, atol=1e-12 * h_scale)
    return d


def regular_tets():
    base = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    rest = base[None] + rng.normal(scale=0.05, size=(COUNT, 4, 3))
    current = rest @ (np.eye(3) + rng.normal(scale=0.2, size=(COUNT, 3, 3))) \
        + rng.normal(size=(COUNT, 1, 3))
    return rest, current


def test_inertia_and_gravity_on_vertices():
    s = yasps.scene("vertices")
    v = s.addMesh("m").addPrimitive("v", numInstances=COUNT)
    x = v.addAttribute("x", rows=3, cols=1)
    x.updateValue(rng.normal(size=(COUNT, 3)))
    x_hat = v.addConstant("x_hat", rows=3)
    x_hat.updateValue(rng.normal(size=(COUNT, 3)))
    mass = v.addConstant("mass", rows=1)
    mass.updateValue(rng.uniform(1, 2, size=(COUNT, 1)))
    e = v.addAttribute("e", computed_attribute=E.inertia(x, x_hat, mass)
                       + E.gravity(x, mass, np.array([0.0, 0.0, -9.81])))
    s.addEnergy(e)
    s.addMinimizeTarget([x])
    d = check_derivatives(s, e)
    # Closed form: m (x - x_hat) - m g, Hessian m I.
    m = mass.value[:, 0, 0]
    want = m[:, None] * (x.value[:, :, 0] - x_hat.value[:, :, 0]) \
        - m[:, None] * np.array([0, 0, -9.81])
    np.testing.assert_allclose(d.gradient, want, rtol=1e-13)
    np.testing.assert_allclose(d.hessian, m[:, None, None] * np.eye(3), rtol=1e-14)


def test_mass_spring():
    ends = rng.normal(size=(COUNT, 2, 3))
    s, m, v, e, x, corners = elements_scene(2, ends)
    rest = e.addConstant("rest", rows=1)
    rest.updateValue(rng.uniform(0.5, 1.5, size=(COUNT, 1)))
    energy = e.addAttribute("spring", computed_attribute=E.mass_spring(corners, rest, 3.0))
    s.addEnergy(energy)
    s.addMinimizeTarget([x])
    d = check_derivatives(s, energy)
    # Closed form gradient on x1: k (|u| - l) u / |u|.
    u = ends[:, 1] - ends[:, 0]
    length = np.linalg.norm(u, axis=1)
    g1 = 3.0 * (length - rest.value[:, 0, 0])[:, None] * u / length[:, None]
    np.testing.assert_allclose(d.gradient[:, 3:], g1, rtol=1e-12)
    np.testing.assert_allclose(d.gradient[:, :3], -g1, rtol=1e-12)


def test_stable_neo_hookean_on_positions():
    rest, current = regular_tets()
    s, m, v, e, x, corners = elements_scene(4, current)
    dm = np.stack([rest[:, k] - rest[:, 0] for k in (1, 2, 3)], axis=2)
    dm_inv = e.addConstant("DmInv", rows=3, cols=3)
    dm_inv.updateValue(np.linalg.inv(dm))
    vol = e.addConstant("volume", rows=1)
    vol.updateValue(np.abs(np.linalg.det(dm))[:, None] / 6)
    F = E.deformation_gradient(corners, dm_inv)
    energy = e.addAttribute("snh", computed_attribute=E.stable_neo_hookean(F, 1.3, 4.1, vol))
    s.addEnergy(energy)
    s.addMinimizeTarget([x])
    d = check_derivatives(s, energy)
    assert d.gradient.shape == (COUNT, 12)


def test_stable_neo_hookean_on_deformation_gradient():
    s = yasps.scene("F")
    t = s.addMesh("m").addPrimitive("t", numInstances=COUNT)
    F = t.addAttribute("F", rows=3, cols=3)
    F.updateValue(np.eye(3) + rng.normal(scale=0.3, size=(COUNT, 3, 3)))
    energy = t.addAttribute("psi", computed_attribute=E.stable_neo_hookean(F, 1.0, 10.0, 1.0))
    s.addEnergy(energy)
    s.addMinimizeTarget([F])
    d = check_derivatives(s, energy)
    # dPsi/dF = mu F - mu F / (I_C + 1) + lam (J - alpha) cof(F), column-major.
    Fv = F.value
    ic = (Fv ** 2).sum(axis=(1, 2))
    J = np.linalg.det(Fv)
    cof = J[:, None, None] * np.transpose(np.linalg.inv(Fv), (0, 2, 1))
    alpha = 1 + 0.75 * 1.0 / 10.0
    P = Fv - Fv / (ic + 1)[:, None, None] + 10.0 * (J - alpha)[:, None, None] * cof
    np.testing.assert_allclose(d.gradient, np.transpose(P, (0, 2, 1)).reshape(COUNT, 9),
                               rtol=1e-12, atol=1e-12)


def test_baraff_witkin_cloth():
    rest = np.array([[0, 0], [1, 0], [0, 1]], float)[None] + \
        rng.normal(scale=0.05, size=(COUNT, 3, 2))
    current = np.concatenate([rest, np.zeros((COUNT, 3, 1))], axis=2) \
        @ (np.eye(3) + rng.normal(scale=0.2, size=(COUNT, 3, 3)))
    s, m, v, e, x, corners = elements_scene(3, current)
    duv = np.stack([rest[:, k] - rest[:, 0] for k in (1, 2)], axis=2)
    inv = e.addConstant("DuvInv", rows=2, cols=2)
    inv.updateValue(np.linalg.inv(duv))
    area = e.addConstant("area", rows=1)
    area.updateValue(np.abs(np.linalg.det(duv))[:, None] / 2)
    energy = e.addAttribute("bw", computed_attribute=E.baraff_witkin(corners, inv, area, 50.0, 20.0))
    s.addEnergy(energy)
    s.addMinimizeTarget([x])
    check_derivatives(s, energy)


def test_dihedral_bending():
    hinge = np.array([[0, 0, 0], [1, 0, 0], [0.3, 1, 0], [0.6, -1, 0.4]], float)[None] \
        + rng.normal(scale=0.05, size=(COUNT, 4, 3))
    s, m, v, e, x, corners = elements_scene(4, hinge)
    energy = e.addAttribute("bend", computed_attribute=E.dihedral_bending(corners, 1.0, 2.0))
    s.addEnergy(energy)
    s.addMinimizeTarget([x])
    check_derivatives(s, energy)


@pytest.mark.parametrize("kind", ["pp", "pe", "pt", "ee"])
def test_ipc_barriers(kind):
    arity = {"pp": 2, "pe": 3, "pt": 4, "ee": 4}[kind]
    pts = rng.normal(scale=0.1, size=(COUNT, arity, 3))
    # Close configurations: d well inside (0, dhat).
    pts[:, 1:] *= 3.0
    if kind == "pp":
        pts[:, 1] = pts[:, 0] + rng.normal(scale=0.02, size=(COUNT, 3))
    s, m, v, e, x, c = elements_scene(arity, pts)
    rows = [c.row(i).T for i in range(arity)]
    d = {"pp": lambda: E.point_point_distance2(rows[0], rows[1]),
         "pe": lambda: E.point_edge_distance2(*rows),
         "pt": lambda: E.point_triangle_distance2(*rows),
         "ee": lambda: E.edge_edge_distance2(*rows)}[kind]()
    dist = e.addAttribute("d2", computed_attribute=d)
    values = dist.compute().value[:, 0, 0]
    dhat = float(values.max()) * 2.0
    energy = e.addAttribute("barrier", computed_attribute=E.ipc_barrier(dist, dhat, 1e3))
    s.addEnergy(energy)
    s.addMinimizeTarget([x])
    check_derivatives(s, energy, rtol=1e-5)


def test_abd_orthogonality():
    s = yasps.scene("abd")
    b = s.addMesh("m").addPrimitive("body", numInstances=COUNT)
    A = b.addAttribute("A", rows=3, cols=3)
    A.updateValue(np.eye(3) + rng.normal(scale=0.2, size=(COUNT, 3, 3)))
    energy = b.addAttribute("orth", computed_attribute=E.abd_orthogonality(A, 5.0))
    s.addEnergy(energy)
    s.addMinimizeTarget([A])
    d = check_derivatives(s, energy)
    # Gradient 2k A (A^T A - I), column-major.
    Av = A.value
    G = 2 * 5.0 * Av @ (np.transpose(Av, (0, 2, 1)) @ Av - np.eye(3))
    np.testing.assert_allclose(d.gradient, np.transpose(G, (0, 2, 1)).reshape(COUNT, 9),
                               rtol=1e-12, atol=1e-12)


def test_pendulum_angle_parameterisation():
    # Positions are nonlinear in the angles, so the second-order chain rule's
    # curvature term matters.
    s = yasps.scene("pendulum")
    p = s.addMesh("m").addPrimitive("bob", numInstances=COUNT)
    theta = p.addAttribute("theta", rows=2, cols=1)
    theta.updateValue(rng.uniform(-1, 1, size=(COUNT, 2)))
    a, b = theta[0], theta[1]
    x = yasps.vstack([a.sin() + b.sin(), -(a.cos() + b.cos())])
    p.addAttribute("position", computed_attribute=x)
    target = np.array([0.5, -1.0])
    energy = p.addAttribute("e", computed_attribute=(p["position"] - target).squaredNorm()
                            + 9.81 * p["position"][1])
    s.addEnergy(energy)
    s.addMinimizeTarget([theta])
    check_derivatives(s, energy)


def test_barrier_over_union_of_free_and_affine_vertices():
    """The paper's mixed parameterisation: one compiled kernel gives the
    Hessians of soft-soft, soft-affine, affine-soft and affine-affine pairs
    (6, 15, 15 and 24 parameters; UNION slots padded to 12)."""
    s = yasps.scene("mixed")
    soft = s.addMesh("soft").addPrimitive("v", numInstances=4)
    xs = soft.addAttribute("x", rows=3, cols=1)
    xs.updateValue(rng.normal(scale=0.05, size=(4, 3)))
    rigid = s.addMesh("rigid")
    bodies = rigid.addPrimitive("body", numInstances=4)
    A = bodies.addAttribute("A", rows=3, cols=3)
    A.updateValue(np.eye(3) + rng.normal(scale=0.1, size=(4, 3, 3)))
    t = bodies.addAttribute("t", rows=3, cols=1)
    t.updateValue(rng.normal(scale=0.05, size=(4, 3)))
    verts = rigid.addPrimitive("v", numInstances=4)
    rest = verts.addConstant("rest", rows=3)
    rest.updateValue(rng.normal(scale=0.05, size=(4, 3)))
    v2b = verts.addConnectivity("v2b", bodies, np.arange(4), 1)
    jA = verts.addAttribute("A", through=v2b, source=A)
    jt = verts.addAttribute("t", through=v2b, source=t)
    verts.addAttribute("x", computed_attribute=jA.resize(3, 3) * rest + jt.resize(3, 1))
    world = s.addMesh("world")
    u = world.addPrimitiveUnion("v", [soft, verts])
    u.addAttribute("x")
    pp = world.addPrimitive("pp", numInstances=4, isDynamic=True)
    pairs = [[u.indexOf(soft, 0), u.indexOf(soft, 1)],
             [u.indexOf(soft, 2), u.indexOf(verts, 0)],
             [u.indexOf(verts, 1), u.indexOf(soft, 3)],
             [u.indexOf(verts, 2), u.indexOf(verts, 3)]]
    p2v = pp.addConnectivity("p2v", u, pairs, 2)
    x = pp.addAttribute("x", through=p2v, source=u["x"])
    d2 = E.point_point_distance2(x.row(0), x.row(1))
    dist = pp.addAttribute("d2", computed_attribute=d2)
    dhat = float(dist.compute().value.max()) * 2.0
    energy = pp.addAttribute("barrier", computed_attribute=E.ipc_barrier(dist, dhat, 1e3))
    s.addEnergy(energy, dynamic_instances=True)
    s.addMinimizeTarget([xs, A, t])
    d = check_derivatives(s, energy, rtol=1e-5)
    assert d.gradient.shape == (4, 24)
    real = [sum(l is not None for l in d.locations(i)) for i in range(4)]
    assert real == [6, 15, 15, 24]


@pytest.mark.parametrize("method", ["clamp", "abs", "none"])
def test_projected_hessians(method, monkeypatch):
    # Stable Neo-Hookean under compression has indefinite local Hessians.
    # Projected in the positions, not through F (test_references checks
    # the projection through linear maps against JAX).
    monkeypatch.setattr(yasps.config, "linear_map_projection", False)
    rest, current = regular_tets()
    current = rest * 0.5 + rng.normal(scale=0.05, size=rest.shape)
    s, m, v, e, x, corners = elements_scene(4, current)
    dm = np.stack([rest[:, k] - rest[:, 0] for k in (1, 2, 3)], axis=2)
    dm_inv = e.addConstant("DmInv", rows=3, cols=3)
    dm_inv.updateValue(np.linalg.inv(dm))
    F = E.deformation_gradient(corners, dm_inv)
    energy = e.addAttribute("snh", computed_attribute=E.stable_neo_hookean(F, 1.0, 20.0, 1.0))
    s.addEnergy(energy, projection=method)
    s.addMinimizeTarget([x])
    d = s.energyDerivatives(energy)
    w, V = np.linalg.eigh(d.hessian)
    assert (w.min(axis=1) < 0).any(), "the test needs indefinite Hessians"
    f = {"clamp": np.maximum(w, 0), "abs": np.abs(w), "none": w}[method]
    want = np.einsum("nij,nj,nkj->nik", V, f, V)
    scale = np.abs(d.hessian).max()
    assert np.abs(d.projectedHessian - want).max() / scale < 1e-12
    if method != "none":
        assert np.linalg.eigvalsh(d.projectedHessian).min() >= -1e-10 * scale
    if method != "clamp":
        assert f"projection {method}" in s.ir() or method == "clamp"


def test_reduced_space_projection_of_mixed_barrier():
    """Over free and affine vertices the barrier's Hessian is J^T H_inner J
    with a 6x6 H_inner: its reduced projection is PSD, of rank <= 6, and
    differs from the Hessian by J^T (positive part) J >= 0."""
    s = yasps.scene("mixed")
    soft = s.addMesh("soft").addPrimitive("v", numInstances=2)
    xs = soft.addAttribute("x", rows=3, cols=1)
    xs.updateValue(rng.normal(scale=0.05, size=(2, 3)))
    rigid = s.addMesh("rigid")
    bodies = rigid.addPrimitive("body", numInstances=2)
    A = bodies.addAttribute("A", rows=3, cols=3)
    A.updateValue(np.eye(3) + rng.normal(scale=0.1, size=(2, 3, 3)))
    t = bodies.addAttribute("t", rows=3, cols=1)
    t.updateValue(rng.normal(scale=0.05, size=(2, 3)))
    verts = rigid.addPrimitive("v", numInstances=2)
    verts.addConstant("rest", rows=3).updateValue(rng.normal(scale=0.05, size=(2, 3)))
    v2b = verts.addConnectivity("v2b", bodies, np.arange(2), 1)
    jA = verts.addAttribute("A", through=v2b, source=A)
    jt = verts.addAttribute("t", through=v2b, source=t)
    verts.addAttribute("x", computed_attribute=jA.resize(3, 3) * verts["rest"] + jt.resize(3, 1))
    u = s.addMesh("world").addPrimitiveUnion("v", [soft, verts])
    u.addAttribute("x")
    pp = s.world.addPrimitive("pp", numInstances=2, isDynamic=True)
    p2v = pp.addConnectivity("p2v", u, [[u.indexOf(soft, 0), u.indexOf(verts, 0)],
                                        [u.indexOf(verts, 1), u.indexOf(soft, 1)]], 2)
    x = pp.addAttribute("x", through=p2v, source=u["x"])
    d2 = pp.addAttribute("d2", computed_attribute=E.point_point_distance2(x.row(0), x.row(1)))
    dhat = float(d2.compute().value.max()) * 1.5
    energy = pp.addAttribute("b", computed_attribute=E.ipc_barrier(d2, dhat, 1e3))
    s.addEnergy(energy, dynamic_instances=True)
    s.addMinimizeTarget([xs, A, t])
    d = s.energyDerivatives(energy)
    R, H = d.projectedHessian, d.hessian
    scale = np.abs(H).max()
    for i in range(2):
        assert np.linalg.eigvalsh(R[i]).min() >= -1e-9 * scale
        assert np.linalg.eigvalsh(R[i] - H[i]).min() >= -1e-9 * scale
        assert np.linalg.matrix_rank(R[i], tol=1e-9 * scale) <= 6


def test_simd_lanes_give_the_results_of_scalar_kernels(monkeypatch):
    """CPU kernels evaluate several instances per vector instruction (their
    leaves staged per instance, the arithmetic and the projection in lanes,
    full tiles stored through in-register transposes): on a barrier over a
    UNION of free and affine vertices (gathers, union decoding, reduced-space
    projection) and on stable Neo-Hookean (full projection), every output
    equals that of the scalar kernels, for full and partial tiles and for a
    lane count that is not a power of two."""
    count = 37  # four tiles of 8 and a partial one
    s = yasps.scene("lanes")
    soft = s.addMesh("soft").addPrimitive("v", numInstances=count)
    xs = soft.addAttribute("x", rows=3, cols=1)
    xs.updateValue(rng.normal(scale=0.05, size=(count, 3)))
    rigid = s.addMesh("rigid")
    bodies = rigid.addPrimitive("body", numInstances=count)
    A = bodies.addAttribute("A", rows=3, cols=3)
    A.updateValue(np.eye(3) + rng.normal(scale=0.1, size=(count, 3, 3)))
    t = bodies.addAttribute("t", rows=3, cols=1)
    t.updateValue(rng.normal(scale=0.05, size=(count, 3)))
    verts = rigid.addPrimitive("v", numInstances=count)
    verts.addConstant("rest", rows=3).updateValue(
        rng.normal(scale=0.05, size=(count, 3)))
    v2b = verts.addConnectivity("v2b", bodies, np.arange(count), 1)
    jA = verts.addAttribute("A", through=v2b, source=A)
    jt = verts.addAttribute("t", through=v2b, source=t)
    verts.addAttribute("x", computed_attribute=jA.resize(3, 3) * verts["rest"]
                       + jt.resize(3, 1))
    u = s.addMesh("world").addPrimitiveUnion("v", [soft, verts])
    u.addAttribute("x")
    pp = s.world.addPrimitive("pp", numInstances=count, isDynamic=True)
    ends = rng.integers(0, 2 * count, size=(count, 2))
    ends[:, 1] = (ends[:, 0] + 1 + ends[:, 1] % (2 * count - 1)) % (2 * count)
    p2v = pp.addConnectivity("p2v", u, ends, 2)
    x = pp.addAttribute("x", through=p2v, source=u["x"])
    d2 = E.point_point_distance2(x.row(0), x.row(1))
    dhat = float(pp.addAttribute("d2", computed_attribute=d2).compute().value.max()) * 2
    barrier = pp.addAttribute("barrier", computed_attribute=E.ipc_barrier(d2, dhat, 1e3))
    s.addEnergy(barrier, dynamic_instances=True)
    s.addMinimizeTarget([xs, A, t])

    rest = np.concatenate([regular_tets()[0]] * 5)  # 20 tets
    current = rest * 0.6 + rng.normal(scale=0.05, size=rest.shape)
    s2 = yasps.scene("tets")
    m = s2.addMesh("m")
    v = m.addPrimitive("v", numInstances=4 * len(rest))
    e = m.addPrimitive("e", numInstances=len(rest))
    x2 = v.addAttribute("x", rows=3, cols=1)
    x2.updateValue(current.reshape(-1, 3))
    corners = e.addAttribute("corners", source=x2, through=e.addConnectivity(
        "e2v", v, np.arange(4 * len(rest)).reshape(-1, 4), 4))
    dm = np.stack([rest[:, k] - rest[:, 0] for k in (1, 2, 3)], axis=2)
    dm_inv = e.addConstant("DmInv", rows=3, cols=3)
    dm_inv.updateValue(np.linalg.inv(dm))
    snh = e.addAttribute("snh", computed_attribute=E.stable_neo_hookean(
        E.deformation_gradient(corners, dm_inv), 1.0, 20.0, 1.0))
    s2.addEnergy(snh)
    s2.addMinimizeTarget([x2])

    for scene, energy in [(s, barrier), (s2, snh)]:
        results = {}
        for lanes in (1, 0, 3):
            monkeypatch.setattr(yasps.config, "simd_lanes", lanes)
            d = scene.energyDerivatives(energy, threads=1)
            results[lanes] = (d.value, d.gradient, d.hessian,
                              d.projectedHessian, d.dofs())
        for lanes in (0, 3):
            for want, got in zip(results[1], results[lanes]):
                scale = max(np.abs(want).max(), 1.0)
                np.testing.assert_allclose(got, want, rtol=0,
                                           atol=1e-12 * scale)
