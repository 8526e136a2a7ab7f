"""User mistakes raise at the line that makes them, with a message naming
attributes, owners and shapes, and leave the scene as it was."""

import numpy as np
import pytest

import yasps
from yasps import LineageError, SceneError, ShapeError, ValueUpdateError

from conftest import box_mesh, running_example


def small_scene():
    verts, tets = box_mesh(1)
    s = yasps.scene("s")
    m = s.addMesh("bunny")
    m.addPrimitive("vertices", numInstances=len(verts))
    m.addPrimitive("tets", numInstances=len(tets))
    x = m.vertices.addAttribute("position", rows=3, cols=1)
    x.updateValue(verts)
    m.tets.addConstant("volume", rows=1, cols=1)
    m.tets.addConstant("Dm", rows=3, cols=3)
    t2v = m.tets.addConnectivity("tet2v", m.vertices, tets, 4)
    m.tets.addAttribute("x", through=t2v, source=x)
    other = s.addMesh("other")
    other.addPrimitive("vertices", numInstances=2)
    other.vertices.addAttribute("position", rows=3, cols=1)
    return s


def unchanged(s, action, error, *fragments):
    """Runs `action`, expects `error` with every fragment in its message, and
    checks that the scene's IR is what it was and still verifies."""
    before = s.ir()
    with pytest.raises(error) as info:
        action()
    for fragment in fragments:
        assert fragment in str(info.value), (fragment, str(info.value))
    assert s.ir() == before
    return info.value


def test_tet_attribute_plus_vertex_attribute():
    s = small_scene()
    m = s.bunny
    unchanged(s, lambda: m.tets["volume"] + m.vertices["position"],
              LineageError, "constant attribute 'volume' [1x1] on primitive "
              "'bunny.tets'", "data attribute 'position' [3x1] on primitive "
              "'bunny.vertices'", "JOIN")


def test_attributes_of_two_meshes():
    s = small_scene()
    unchanged(s, lambda: s.bunny.vertices["position"] +
              s.other.vertices["position"], LineageError,
              "'bunny.vertices'", "'other.vertices'", "not on one lineage")


def test_join_of_3x3_through_arity_4_used_as_4x3():
    s = small_scene()
    m = s.bunny
    t2v = m.tets.connectivities["tet2v"]
    m.vertices.addConstant("F", rows=3, cols=3)
    joined = m.tets.addAttribute("F", through=t2v, source=m.vertices["F"])
    assert joined.shape == (4, 9)
    unchanged(s, lambda: joined + m.tets["x"], ShapeError,
              "join attribute 'F' [4x9] on primitive 'bunny.tets'",
              "join attribute 'x' [4x3]")
    unchanged(s, lambda: joined.T * m.tets["Dm"], ShapeError,
              "inner dimensions differ", "[9x4]", "'Dm' [3x3]")


def test_join_through_a_foreign_connectivity_or_of_a_wrong_source():
    s = small_scene()
    m = s.bunny
    t2v = m.tets.connectivities["tet2v"]
    unchanged(s, lambda: m.vertices.addAttribute("y", through=t2v,
                                                 source=m.vertices["position"]),
              LineageError, "is not a connectivity of primitive "
              "'bunny.vertices'")
    unchanged(s, lambda: m.tets.addAttribute("y", through=t2v,
                                             source=s.other.vertices["position"]),
              LineageError, "not an attribute of the connectivity's target "
              "primitive 'bunny.vertices'")
    unchanged(s, lambda: m.tets.addAttribute(
        "y", through=t2v, source=m.vertices["position"] * 2.0),
        LineageError, "unnamed expression")


def test_union_over_primitives_without_the_attribute():
    s = small_scene()
    all_ = s.addMesh("all")
    u = all_.addPrimitiveUnion("vertices", [s.bunny.vertices, s.bunny.tets])
    unchanged(s, lambda: u.addAttribute("position"), LineageError,
              "UNION needs attribute 'position' on every member",
              "primitive 'bunny.tets'")
    unchanged(s, lambda: u.addAttribute("volume"), LineageError,
              "primitive 'bunny.vertices'")


def test_union_of_different_shapes():
    s = small_scene()
    s.other.vertices.addConstant("volume", rows=3, cols=1)
    all_ = s.addMesh("all")
    u = all_.addPrimitiveUnion("mixed", [s.bunny.tets, s.other.vertices])
    unchanged(s, lambda: u.addAttribute("volume"), ShapeError,
              "UNION needs one shape", "[1x1]", "[3x1]")


