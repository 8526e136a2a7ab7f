"""attr.compute().value against NumPy: every expression op, JOINs, UNIONs,
scene- and mesh-level attributes, dynamic primitives, domain errors and the
kernel cache."""

import os
import subprocess
import sys

import numpy as np
import pytest

import yasps

from conftest import REPO, box_mesh

N = 7
rng = np.random.default_rng(42)


@pytest.fixture
def p():
    s = yasps.scene("s")
    m = s.addMesh("m")
    prim = m.addPrimitive("p", numInstances=N)
    for name, shape in [("a", (3, 3)), ("b", (3, 3)), ("v", (3, 1)),
                        ("w", (3, 1)), ("r", (1, 3)), ("s", (1, 1)),
                        ("t", (1, 1)), ("j", (2, 4)), ("q", (4, 4)),
                        ("h", (2, 2))]:
        attr = prim.addAttribute(name, rows=shape[0], cols=shape[1])
        attr.updateValue(rng.uniform(0.5, 2.0, size=(N,) + shape))
    return prim


def val(attr):
    return attr.value


def check(expr, expected, rtol=1e-13):
    got = expr.compute().value
    expected = np.asarray(expected, dtype=float).reshape(got.shape)
    np.testing.assert_allclose(got, expected, rtol=rtol, atol=1e-14)


def cases(p):
    a, b, v, w, r, s, t, j, q, h = (p[n] for n in "abvwrstjqh")
    A, B, V, W, R, S, T, J, Q, H = (x.value for x in (a, b, v, w, r, s, t, j, q, h))
    return [
        ("add", a + b, A + B),
        ("sub", v - w, V - W),
        ("neg", -j, -J),
        ("matmul", a * v, A @ V),
        ("matmul rect", j.T * j, np.transpose(J, (0, 2, 1)) @ J),
        ("scale", v * s, V * S),
        ("scale number", 2.5 * a, 2.5 * A),
        ("div", v / s, V / S),
        ("div number", 1.0 / s, 1.0 / S),
        ("elementwise", v.cwiseProduct(w), V * W),
        ("transpose", j.T, np.transpose(J, (0, 2, 1))),
        ("dot", v.dot(w), np.sum(V * W, axis=(1, 2)).reshape(N, 1, 1)),
        ("dot rows", r.dot(r), np.sum(R * R, axis=(1, 2)).reshape(N, 1, 1)),
        ("cross", v.cross(w), np.cross(V[..., 0], W[..., 0])[..., None]),
        ("cross rows", r.cross(r * 2.0 + 1.0),
         np.cross(R[:, 0], 2 * R[:, 0] + 1)[:, None, :]),
        ("row", j.row(1), J[:, 1:2, :]),
        ("col", a.col(2), A[:, :, 2:3]),
        ("element", a[1, 2], A[:, 1:2, 2:3]),
        ("slice", j[0:2, 1:3], J[:, 0:2, 1:3]),
        ("resize", j.resize(4, 2),
         np.stack([x.reshape(-1, order="F").reshape(4, 2, order="F") for x in J])),
        ("vstack", yasps.vstack([v, w]), np.concatenate([V, W], axis=1)),
        ("hstack", yasps.hstack([a, v]), np.concatenate([A, V], axis=2)),
        ("det 1", s.resize(1, 1).determinant(), S),
        ("det 2", h.determinant(), np.linalg.det(H).reshape(N, 1, 1)),
        ("det 3", a.determinant(), np.linalg.det(A).reshape(N, 1, 1)),
        ("det 4", q.determinant(), np.linalg.det(Q).reshape(N, 1, 1)),
        ("inverse 2", h.inverse(), np.linalg.inv(H)),
        ("inverse 3", a.inverse(), np.linalg.inv(A)),
        ("inverse 4", q.inverse(), np.linalg.inv(Q)),
        ("cofactor 2", h.cofactor(),
         np.linalg.det(H)[:, None, None] * np.transpose(np.linalg.inv(H), (0, 2, 1))),
        ("cofactor 3", a.cofactor(),
         np.linalg.det(A)[:, None, None] * np.transpose(np.linalg.inv(A), (0, 2, 1))),
        ("cofactor 4", q.cofactor(),
         np.linalg.det(Q)[:, None, None] * np.transpose(np.linalg.inv(Q), (0, 2, 1))),
        ("trace", a.trace(), np.trace(A, axis1=1, axis2=2).reshape(N, 1, 1)),
        ("norm", j.norm(), np.linalg.norm(J, axis=(1, 2)).reshape(N, 1, 1)),
        ("squaredNorm", v.squaredNorm(), np.sum(V ** 2, axis=(1, 2)).reshape(N, 1, 1)),
        ("sum", j.sum(), J.sum(axis=(1, 2)).reshape(N, 1, 1)),
        ("sqrt", v.sqrt(), np.sqrt(V)),
        ("log", v.log(), np.log(V)),
        ("exp", v.exp(), np.exp(V)),
        ("pow scalar", v ** 3, V ** 3),
        ("pow attr", v.pow(s), V ** S),
        ("pow entrywise", v.pow(w), V ** W),
        ("sin", v.sin(), np.sin(V)),
        ("cos", v.cos(), np.cos(V)),
        ("atan2", v.atan2(w - 1.0), np.arctan2(V, W - 1.0)),
        ("abs", abs(v - 1.0), np.abs(V - 1.0)),
        ("min", v.min(w), np.minimum(V, W)),
        ("max", v.max(w), np.maximum(V, W)),
        ("lt", v < w, (V < W).astype(float)),
        ("ge", v >= w, (V >= W).astype(float)),
        ("eq", v.eq(v), np.ones_like(V)),
        ("ne", v.ne(w), (V != W).astype(float)),
        ("select scalar", (s < t).select(v, w), np.where(S < T, V, W)),
        ("select entrywise", (v < w).select(v, w), np.where(V < W, V, W)),
        ("asConstant", v.asConstant(), V),
        ("constant", v + np.array([1.0, 2.0, 3.0]), V + np.array([1.0, 2.0, 3.0])[:, None]),
        ("identity", a + yasps.identity(3), A + np.eye(3)),
    ]


