"""The global Newton system: assembly against dense references built from
the per-instance derivatives, and the PCG solution against numpy.linalg."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import yasps
from yasps import energies as E
from yasps.runtime import cpu_backend
from yasps.compiler.cpu import kernels_compiled
from yasps.solve import DofLayout, NoDerivativesError
from yasps.solve import assemble as assemble_on


def assemble(s, **kw):
    """The system assembled on the CPU (whose dense() the checks read) and
    its layout."""
    assembly = assemble_on(s, cpu_backend(), **kw)
    return assembly.system, assembly.layout

from conftest import box_mesh

rng = np.random.default_rng(5)


def dense_reference(scene):
    """Gradient and projected Hessian assembled with NumPy from
    energyDerivatives and the parameter locations."""
    targets = scene.minimizeTargets
    base, size = {}, 0
    for t in targets:
        base[id(t)] = size
        size += t.owner.numInstances * t.rows * t.cols
    g = np.zeros(size)
    H = np.zeros((size, size))
    for energy in scene.energies:
        d = scene.energyDerivatives(energy)
        for i in range(len(d.value)):
            dofs = [None if loc is None else
                    base[id(loc[0])] + loc[1] * loc[0].rows * loc[0].cols + loc[2]
                    for loc in d.locations(i)]
            for a, da in enumerate(dofs):
                if da is None:
                    continue
                g[da] += d.gradient[i, a]
                for b, db in enumerate(dofs):
                    if db is not None:
                        H[da, db] += d.projectedHessian[i, a, b]
    return g, H


def system_arrays(system):
    """The assembled gradient and dense Hessian of a runtime system."""
    g = np.zeros(system.size)
    system.gradient(g)
    H = np.zeros(system.size * system.size)
    system.dense(H)
    return g, H.reshape(system.size, system.size)


def soft_box():
    verts, tets = box_mesh(2)
    s = yasps.scene("soft")
    m = s.addMesh("m")
    v = m.addPrimitive("v", numInstances=len(verts))
    t = m.addPrimitive("t", numInstances=len(tets))
    x = v.addAttribute("x", rows=3)
    x.updateValue(verts * 0.9 + rng.normal(scale=0.02, size=verts.shape))
    xh = v.addConstant("x_hat", rows=3)
    xh.updateValue(verts)
    dm = np.stack([verts[tets][:, k] - verts[tets][:, 0] for k in (1, 2, 3)], axis=2)
    inv = t.addConstant("inv", rows=3, cols=3)
    inv.updateValue(np.linalg.inv(dm))
    vol = t.addConstant("vol", rows=1)
    vol.updateValue(np.abs(np.linalg.det(dm))[:, None] / 6)
    t2v = t.addConnectivity("t2v", v, tets, 4)
    c = t.addAttribute("c", through=t2v, source=x)
    s.addEnergy(v.addAttribute("inertia", computed_attribute=E.inertia(x, xh, 1.0)))
    s.addEnergy(t.addAttribute("snh", computed_attribute=E.stable_neo_hookean(
        E.deformation_gradient(c, inv), 10.0, 100.0, vol)))
    s.addMinimizeTarget([x])
    return s


def test_assembly_and_solve_on_a_soft_box():
    s = soft_box()
    system, layout = assemble(s)
    g_ref, H_ref = dense_reference(s)
    g, H = system_arrays(system)
    np.testing.assert_allclose(g, g_ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(H, H_ref, rtol=1e-12, atol=1e-10 * np.abs(H_ref).max())
    (dx,) = s.minimizeEnergy(tolerance=1e-12)
    want = np.linalg.solve(H_ref, g_ref)
    np.testing.assert_allclose(dx.reshape(-1), want, rtol=1e-8,
                               atol=1e-8 * np.abs(want).max())
    assert s.lastSolve["converged"] and s.lastSolve["iterations"] > 0
    assert set(s.lastSolve["seconds"]) == {"derivatives", "indices", "assembly", "solve"}


def mixed_scene(pairs):
    """Soft vertices, affine bodies and dynamic pairs through a UNION, with
    points well apart so that the system is well conditioned."""
    rng = np.random.default_rng(1)
    s = yasps.scene("mixed")
    soft = s.addMesh("soft").addPrimitive("v", numInstances=3)
    xs = soft.addAttribute("x", rows=3)
    xs.updateValue(np.array([[0.0, 0, 0], [0.3, 0, 0], [0, 0.3, 0]])
                   + rng.normal(scale=0.01, size=(3, 3)))
    xh = soft.addConstant("x_hat", rows=3)
    xh.updateValue(xs.value[:, :, 0])
    rigid = s.addMesh("rigid")
    body = rigid.addPrimitive("body", numInstances=1)
    A = body.addAttribute("A", rows=3, cols=3)
    A.updateValue(np.eye(3) + rng.normal(scale=0.05, size=(3, 3)))
    t = body.addAttribute("t", rows=3)
    t.updateValue([0.02, 0.0, 0.0])
    verts = rigid.addPrimitive("v", numInstances=2)
    verts.addConstant("rest", rows=3).updateValue(
        np.array([[0, 0, 0.3], [0.3, 0.3, 0.3]]) + rng.normal(scale=0.01, size=(2, 3)))
    v2b = verts.addConnectivity("v2b", body, [0, 0], 1)
    jA = verts.addAttribute("A", through=v2b, source=A)
    jt = verts.addAttribute("t", through=v2b, source=t)
    verts.addAttribute("x", computed_attribute=jA.resize(3, 3) * verts["rest"] + jt.resize(3, 1))
    u = s.addMesh("world").addPrimitiveUnion("v", [soft, verts])
    u.addAttribute("x")
    pp = s.world.addPrimitive("pp", numInstances=len(pairs), isDynamic=True)
    p2v = pp.addConnectivity("p2v", u, pairs, 2)
    x = pp.addAttribute("x", through=p2v, source=u["x"])
    d2 = pp.addAttribute("d2", computed_attribute=E.point_point_distance2(x.row(0), x.row(1)))
    s.addEnergy(soft.addAttribute("inertia", computed_attribute=E.inertia(xs, xh, 1.0)))
    # Orthogonality alone leaves rotations free; an inertia-like term on the
    # body keeps the system well conditioned.
    s.addEnergy(body.addAttribute("orth", computed_attribute=E.abd_orthogonality(A, 10.0)
                                  + 0.5 * (A - np.eye(3)).squaredNorm()
                                  + 0.5 * t.squaredNorm()))
    s.addEnergy(pp.addAttribute("b", computed_attribute=E.ipc_barrier(d2, 1.0, 1.0)),
                dynamic_instances=True)
    s.addMinimizeTarget([xs, A, t])
    return s, pp, p2v, u, soft, verts


def test_mixed_soft_affine_system_and_changing_pairs():
    s, pp, p2v, u, soft, verts = mixed_scene([[0, 3], [1, 4]])
    rebuilt = []
    for pairs in ([[0, 3], [1, 4]], [[2, 4]], [[0, 1], [2, 3], [1, 4]], [],
                  "static change", [[0, 4]]):
        if pairs == "static change":
            # A static connectivity changes: the static part is rebuilt.
            verts.connectivities["v2b"].updateConnectivity([0, 0])
            pairs = [[1, 3]]
        pp.updateNumInstances(len(pairs))
        p2v.updateConnectivity(np.array(pairs, dtype=np.int64).reshape(-1, 2))
        assembly = assemble_on(s, cpu_backend())
        system, layout = assembly.system, assembly.layout
        rebuilt.append(assembly.static_structure_rebuilt)
        g_ref, H_ref = dense_reference(s)
        _, H = system_arrays(system)
        np.testing.assert_allclose(H, H_ref, rtol=1e-11,
                                   atol=1e-11 * np.abs(H_ref).max())
        dxs, dA, dt = s.minimizeEnergy(tolerance=1e-12)
        assert dxs.shape == (3, 3, 1) and dA.shape == (1, 3, 3) and dt.shape == (1, 3, 1)
        flat = np.concatenate([dxs.reshape(-1), np.transpose(dA, (0, 2, 1)).reshape(-1),
                               dt.reshape(-1)])
        want = np.linalg.solve(H_ref, g_ref)
        np.testing.assert_allclose(flat, want, rtol=1e-7, atol=1e-7 * np.abs(want).max())
        assert s.lastSolve["staticStructureRebuilt"] is False
    # Only the first assembly and the static change build the static part;
    # the changing pairs re-index the dynamic part alone.
    assert rebuilt == [True, False, False, False, True, False]


def test_non_convergence_is_reported():
    s = soft_box()
    with pytest.raises(yasps.SolverError,
                       match="iteration limit, after 1 iterations") as err:
        s.minimizeEnergy(tolerance=1e-14, maxIterations=1)
    assert not err.value.info["converged"]
    assert err.value.info["stop"] == "max_iterations"
    assert err.value.solution[0].shape == s.m.v["x"].value.shape


@pytest.mark.usefixtures("one_preconditioner")
def test_factored_and_dense_reduced_hessians_agree(monkeypatch):
    """The barrier over free and affine-body vertices: by default (the cost
    rule, 2 m (n + m) <= n^2 with n = 24, m = 6) it keeps J (6x24),
    P(H_inner) and H_inner (6x6) apart and the runtime forms J^T P J while
    assembling; forced dense, the kernels form the products. Gradients,
    Hessians, projected Hessians and Newton directions agree."""
    pairs = [[0, 3], [1, 4], [2, 3]]
    s, pp, *_ = mixed_scene(pairs)
    barrier = s.energies[-1]
    monkeypatch.setattr(yasps.config, "separate_reduced_hessians", False)
    formed = s.energyDerivatives(barrier)
    assert formed.innerMap is None
    want = s.minimizeEnergy(tolerance=1e-14)
    monkeypatch.setattr(yasps.config, "separate_reduced_hessians", None)
    factors = s.energyDerivatives(barrier)
    assert factors.innerMap.shape == (3, 6, 24)
    assert factors.projectedInnerHessian.shape == (3, 6, 6)
    for name in ("gradient", "hessian", "projectedHessian"):
        a, b = getattr(factors, name), getattr(formed, name)
        np.testing.assert_allclose(a, b, rtol=0,
                                   atol=1e-12 * np.abs(b).max(), err_msg=name)
    got = s.minimizeEnergy(tolerance=1e-14)
    # Each direction meets its residual tolerance 1e-14, which bounds their
    # relative difference by about 2 cond(H) 1e-14 (cond ~ 640 here).
    bound = 2e-14 * s.lastSolve["conditionEstimate"]
    for a, b in zip(got, want):
        np.testing.assert_allclose(a, b, rtol=0, atol=bound * np.abs(b).max())


def test_generated_placement_indices_match_the_parameter_locations():
    """@E__dofs kernels (yasps-generate-indices) give every local parameter
    its global DoF, -1 for UNION padding, as ParamSlot.locations says."""
    s, pp, *_ = mixed_scene([[0, 3], [1, 4], [2, 3], [4, 1]])
    layout = DofLayout(s.minimizeTargets)
    padded = 0
    for energy in s.energies:
        d = s.energyDerivatives(energy)
        dofs = d.dofs()
        assert dofs.dtype == np.int64 and dofs.shape == d.gradient.shape
        for i in range(dofs.shape[0]):
            want = [-1 if loc is None else
                    layout.offset[id(loc[0])] + loc[1] * loc[0].rows * loc[0].cols
                    + loc[2] for loc in d.locations(i)]
            np.testing.assert_array_equal(dofs[i], want)
            padded += want.count(-1)
    # Free vertices in 12-wide UNION slots leave 9 padded entries each.
    assert padded > 0


def pendulum_pairs_scene():
    """Pairs over a UNION of pendulum bobs (2 angles, nonlinear: full
    projection; padded to 3) and free points (3 coordinates), including a
    bob paired with itself (repeated DoFs)."""
    rng = np.random.default_rng(0)
    s = yasps.scene("compressed")
    m = s.addMesh("m")
    bob = m.addPrimitive("bob", numInstances=3)
    th = bob.addAttribute("theta", rows=2)
    th.updateValue(rng.uniform(-1, 1, (3, 2)))
    a, b = th[0], th[1]
    bob.addAttribute("pos", computed_attribute=yasps.vstack(
        [a.sin() + b.sin(), -(a.cos() + b.cos())]))
    pts = m.addPrimitive("pts", numInstances=2)
    x = pts.addAttribute("x", rows=3)
    x.updateValue(rng.normal(size=(2, 3)))
    pts.addAttribute("pos", computed_attribute=yasps.vstack([x[0], x[1]]))
    u = m.addPrimitiveUnion("all", [bob, pts])
    u.addAttribute("pos")
    pairs = m.addPrimitive("pairs", numInstances=4)
    c = pairs.addConnectivity("p2a", u, [[0, 0], [0, 3], [1, 2], [3, 4]], 2)
    g = pairs.addAttribute("g", through=c, source=u["pos"])
    d = g.row(0) - g.row(1)
    s.addEnergy(pairs.addAttribute("e", computed_attribute=(d.dot(d) - 0.3) ** 2
                                   + 0.1 * g.row(0)[1] * g.row(0)[0]))
    s.addEnergy(bob.addAttribute("reg", computed_attribute=0.5 * th.squaredNorm()))
    s.addEnergy(pts.addAttribute("reg", computed_attribute=0.5 * x.squaredNorm()))
    s.addMinimizeTarget([th, x])
    return s


def compressed_reference(s):
    """The global Hessian with every local Hessian merged by DoF, padding
    dropped, then clamp-projected (paper 7.2), with NumPy."""
    size = DofLayout(s.minimizeTargets).size
    ref = np.zeros((size, size))
    for energy in s.energies:
        d = s.energyDerivatives(energy)
        dofs = d.dofs()
        for i in range(dofs.shape[0]):
            unique = [v for v in dict.fromkeys(dofs[i].tolist()) if v >= 0]
            S = np.zeros((dofs.shape[1], len(unique)))
            for a, v in enumerate(dofs[i]):
                if v >= 0:
                    S[a, unique.index(v)] = 1
            w, V = np.linalg.eigh(S.T @ d.hessian[i] @ S)
            ref[np.ix_(unique, unique)] += V @ np.diag(np.maximum(w, 0)) @ V.T
    return ref


def test_local_compression_before_projection():
    s = pendulum_pairs_scene()
    pairs = s.energies[0]
    from yasps.solve.compression import _projectors, compressed_sizes
    sizes = compressed_sizes(s.energyDerivatives(pairs).dofs())
    # Self pair: 2 angles; bob-point 5; bob-bob 4; point-point 6 (of 6).
    np.testing.assert_array_equal(sizes, [2, 5, 4, 6])
    _, H = system_arrays(assemble(s)[0])
    ref = compressed_reference(s)
    np.testing.assert_allclose(H, ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    # One projection kernel per compressed size met (6 x 6 is the fused
    # kernel's size but is met too, in the same energy).
    assert {(k, "clamp", "f64") for k in (2, 4, 5, 6)} <= set(_projectors)
    # Without compression, the self pair is projected before its repeated
    # DoFs are merged: a different (still PSD) matrix.
    yasps.config.compress_local_hessians = False
    try:
        system, _ = assemble(s)
    finally:
        yasps.config.compress_local_hessians = True
    _, H2 = system_arrays(system)
    assert np.abs(H2 - ref).max() > 1e-6 * np.abs(ref).max()


def test_fixed_dofs_are_excluded_from_the_solve():
    s = soft_box()
    x = s.minimizeTargets[0]
    n = x.owner.numInstances
    fixed = np.zeros((n, 3, 1), dtype=bool)
    fixed[0] = True          # a whole vertex
    fixed[2, 1, 0] = True    # one coordinate of another
    (dx,) = s.minimizeEnergy(tolerance=1e-12, fixed=[fixed])
    assert (dx[fixed] == 0).all()
    g, H = dense_reference(s)
    free = ~fixed.reshape(-1)
    want = np.linalg.solve(H[np.ix_(free, free)], g[free])
    np.testing.assert_allclose(dx.reshape(-1)[free], want, rtol=1e-8,
                               atol=1e-10 * np.abs(want).max())
    # A mask of instances fixes all their entries.
    (dx,) = s.minimizeEnergy(tolerance=1e-12, fixed=[np.arange(n) < 2])
    assert (dx[:2] == 0).all() and np.abs(dx[2:]).max() > 0
    with pytest.raises(ValueError, match="fixed mask of .* has shape"):
        s.minimizeEnergy(fixed=[np.zeros(3, dtype=bool)])


def cloth_patch(n: int = 3):
    """An n x n grid of vertices: Baraff-Witkin triangles, dihedral hinges
    across the interior edges, inertia; slightly crumpled."""
    u, v = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    rest = np.stack([u.ravel(), v.ravel(), np.zeros(n * n)], axis=1) * 0.1
    idx = lambda i, j: i * n + j  # noqa: E731
    tris, hinges = [], []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = idx(i, j), idx(i + 1, j), idx(i, j + 1), idx(i + 1, j + 1)
            tris += [[a, b, d], [a, d, c]]
            hinges.append([a, d, b, c])              # the cell's diagonal
            if i + 1 < n - 1:
                hinges.append([b, d, a, idx(i + 2, j + 1)])
    tris, hinges = np.array(tris), np.array(hinges)
    s = yasps.scene("cloth")
    m = s.addMesh("cloth")
    vv = m.addPrimitive("v", numInstances=n * n)
    x = vv.addAttribute("x", rows=3)
    x.updateValue(rest + rng.normal(scale=0.01, size=rest.shape))
    xh = vv.addConstant("x_hat", rows=3)
    xh.updateValue(rest)
    t = m.addPrimitive("t", numInstances=len(tris))
    duv = np.stack([rest[tris][:, k, :2] - rest[tris][:, 0, :2] for k in (1, 2)], axis=2)
    t.addConstant("inv", rows=2, cols=2).updateValue(np.linalg.inv(duv))
    corners = t.addAttribute("c", through=t.addConnectivity("t2v", vv, tris, 3), source=x)
    s.addEnergy(t.addAttribute("bw", computed_attribute=E.baraff_witkin(
        corners, t["inv"], 0.005, 100.0, 10.0)))
    h = m.addPrimitive("h", numInstances=len(hinges))
    hx = h.addAttribute("c", through=h.addConnectivity("h2v", vv, hinges, 4), source=x)
    s.addEnergy(h.addAttribute("bend", computed_attribute=E.dihedral_bending(hx, 0.1, 0.01)))
    s.addEnergy(vv.addAttribute("inertia", computed_attribute=E.inertia(x, xh, 0.01)))
    s.addMinimizeTarget([x])
    return s


def test_assembly_and_solve_on_a_cloth_patch():
    s = cloth_patch()
    system, _ = assemble(s)
    g_ref, H_ref = dense_reference(s)
    g, H = system_arrays(system)
    np.testing.assert_allclose(g, g_ref, rtol=1e-12, atol=1e-12 * np.abs(g_ref).max())
    np.testing.assert_allclose(H, H_ref, rtol=1e-11,
                               atol=1e-11 * np.abs(H_ref).max())
    (dx,) = s.minimizeEnergy(tolerance=1e-12)
    want = np.linalg.solve(H_ref, g_ref)
    np.testing.assert_allclose(dx.reshape(-1), want, rtol=1e-8,
                               atol=1e-8 * np.abs(want).max())


def test_an_energy_without_targets_has_no_derivatives_and_is_left_out():
    """The compiler makes no derivative kernels for an energy that reads no
    minimisation target: its derivatives raise NoDerivativesError (a
    SceneError), and the Newton system is that of the other energies."""
    positions = rng.standard_normal((3, 3))

    def build(with_constant_energy: bool):
        s = yasps.scene("s")
        p = s.addMesh("m").addPrimitive("p", numInstances=3)
        x = p.addAttribute("x", rows=3)
        x.updateValue(positions)
        c = p.addConstant("c", rows=3)
        c.updateValue(np.ones((3, 3)))
        s.addEnergy(p.addAttribute("e", computed_attribute=(x - c).squaredNorm()))
        if with_constant_energy:
            s.addEnergy(p.addAttribute("k", computed_attribute=c.squaredNorm()))
        s.addMinimizeTarget(x)
        return s

    s = build(True)
    with pytest.raises(NoDerivativesError, match="depends on no minimisation"):
        s.energyDerivatives(s.m.p["k"])
    assert issubclass(NoDerivativesError, yasps.SceneError)
    (dx,) = s.minimizeEnergy(tolerance=1e-12)
    (reference,) = build(False).minimizeEnergy(tolerance=1e-12)
    x = s.m.p["x"].value
    assert np.allclose(dx, reference) and np.allclose(dx, x - 1.0)


@pytest.mark.parametrize("factored", [False, True])
def test_new_pair_counts_run_no_compiler(monkeypatch, factored):
    """Dynamic instance counts are not part of what is compiled: once warm,
    1,000 minimizeEnergy calls with 0 to 5,000 collision pairs, and
    compute() at some of them, ask the C++ compiler for nothing (no parse,
    no pass, no LLVM) and compile no kernel, with dense or factored
    projected Hessians."""
    monkeypatch.setattr(yasps.config, "separate_reduced_hessians", factored)
    s, pp, p2v, *_ = mixed_scene([[0, 3], [1, 4]])
    barrier = pp["b"]
    s.minimizeEnergy()
    barrier.compute()
    before = yasps.compiler.invocations()
    compiled = kernels_compiled()
    counts = np.random.default_rng(3)
    for call in range(1000):
        n = int(counts.integers(0, 5001))
        pp.updateNumInstances(n)
        p2v.updateConnectivity(np.stack([counts.integers(0, 3, n),
                                         counts.integers(3, 5, n)], axis=1))
        s.minimizeEnergy()
        if call % 50 == 0:
            assert barrier.compute().value.shape == (n, 1, 1)
    assert yasps.compiler.invocations() == before
    assert kernels_compiled() == compiled


COMPILE_ONCE = """
import sys
from pathlib import Path
sys.path[:0] = [{tests!r}, str(Path({tests!r}).parent)]
import yasps
from test_minimize import mixed_scene
yasps.config.cache_dir = {cache!r}
s, pp, *_ = mixed_scene([[0, 3], [1, 4]])
compiled = yasps.compiler.cpu.kernels_compiled
def every_request():
    for energy in s.energies:
        s.energyDerivatives(energy)
    s.minimizeEnergy()
    s.evaluateEnergy()
