"""Every expression op of the dialect is reachable from Python with the
paper's semantics; shapes are eager and the emitted IR verifies."""

import numpy as np
import pytest

import yasps
from yasps import ShapeError, compiler


@pytest.fixture
def p():
    s = yasps.scene("s")
    m = s.addMesh("m")
    prim = m.addPrimitive("p", numInstances=2)
    prim.addAttribute("a", rows=3, cols=3)
    prim.addAttribute("v", rows=3, cols=1)
    prim.addAttribute("w", rows=3, cols=1)
    prim.addAttribute("r", rows=1, cols=3)
    prim.addAttribute("s", rows=1, cols=1)
    prim.addAttribute("j", rows=2, cols=3)
    return prim


def cases(p):
    a, v, w, r, s, j = (p[n] for n in "avwrsj")
    return [
        # (expression, expected op, expected shape)
        (v + w, "yasps.add", (3, 1)),
        (v - w, "yasps.sub", (3, 1)),
        (-v, "yasps.neg", (3, 1)),
        (a * v, "yasps.matmul", (3, 1)),
        (a @ a, "yasps.matmul", (3, 3)),
        (2.0 * v, "yasps.scale", (3, 1)),
        (v * s, "yasps.scale", (3, 1)),
        (s * a, "yasps.scale", (3, 3)),
        (v / s, "yasps.div", (3, 1)),
        (v / 2, "yasps.div", (3, 1)),
        (1.0 / s, "yasps.div", (1, 1)),
        (s + 1.0, "yasps.add", (1, 1)),
        (1.0 - s, "yasps.sub", (1, 1)),
        (v.cwiseProduct(w), "yasps.elementwise_mul", (3, 1)),
        (v.T, "yasps.transpose", (1, 3)),
        (a.transpose(), "yasps.transpose", (3, 3)),
        (v.dot(w), "yasps.dot", (1, 1)),
        (r.dot(r), "yasps.dot", (1, 1)),
        (v.cross(w), "yasps.cross", (3, 1)),
        (j.row(1), "yasps.row", (1, 3)),
        (a.col(2), "yasps.col", (3, 1)),
        (v[1], "yasps.element", (1, 1)),
        (r[2], "yasps.element", (1, 1)),
        (a[1, 2], "yasps.element", (1, 1)),
        (a[-1], "yasps.row", (1, 3)),
        (a[:, 0], "yasps.col", (3, 1)),
        (a[0:2, 1:3], "yasps.slice", (2, 2)),
        (v[1:], "yasps.slice", (2, 1)),
        (j.resize(3, 2), "yasps.resize", (3, 2)),
        (yasps.vstack([v, w]), "yasps.concat vertical", (6, 1)),
        (yasps.hstack([v, w, a]), "yasps.concat horizontal", (3, 5)),
        (a.determinant(), "yasps.det", (1, 1)),
        (a.inverse(), "yasps.inverse", (3, 3)),
        (a.cofactor(), "yasps.cofactor", (3, 3)),
        (a.trace(), "yasps.trace", (1, 1)),
        (a.norm(), "yasps.norm", (1, 1)),
        (v.squaredNorm(), "yasps.squared_norm", (1, 1)),
        (j.sum(), "yasps.sum", (1, 1)),
        (s.sqrt(), "yasps.sqrt", (1, 1)),
        (s.log(), "yasps.log", (1, 1)),
        (v.exp(), "yasps.exp", (3, 1)),
        (s.pow(3), "yasps.pow", (1, 1)),
        (v ** 2, "yasps.pow", (3, 1)),
        (v ** w, "yasps.pow", (3, 1)),
        (2.0 ** v, "yasps.pow", (3, 1)),
        (s.sin(), "yasps.sin", (1, 1)),
        (s.cos(), "yasps.cos", (1, 1)),
        (s.atan2(s * 2.0), "yasps.atan2", (1, 1)),
        (abs(v), "yasps.abs", (3, 1)),
        (v.min(w), "yasps.min", (3, 1)),
        (v.max(0.0), "yasps.max", (3, 1)),
        (v < w, "yasps.cmp lt", (3, 1)),
        (s >= 0.5, "yasps.cmp ge", (1, 1)),
        (v.eq(w), "yasps.cmp eq", (3, 1)),
        ((s < 1.0).select(v, w), "yasps.select", (3, 1)),
        (yasps.select(v > w, v, 0.0), "yasps.select", (3, 1)),
        (v.asConstant(), "yasps.stop_gradient", (3, 1)),
        (a.project(), "yasps.project clamp", (3, 3)),
        (a.project("abs"), "yasps.project abs", (3, 3)),
        (a * np.eye(3), "yasps.matmul", (3, 3)),
        (np.ones((1, 3)) @ v, "yasps.matmul", (1, 1)),
        (v + np.array([1.0, 2.0, 3.0]), "yasps.add", (3, 1)),
        (a + yasps.identity(3), "yasps.add", (3, 3)),
        (v - yasps.zeros(3, 1), "yasps.sub", (3, 1)),
    ]