def test_every_op_matches_numpy(p):
    for name, expr, expected in cases(p):
        rtol = 1e-10 if "inverse" in name or "det" in name else 1e-13
        try:
            check(expr, expected, rtol)
        except AssertionError as err:
            raise AssertionError(f"op {name}: {err}") from None


@pytest.mark.parametrize("shape", [(1, 1), (2, 5), (6, 6)])
def test_shapes(shape):
    s = yasps.scene("shapes")
    prim = s.addMesh("m").addPrimitive("p", numInstances=N)
    x = prim.addAttribute("x", rows=shape[0], cols=shape[1])
    X = rng.normal(size=(N,) + shape)
    x.updateValue(X)
    check(x * 2.0 - x.cwiseProduct(x), 2 * X - X * X)
    check(x.T * x, np.transpose(X, (0, 2, 1)) @ X)


def test_scene_and_mesh_attributes_broadcast():
    s = yasps.scene("s")
    g = s.addConstant("gravity", rows=3, cols=1)
    g.updateValue([0.0, 0.0, -9.81])
    m = s.addMesh("m")
    k = m.addConstant("k", rows=1, cols=1)
    k.updateValue([[4.0]])
    v = m.addPrimitive("v", numInstances=N)
    x = v.addAttribute("x", rows=3, cols=1)
    X = rng.normal(size=(N, 3, 1))
    x.updateValue(X)
    check(k * x.dot(g), 4.0 * (X[:, 2, 0] * -9.81))
    # Attributes of the mesh itself have one instance.
    assert (k * 2.0).compute().value.shape == (1, 1, 1)


def test_joins_of_arity_4_and_8_and_join_of_join():
    verts, tets = box_mesh(2)
    s = yasps.scene("j")
    m = s.addMesh("m")
    v = m.addPrimitive("v", numInstances=len(verts))
    t = m.addPrimitive("t", numInstances=len(tets))
    x = v.addAttribute("x", rows=3, cols=1)
    X = verts + rng.normal(scale=0.01, size=verts.shape)
    x.updateValue(X)
    t2v = t.addConnectivity("t2v", v, tets, 4)
    tx = t.addAttribute("x", through=t2v, source=x)
    check(tx, X[tets])
    # Deformation gradient-like computation on the gathered rows.
    Ds = yasps.hstack([(tx.row(i) - tx.row(0)).T for i in (1, 2, 3)])
    ref = np.stack([np.stack([X[c[i]] - X[c[0]] for i in (1, 2, 3)], axis=1)
                    for c in tets])
    check(Ds.determinant(), np.linalg.det(ref))

    # Arity 8: cells gathering 8 tets' volumes, then a JOIN of that JOIN.
    vol = t.addAttribute("vol", computed_attribute=Ds.determinant() / 6.0)
    cells = len(tets) // 6
    c = m.addPrimitive("cells", numInstances=cells)
    eight = (np.arange(cells)[:, None] * 6 + np.arange(8)[None, :]) % len(tets)
    c2t = c.addConnectivity("c2t", t, eight, 8)
    vols = c.addAttribute("vols", through=c2t, source=vol)
    cidx = c2t.indices
    tet_vol = np.linalg.det(ref) / 6.0
    check(vols, tet_vol[cidx][:, :, None])
    total = c.addAttribute("total", computed_attribute=vols.sum())
    top = m.addPrimitive("top", numInstances=2)
    top2c = top.addConnectivity("top2c", c, [[0, 1], [1, 0]], 2)
    joined = top.addAttribute("totals", through=top2c, source=total)
    per_cell = tet_vol[cidx].sum(axis=1)
    check(joined, per_cell[[[0, 1], [1, 0]]][:, :, None])