every_request()
kernels = compiled()
# Asked again, in any order, every kernel is found: none is compiled twice.
s.minimizeEnergy()
for energy in s.energies:
    s.energyDerivatives(energy)
every_request()
print(kernels, compiled(), len(list(Path({cache!r}).glob("*.o"))))
"""


def test_every_kernel_is_compiled_once(tmp_path):
    """energyDerivatives, minimizeEnergy and compute() ask for different
    sets of kernels (assembly adds the inner gradients and the slot
    Jacobian tables of factored energies); each kernel is compiled to
    machine code once in a process (a fresh one here) and shared by every
    request that names it, with one object per kernel on disk."""
    script = COMPILE_ONCE.format(tests=str(Path(__file__).parent),
                                 cache=str(tmp_path))
    out = subprocess.run([sys.executable, "-c", script], check=True,
                         capture_output=True, text=True).stdout.split()
    kernels, total, objects = map(int, out)
    assert kernels > 0 and total == kernels and objects == kernels


@pytest.mark.usefixtures("one_preconditioner")
def test_a_warm_newton_iteration_allocates_no_outputs(monkeypatch):
    """The derivative kernels' outputs keep their memory from one
    minimizeEnergy to the next (no fresh pages to fault in); outputs asked
    for by energyDerivatives are the caller's own."""
    import yasps.runtime.cpu as cpu
    allocated = []
    original = cpu.allocate_output

    def counting(*args):
        out = original(*args)
        allocated.append(out)
        return out

    monkeypatch.setattr(cpu, "allocate_output", counting)
    s = soft_box()
    s.minimizeEnergy()
    first = len(allocated)
    assert first > 0
    x = s.m.v["x"]
    x.updateValue(x.value[:, :, 0] * 1.01)
    (dx,) = s.minimizeEnergy()
    assert len(allocated) == first
    # The same direction as a cold solve of the same system.
    fresh = soft_box()
    fresh.m.v["x"].updateValue(x.value[:, :, 0])
    (want,) = fresh.minimizeEnergy()
    np.testing.assert_allclose(dx, want, rtol=1e-12, atol=1e-14)
    d1 = s.energyDerivatives(s.energies[1])
    d2 = s.energyDerivatives(s.energies[1])
    assert not np.shares_memory(d1.hessian, d2.hessian)