@pytest.mark.parametrize("values, fragment", [
    (np.zeros((7, 3)), "expected 8 instance(s) of 3x1"),
    (np.zeros(25), "got shape (25,)"),
    (np.array(["a"] * 24), "values must be real numbers"),
    (np.zeros((8, 3), dtype=complex), "values must be real numbers"),
    ([[0.0, 0.0, float("nan")]] * 8, "NaN or inf (first at instance 0)"),
    ([[1, 2], [3]], "cannot read"),
])
def test_update_value_rejects_bad_values(values, fragment):
    s = small_scene()
    x = s.bunny.vertices["position"]
    old = x.value.copy()
    unchanged(s, lambda: x.updateValue(values), ValueUpdateError,
              "data attribute 'position' [3x1] on primitive 'bunny.vertices'",
              fragment)
    np.testing.assert_array_equal(x.value, old)


def test_update_value_of_a_computed_attribute():
    s = small_scene()
    unchanged(s, lambda: s.bunny.tets["x"].updateValue(np.zeros((6, 4, 3))),
              ValueUpdateError, "computed from other attributes")


def test_connectivity_errors():
    s = small_scene()
    m = s.bunny
    _, tets = box_mesh(1)
    bad = tets.copy()
    bad[2, 1] = 8
    unchanged(s, lambda: m.tets.addConnectivity("t", m.vertices, bad, 4),
              SceneError, "index 8 (instance 2, slot 1) is out of range: the "
              "target has 8 instances")
    # An unsigned index past the int64 range is reported as itself.
    huge = tets.astype(np.uint64)
    huge[1, 3] = np.uint64(2 ** 64 - 1)
    unchanged(s, lambda: m.tets.addConnectivity("t", m.vertices, huge, 4),
              SceneError, "index 18446744073709551615 (instance 1, slot 3) "
              "is out of range")
    unchanged(s, lambda: m.tets.addConnectivity("t", m.vertices, tets[:3], 4),
              SceneError, "expected 6 instance(s) of arity 4")
    unchanged(s, lambda: m.tets.addConnectivity("t", m.vertices,
                                                tets.astype(float), 4),
              SceneError, "indices must be integers")
    unchanged(s, lambda: m.tets.addConnectivity("t", m.vertices, tets, 0),
              SceneError, "arity must be a positive integer")


def test_names():
    s = small_scene()
    m = s.bunny
    unchanged(s, lambda: m.vertices.addAttribute("position", rows=3),
              SceneError, "already has", "'position'")
    unchanged(s, lambda: m.addPrimitive("vertices", numInstances=3),
              SceneError, "already has")
    unchanged(s, lambda: m.addPrimitive("2d", numInstances=3), SceneError,
              "must be an identifier")
    with pytest.raises(KeyError, match="has no attribute 'pos'.*position"):
        m.vertices["pos"]
    with pytest.raises(AttributeError, match="has no primitive 'edges'"):
        m.edges


def test_energy_and_target_errors():
    s = small_scene()
    m = s.bunny
    x = m.vertices["position"]
    unchanged(s, lambda: s.addEnergy(x), ShapeError, "must be 1x1",
              "'position' [3x1]")
    unchanged(s, lambda: s.addMinimizeTarget([m.tets["volume"]]), SceneError,
              "constant attribute 'volume'", "not a data attribute")
    unchanged(s, lambda: s.addMinimizeTarget([x, x]), SceneError,
              "listed twice")
    unchanged(s, lambda: s.addEnergy(x.squaredNorm(), dynamic_instances=True),
              SceneError, "is not dynamic")
    pairs = m.addPrimitive("pairs", numInstances=0, isDynamic=True)
    e = pairs.addConstant("e", rows=1, cols=1)
    unchanged(s, lambda: s.addEnergy(e), SceneError, "dynamic_instances=True")


def test_computed_attribute_on_the_wrong_entity():
    s = small_scene()
    m = s.bunny
    m.addConstant("k", rows=1, cols=1)
    unchanged(s, lambda: m.vertices.addAttribute("kk",
                                                 computed_attribute=m["k"] * 2.0),
              LineageError, "only reads attributes of mesh 'bunny'",
              "add it to mesh 'bunny'")
    unchanged(s, lambda: m.tets.addAttribute(
        "y", computed_attribute=m.vertices["position"] * 2.0),
        LineageError, "not on the lineage of primitive 'bunny.tets'")