def three_way_union():
    s = yasps.scene("u")
    soft = s.addMesh("soft")
    soft.addPrimitive("v", numInstances=3)
    xs = soft.v.addAttribute("x", rows=3, cols=1)
    XS = rng.normal(size=(3, 3))
    xs.updateValue(XS)
    rigid = s.addMesh("rigid")
    rigid.addPrimitive("v", numInstances=2)
    rigid.addPrimitive("body", numInstances=1)
    A = rigid.body.addAttribute("A", rows=3, cols=3)
    AM = rng.normal(size=(3, 3))
    A.updateValue(AM)
    rest = rigid.v.addConstant("rest", rows=3, cols=1)
    RE = rng.normal(size=(2, 3))
    rest.updateValue(RE)
    v2b = rigid.v.addConnectivity("v2b", rigid.body, [0, 0], 1)
    jA = rigid.v.addAttribute("A", through=v2b, source=A)
    rigid.v.addAttribute("x", computed_attribute=jA.resize(3, 3) * rest)
    fixed = s.addMesh("fixed")
    fixed.addPrimitive("v", numInstances=4)
    xf = fixed.v.addConstant("x", rows=3, cols=1)
    XF = rng.normal(size=(4, 3))
    xf.updateValue(XF)
    world = s.addMesh("world")
    u = world.addPrimitiveUnion("v", [soft.v, rigid.v, fixed.v])
    u.addAttribute("x")
    expected = np.concatenate([XS, RE @ AM.T, XF])
    return s, u, expected


def test_three_way_union():
    s, u, expected = three_way_union()
    np.testing.assert_allclose(u["x"].compute().value[:, :, 0], expected,
                               rtol=1e-14)
    # Pairs through the union, and a dynamic count between calls.
    world = s.world
    pairs = world.addPrimitive("pairs", numInstances=0, isDynamic=True)
    p2v = pairs.addConnectivity("p2v", u, [], 2)
    x = pairs.addAttribute("x", through=p2v, source=u["x"])
    gap = pairs.addAttribute("gap", computed_attribute=(x.row(1) - x.row(0)).norm())
    assert gap.compute().value.shape == (0, 1, 1)
    for count in (3, 8, 1):
        idx = rng.integers(0, u.numInstances, size=(count, 2)).astype(np.int32)
        pairs.updateNumInstances(count)
        p2v.updateConnectivity(idx)
        result = gap.compute()
        want = np.linalg.norm(expected[idx[:, 1]] - expected[idx[:, 0]], axis=1)
        np.testing.assert_allclose(result.value[:, 0, 0], want, rtol=1e-13)
        if count != 3:
            # Only instance counts changed: the kernel is reused.
            assert result.stats["from_memory"]


def test_domain_errors_give_nan():
    s = yasps.scene("d")
    prim = s.addMesh("m").addPrimitive("p", numInstances=3)
    x = prim.addAttribute("x", rows=1, cols=1)
    x.updateValue([[-1.0], [0.0], [4.0]])
    logs = x.log().compute().value[:, 0, 0]
    roots = x.sqrt().compute().value[:, 0, 0]
    assert np.isnan(logs[0]) and logs[1] == -np.inf and logs[2] == np.log(4.0)
    assert np.isnan(roots[0]) and roots[2] == 2.0
    assert np.isnan((x / 0.0 * 0.0).compute().value[1, 0, 0])


