"""Parameterisations of the paper's examples: a caged bunny (arity-8 JOIN) and
a three-way UNION of soft, affine and fixed vertices."""

import numpy as np

import yasps
from yasps import compiler


def test_caged_vertex_as_weighted_sum_of_eight_cage_points():
    s = yasps.scene("caged")
    cage = s.addMesh("cage")
    cage.addPrimitive("points", numInstances=8)
    cage.addPrimitive("surface", numInstances=5)
    points = cage.points.addAttribute("position", rows=3, cols=1)
    points.updateValue(np.random.default_rng(0).random((8, 3)))
    weights = cage.surface.addConstant("weights", rows=8, cols=1)
    weights.updateValue(np.full((5, 8), 1.0 / 8))
    s2c = cage.surface.addConnectivity("to_cage", cage.points,
                                       np.tile(np.arange(8), (5, 1)), 8)
    corners = cage.surface.addAttribute("corners", through=s2c, source=points)
    assert corners.shape == (8, 3)
    position = cage.surface.addAttribute(
        "position", computed_attribute=corners.T * weights)
    assert position.shape == (3, 1)
    s.addMinimizeTarget([points])
    ir = s.ir()
    assert "yasps.join @to_cage(@cage::@points::@position) : !yasps.mat<8x3xf64>" in ir
    assert "yasps.matmul" in ir


def test_three_way_union_of_soft_affine_and_fixed_vertices():
    s = yasps.scene("three")
    soft = s.addMesh("soft")
    soft.addPrimitive("vertices", numInstances=4)
    soft.vertices.addAttribute("position", rows=3, cols=1)

    rigid = s.addMesh("rigid")
    rigid.addPrimitive("vertices", numInstances=3)
    rigid.addPrimitive("body", numInstances=1)
    A = rigid.body.addAttribute("A", rows=3, cols=3)
    t = rigid.body.addAttribute("t", rows=3, cols=1)
    rest = rigid.vertices.addConstant("rest", rows=3, cols=1)
    v2b = rigid.vertices.addConnectivity("v2b", rigid.body, [0, 0, 0], 1)
    jA = rigid.vertices.addAttribute("A", through=v2b, source=A)
    jt = rigid.vertices.addAttribute("t", through=v2b, source=t)
    rigid.vertices.addAttribute(
        "position", computed_attribute=jA.resize(3, 3) * rest + jt.resize(3, 1))

    ground = s.addMesh("ground")
    ground.addPrimitive("vertices", numInstances=2)
    ground.vertices.addConstant("position", rows=3, cols=1)

    world = s.addMesh("world")
    world.addPrimitiveUnion("vertices", [soft.vertices, rigid.vertices,
                                         ground.vertices])
    world.vertices.addAttribute("position")
    assert world.vertices.numInstances == 9
    assert world.vertices.indexOf(ground.vertices, 1) == 8
    world.addPrimitive("pairs", numInstances=0, isDynamic=True)
    pairs = world.pairs.addConnectivity("p2v", world.vertices, [], 2)
    x = world.pairs.addAttribute("x", through=pairs,
                                 source=world.vertices["position"])
    gap = world.pairs.addAttribute(
        "gap", computed_attribute=(x.row(1) - x.row(0)).squaredNorm())
    s.addEnergy(gap, dynamic_instances=True)
    s.addMinimizeTarget([soft.vertices["position"], A, t])
    printed = compiler.run_pipeline(s.ir(), "")
    assert ("yasps.primitive_union @vertices [@soft::@vertices, "
            "@rigid::@vertices, @ground::@vertices]") in printed

    # Dynamic pairs change count and connectivity between solves.
    world.pairs.updateNumInstances(2)
    pairs.updateConnectivity([[0, world.vertices.indexOf(rigid.vertices, 2)],
                              [3, 8]])
    assert pairs.indices.tolist() == [[0, 6], [3, 8]]
    s.verify()