def test_dynamic_primitive_updates():
    s = running_example(1)
    pp = s.bunnies.pp
    conn = pp.connectivities["pp2v"]
    with pytest.raises(SceneError, match="expected 0 instance"):
        conn.updateConnectivity([[0, 1]])
    pp.updateNumInstances(1)
    with pytest.raises(SceneError, match="no indices"):
        conn.indices
    conn.updateConnectivity([[0, s.bunnies.vertices.indexOf(
        s.bunny_soft.vertices, 0)]])
    assert conn.indices.tolist() == [[0, 8]]
    with pytest.raises(SceneError, match="not dynamic"):
        s.bunny_soft.vertices.updateNumInstances(3)
    assert "yasps.primitive @pp(1) dynamic" in s.ir()


def test_stale_connectivity_into_a_shrunk_dynamic_primitive():
    s = yasps.scene("stale")
    m = s.addMesh("m")
    pts = m.addPrimitive("pts", numInstances=3, isDynamic=True)
    x = pts.addAttribute("x", rows=1)
    x.updateValue([[1.0], [2.0], [3.0]])
    pairs = m.addPrimitive("pairs", numInstances=1)
    conn = pairs.addConnectivity("p2p", pts, [[0, 2]], 2)
    joined = pairs.addAttribute("x", through=conn, source=x)
    assert joined.compute().value.tolist() == [[[1.0], [3.0]]]
    pts.updateNumInstances(2)
    x.updateValue([[1.0], [2.0]])
    with pytest.raises(SceneError, match="refers to instance 2 .* which now has 2"):
        joined.compute()


def test_a_huge_primitive_is_a_yasps_error_before_any_allocation(monkeypatch):
    """10^9 instances without values: the missing values are reported
    before the 8 GB output is allocated; 10^12 instances of a value that
    needs no inputs: the allocation fails as a yasps error naming the
    attribute and the bytes (not numpy's MemoryError)."""
    monkeypatch.setattr(yasps.config, "backend", "cpu")
    s = yasps.scene("huge")
    p = s.addMesh("m").addPrimitive("p", numInstances=10 ** 9)
    x = p.addAttribute("x", rows=3)
    doubled = p.addAttribute("d", computed_attribute=2.0 * x)
    with pytest.raises(yasps.ValueUpdateError, match="has no values"):
        doubled.compute()
    q = s.m.addPrimitive("q", numInstances=10 ** 12)
    one = q.addAttribute("one", computed_attribute=yasps.constant(
        np.ones((3, 1))) * 1.0)
    with pytest.raises(yasps.SceneError,
                       match=r"@m::@q::@one: 1000000000000 instances of "
                             r"3x1 doubles need 24,000,000,000,000 bytes"):
        one.compute()


def test_counts_past_int64_are_reported_as_given():
    s = small_scene()
    for count in (2 ** 63, 2 ** 70, np.uint64(2 ** 64 - 1), -1):
        unchanged(s, lambda: s.bunny.addPrimitive("p", numInstances=count),
                  SceneError, "numInstances must be an integer in [0, 2^63-1]",
                  repr(count))
    pp = s.bunny.addPrimitive("pp", numInstances=0, isDynamic=True)
    with pytest.raises(SceneError, match=r"got 9223372036854775808$"):
        pp.updateNumInstances(2 ** 63)
    assert pp.numInstances == 0


def test_list_indices_past_int64_are_reported_as_given():
    """numpy reads [[0, 2**63]] as floats and [[0, 2**70]] as objects: the
    index is still reported as the integer it is, for addConnectivity and
    updateConnectivity alike."""
    s = small_scene()
    m = s.bunny
    pp = m.addPrimitive("pp", numInstances=1, isDynamic=True)
    conn = pp.addConnectivity("c", m.vertices, [[0, 1]], 2)
    for index in (2 ** 63, 2 ** 70, -2 ** 70):
        with pytest.raises(SceneError, match=rf"index {index} \(instance 0, "
                                             r"slot 1\) is out of range"):
            conn.updateConnectivity([[0, index]])
        unchanged(s, lambda: pp.addConnectivity("d", m.vertices,
                                                [[0, index]], 2),
                  SceneError, f"index {index} (instance 0, slot 1)")
    assert conn.indices.tolist() == [[0, 1]]
    with pytest.raises(SceneError, match="indices must be integers"):
        conn.updateConnectivity([[0, 1.0]])