def test_missing_values_are_reported():
    s = yasps.scene("m")
    prim = s.addMesh("m").addPrimitive("p", numInstances=3)
    x = prim.addAttribute("x", rows=1, cols=1)
    with pytest.raises(yasps.ValueUpdateError, match="has no values"):
        (x * 2.0).compute()


def test_threads_give_the_same_result():
    s = yasps.scene("t")
    prim = s.addMesh("m").addPrimitive("p", numInstances=10000)
    x = prim.addAttribute("x", rows=3, cols=1)
    x.updateValue(rng.normal(size=(10000, 3)))
    e = (x.dot(x) + 1.0).log()
    one = e.compute(threads=1).value
    many = e.compute(threads=4).value
    np.testing.assert_array_equal(one, many)


def test_second_process_compiles_nothing(tmp_path):
    """A second process loads the cached object without parsing the IR (the
    request's record names it); a damaged record only costs a parse."""
    script = f"""
import sys, numpy as np
sys.path.insert(0, {str(REPO / 'python')!r})
import yasps
s = yasps.scene("warm")
p = s.addMesh("m").addPrimitive("p", numInstances=5)
x = p.addAttribute("x", rows=3, cols=3)
x.updateValue(np.tile(np.eye(3), (5, 1, 1)) * 2)
r = x.determinant().compute()
assert np.allclose(r.value, 8.0)
print(r.stats["from_disk"], r.stats["from_memory"], r.stats["from_source"])
"""
    env = dict(os.environ, YASPS_CACHE_DIR=str(tmp_path / "cache"))

    def run():
        return subprocess.run([sys.executable, "-c", script], env=env,
                              check=True, capture_output=True,
                              text=True).stdout.split()

    assert run() == ["False", "False", "False"]
    assert run() == ["True", "False", "True"]
    assert len(list((tmp_path / "cache").glob("*.o"))) == 1
    (record,) = (tmp_path / "cache").glob("*.source.json")
    record.write_text(record.read_text()[:40])
    assert run() == ["True", "False", "False"]
    assert len(list((tmp_path / "cache").glob("*.o"))) == 1


@pytest.mark.parametrize("lanes", [1, 0, 3])
@pytest.mark.parametrize("n", [1, 2, 3, 6, 9, 12, 24])
def test_projection_matches_numpy_eigh(n, lanes, monkeypatch):
    # One instance at a time, the host's SIMD width, and an odd lane count;
    # 60 instances leave a partial last tile.
    monkeypatch.setattr(yasps.config, "simd_lanes", lanes)
    count = 60
    s = yasps.scene("proj")
    prim = s.addMesh("m").addPrimitive("p", numInstances=count)
    h = prim.addAttribute("h", rows=n, cols=n)
    M = rng.normal(size=(count, n, n))
    M = M + np.transpose(M, (0, 2, 1))
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    # Repeated, tiny and zero eigenvalues, and a widely scaled diagonal.
    M[0] = Q @ np.diag(np.resize([2.0, 2.0, -1e-12, 1e-12, 0.0, -3.0], n)) @ Q.T
    M[1] = np.diag(np.resize([1e-200, 1e200, -1e-200, 3.0], n))
    M[2] = -np.eye(n)
    # Near the smallest normal numbers (products of entries underflow), a
    # cluster of equal negative eigenvalues, eigenvalues spread over 30
    # orders of magnitude.
    M[3] = Q @ np.diag(rng.normal(size=n)) @ Q.T * 1e-300
    M[4] = Q @ np.diag(np.resize([-2.0, -2.0, -2.0, 1e-14], n)) @ Q.T
    M[5] = Q @ np.diag(10.0 ** rng.uniform(-15, 15, n)
                       * rng.choice([-1, 1], n)) @ Q.T
    M[3:6] = (M[3:6] + np.transpose(M[3:6], (0, 2, 1))) / 2
    h.updateValue(M)
    w, V = np.linalg.eigh(M)
    scale = np.abs(M).max(axis=(1, 2))[:, None, None]
    for method, f in [("clamp", np.maximum(w, 0)), ("abs", np.abs(w)),
                      ("none", w)]:
        got = h.project(method).compute().value
        ref = np.einsum("nij,nj,nkj->nik", V, f, V)
        assert (np.abs(got - ref) / scale).max() < 1e-13, method
        if method == "clamp":
            smallest = np.linalg.eigvalsh(got).min(axis=1)
            assert (smallest >= -1e-12 * scale[:, 0, 0]).all()
            np.testing.assert_array_equal(got[2], 0.0)