def test_each_operator_emits_its_op_with_eager_shape(p):
    for i, (expr, op, shape) in enumerate(cases(p)):
        assert expr.shape == shape, (i, op, expr.shape)
        assert expr.owner is p
        p.addAttribute(f"e{i}", computed_attribute=expr)
    ir = p.scene.ir()  # verifies every attribute with the C++ dialect
    for i, (expr, op, shape) in enumerate(cases(p)):
        region = ir.split(f"yasps.attr @e{i} :")[1].split("yasps.yield")[0]
        assert op in region, (i, op, region)


def test_pure_constants_fold_in_the_compiler(p):
    e = p.addAttribute("c", computed_attribute=(yasps.constant(2.0) + 3.0) * 4.0)
    assert e.owner is p and e.shape == (1, 1)
    out = compiler.run_pipeline(p.scene.ir(), "canonicalize")
    region = out.split("yasps.attr @c")[1].split("yasps.yield")[0]
    assert "dense<2.000000e+01>" in region


def test_literal_precision_survives_emission(p):
    tiny = 1e-300 / 3
    p.addAttribute("t", computed_attribute=p["s"] * tiny)
    out = compiler.run_pipeline(p.scene.ir(), "")
    assert "yasps.scale" in out
    text = p.scene.ir(verify=False)
    literal = text.split("yasps.attr @t")[1].split("dense<")[1].split(">")[0]
    assert float(literal) == tiny


@pytest.mark.parametrize("build, message", [
    (lambda a, v, r, s: v + r, "add: shapes differ"),
    (lambda a, v, r, s: v * v, "matrix product: inner dimensions differ"),
    (lambda a, v, r, s: v / v, "div: the divisor must be 1x1"),
    (lambda a, v, r, s: v.dot(r), "dot: shapes differ"),
    (lambda a, v, r, s: a.cross(a), "cross: needs 3x1 or 1x3"),
    (lambda a, v, r, s: v.determinant(), "determinant: needs a square matrix"),
    (lambda a, v, r, s: v.resize(2, 2), "resize: cannot resize"),
    (lambda a, v, r, s: v.pow(r), "pow: the exponent must be 1x1"),
    (lambda a, v, r, s: yasps.select(v, s, s), "select: the condition"),
    (lambda a, v, r, s: yasps.vstack([v, r]), "equal column counts"),
    (lambda a, v, r, s: a.project("flip"), "project: method must be"),
])
def test_shape_errors_name_operands(p, build, message):
    with pytest.raises((ShapeError, ValueError)) as err:
        build(p["a"], p["v"], p["r"], p["s"])
    assert message in str(err.value)


def test_index_errors(p):
    with pytest.raises(IndexError, match="row 3 is out of range"):
        p["a"].row(3)
    with pytest.raises(IndexError, match="column 5 is out of range"):
        p["a"][0, 5]
    with pytest.raises(IndexError, match="non-empty contiguous"):
        p["v"][::2]


def test_symbolic_values_have_no_truth_value(p):
    with pytest.raises(TypeError, match="select"):
        if p["s"] < 1.0:
            pass