def test_a_connectivity_into_more_instances_than_int32_indices_reach():
    s = small_scene()
    big = s.other.addPrimitive("big", numInstances=2 ** 31)
    unchanged(s, lambda: s.bunny.tets.addConnectivity("c", big, [[0]] * 6, 1),
              SceneError, "the target has 2147483648 instances; connectivity "
              "indices are int32")


def test_values_given_as_large_python_ints():
    s = small_scene()
    x = s.bunny.vertices["position"]
    x.updateValue([[2 ** 70, 0, 0]] * 8)
    assert x.value[0, 0, 0] == float(2 ** 70)
    unchanged(s, lambda: x.updateValue([[10 ** 400, 0, 0]] * 8),
              ValueUpdateError, "an integer is too large")


def test_matrix_entries_are_limited_as_in_the_verifier():
    s = small_scene()
    unchanged(s, lambda: s.bunny.vertices.addAttribute("h", rows=129,
                                                       cols=128),
              ShapeError, "129x128 has 16512 entries; a matrix has at most "
              "16384")
    s.bunny.vertices.addConstant("h", rows=128, cols=128)
    assert "!yasps.mat<128x128xf64>" in s.ir()  # the verifier accepts it


def test_fixed_masks_must_be_boolean_and_one_per_target():
    from yasps.sim import ImplicitEuler

    s = small_scene()
    v = s.bunny.vertices
    x = v["position"]
    x_hat = v.addConstant("x_hat", rows=3)
    x_hat.updateValue(x.value)
    s.addEnergy(v.addAttribute("inertia", computed_attribute=(
        x - x_hat).squaredNorm()))
    s.addMinimizeTarget([x])
    half = np.full(8, 0.5)
    with pytest.raises(SceneError, match="must be boolean .* got dtype "
                                         "float64"):
        s.minimizeEnergy(fixed=[half])
    with pytest.raises(SceneError, match="must be boolean"):
        ImplicitEuler(s, targets=[x], predicted=[x_hat], dt=0.01,
                      gravity=[None], fixed=[half])
    with pytest.raises(SceneError, match="one fixed mask"):
        ImplicitEuler(s, targets=[x], predicted=[x_hat], dt=0.01,
                      gravity=[None], fixed=[None, None])
    with pytest.raises(SceneError, match="fixed has 2 entries"):
        s.minimizeEnergy(fixed=[None, None])
    # 0/1 integers are a mask.
    (dx,) = s.minimizeEnergy(fixed=[(np.arange(8) < 2).astype(np.int64)])
    assert (dx[:2] == 0).all()


def test_a_kernel_past_the_operation_limit_is_an_ir_error():
    """A 128x128 product is 2M multiply-adds of straight-line code per
    instance: refused when compiled, naming the op, before it is emitted."""
    s = yasps.scene("big")
    p = s.addMesh("m").addPrimitive("p", numInstances=1)
    a = p.addAttribute("a", rows=128, cols=128)
    a.updateValue(np.zeros((1, 128, 128)))
    y = p.addAttribute("y", computed_attribute=a @ a)
    with pytest.raises(yasps.IRError, match=r"'yasps.matmul' op makes kernel "
                       r"\S+ exceed 524288 scalar operations per instance"):
        y.compute()


def test_kernel_launch_checks_its_buffers():
    """The runtime checks a compiled kernel's buffers against its codes
    before it calls the kernel: their number, dtype and rank."""
    from yasps.compiler.cpu import compile_cpu
    from yasps.compiler.specs import scene_kernel_paths
    from yasps.ir import emit_scene
    from yasps.runtime.native import native

    s = running_example()
    path = scene_kernel_paths(s)[0]
    kernels = compile_cpu(emit_scene(s), [path], "launch_check")
    entry, codes = kernels.entry(path)
    assert entry and set(codes) <= set("iqfd")
    launch = native().launch_cpu_kernel
    with pytest.raises(ValueError, match=f"takes {len(codes)} buffers, got 0"):
        launch(entry, codes, 1, [])
    wrong = [np.zeros(4, dtype=np.int8) for _ in codes]
    with pytest.raises(ValueError, match="kernel buffer 0 must be 1-D"):
        launch(entry, codes, 1, wrong)
    with pytest.raises(ValueError, match="unknown kernel buffer code 'x'"):
        launch(entry, "x", 1, [np.zeros(1)])