def test_evaluate_energy_is_one_native_call_over_a_plan(monkeypatch):
    """evaluateEnergy (the line search's call) is the sum of each energy's
    compute(), through one native call over a plan made once per scene
    structure: new values, or new instance counts, emit and compile
    nothing; a new energy makes a new plan that includes it."""
    import yasps.runtime.energy_plan as energy_plan
    from yasps.runtime.native import native
    from yasps.sim import add_elastic_tets, add_free_vertices
    verts, tets = box_mesh(1)
    s = yasps.scene("summed")
    b = add_free_vertices(s.addMesh("soft"), verts, 1.0)
    add_elastic_tets(s.soft, b.x, verts * 1.1, tets, 1e4, 4e4, scale=1e-4)
    b.x_hat.updateValue(verts + 0.01)
    emitted, sums = [], []
    original = energy_plan.kernel_ir
    monkeypatch.setattr(energy_plan, "kernel_ir",
                        lambda *a, **k: emitted.append(1) or original(*a, **k))
    module = native()
    summing = module.sum_cpu_kernels
    monkeypatch.setattr(module, "sum_cpu_kernels",
                        lambda *a, **k: sums.append(1) or summing(*a, **k),
                        raising=False)
    assert len(s.energies) > 1
    for shift in (0.0, 0.003):
        b.x.updateValue(verts + shift)
        expected = sum(float(e.compute().value.sum()) for e in s.energies)
        assert s.evaluateEnergy() == pytest.approx(expected, rel=1e-14, abs=0)
    assert len(emitted) == 1 and len(sums) == 2
    # Another energy: a new plan, which sums it too.
    pull = b.x.owner.addAttribute(
        "pull", computed_attribute=(b.x - b.x_hat).squaredNorm())
    s.addEnergy(pull)
    expected = sum(float(e.compute().value.sum()) for e in s.energies)
    assert s.evaluateEnergy() == pytest.approx(expected, rel=1e-14, abs=0)
    assert len(emitted) == 2 and len(sums) == 3


def test_evaluate_energy_sums_without_cancellation():
    """The total is summed with compensation (Neumaier): terms that cancel
    (1e16, 1, -1e16, 1, ...) leave the exact sum, which math.fsum gives,
    where a plain running sum in f64 loses every 1."""
    import math
    count = 400
    weights = np.where(np.arange(count) % 2 == 0,
                       np.where(np.arange(count) % 4 == 0, 1e16, -1e16), 1.0)
    s = yasps.scene("cancelling")
    v = s.addMesh("m").addPrimitive("v", numInstances=count)
    x = v.addAttribute("x", rows=1)
    x.updateValue(np.ones((count, 1, 1)))
    w = v.addConstant("w", rows=1)
    w.updateValue(weights.reshape(count, 1, 1))
    s.addMinimizeTarget(x)
    s.addEnergy(v.addAttribute("e", computed_attribute=w * x * x))
    exact = math.fsum(weights)
    running = 0.0
    for term in weights:
        running += term
    assert exact == count / 2 and running != exact
    assert s.evaluateEnergy() == exact


def test_kernel_argument_kinds_are_the_dialects_enum(tmp_path, monkeypatch):
    """Kernels' argument kinds cross the bindings as the dialect's
    KernelArgKind, also for kernels loaded from the disk cache (which
    records their spelling)."""
    import yasps.compiler.cpu as cpu
    from yasps.compiler.params import ArgumentKind
    from yasps.ir import kernel_ir, symbol_path
    s = yasps.scene("kinds")
    v = s.addMesh("m").addPrimitive("v", numInstances=3)
    x = v.addAttribute("x", rows=3)
    x.updateValue(np.ones((3, 3, 1)))
    energy = s.addEnergy(v.addAttribute("e",
                                        computed_attribute=x.squaredNorm()))
    path = symbol_path(energy)
    kinds, kept = [], []  # kept alive: infos are cached by id(library)
    with yasps.config.override(cache_dir=str(tmp_path)):
        for fresh in (True, False):
            monkeypatch.setattr(cpu, "_libraries", {})
            kernels = cpu.compile_cpu(kernel_ir(s, precision="f64"), (path,),
                                      s.name)
            kept.append(kernels)
            assert kernels.stats.get("from_source", False) is not fresh
            kinds.append([a.kind for a in kernels.kernel(path).arguments])
    assert kinds[0] == kinds[1] == [ArgumentKind.out, ArgumentKind.attr]
    assert all(isinstance(k, ArgumentKind) for k in kinds[0])
