"""The paper's running example (section 4) built in Python: IR that the C++
dialect verifies and that round-trips through the compiler and yasps-opt."""

import subprocess

import pytest

from yasps import compiler

from conftest import yasps_opt


def test_ir_verifies_and_round_trips(example_scene):
    ir = example_scene.ir()  # verifies with the C++ dialect
    printed = compiler.run_pipeline(ir, "")
    assert compiler.run_pipeline(printed, "") == printed
    for fragment in [
        "yasps.primitive_union @vertices [@bunny_affine::@vertices, "
        "@bunny_soft::@vertices]",
        "yasps.primitive @pp(0) dynamic",
        "yasps.join @pp2v(@bunnies::@vertices::@position) : !yasps.mat<2x3xf64>",
        "yasps.join @bunny_vertex_to_affine_body(@bunny_affine::@affine_body::"
        "@affine_matrix) : !yasps.mat<1x9xf64>",
        "yasps.union @position : !yasps.mat<3x1xf64>",
        "yasps.energy @bunnies::@pp::@point_point dynamic_instances",
        "yasps.minimize [@bunny_soft::@vertices::@position, "
        "@bunny_affine::@affine_body::@affine_matrix, "
        "@bunny_affine::@affine_body::@translation]",
    ]:
        assert fragment in printed, fragment


def test_round_trips_through_yasps_opt(example_scene, tmp_path):
    opt = yasps_opt()
    if not opt.exists():
        pytest.fail(f"yasps-opt not built at {opt}")
    source = tmp_path / "scene.mlir"
    source.write_text(example_scene.ir())
    once = subprocess.run([str(opt), str(source)], check=True,
                          capture_output=True, text=True).stdout
    twice = subprocess.run([str(opt)], input=once, check=True,
                           capture_output=True, text=True).stdout
    assert once == twice
    assert once.strip() == compiler.run_pipeline(example_scene.ir(), "").strip()


def test_inline_pipeline_runs_from_python(example_scene):
    out = compiler.run_pipeline(example_scene.ir(),
                                "yasps-inline-reads,canonicalize,cse")
    # After inlining, the barrier reads the JOIN directly and nothing else.
    barrier = out.split("yasps.attr @point_point")[1].split("yasps.yield")[0]
    assert "yasps.join @pp2v" in barrier
    assert "yasps.read" not in barrier


def test_locations_point_at_python_lines(example_scene):
    text = example_scene.ir(locations=True)
    assert 'loc("' in text and "conftest.py" in text
    compiler.verify(text)


def test_repr_shows_shapes_and_owners(example_scene):
    s = example_scene
    assert repr(s.bunnies.pp["positions"]) == (
        "<yasps.Attribute join attribute 'positions' [2x3] on primitive "
        "'bunnies.pp'>")
    d = s.bunnies.pp["positions"].row(0).dot(s.bunnies.pp["positions"].row(1))
    assert "[1x1]" in repr(d) and "'bunnies.pp'" in repr(d)
