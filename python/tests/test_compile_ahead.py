"""Time to first frame: cache keys that name only what is compiled,
building without compiling, and ``yasps.compile`` with its summary and the
stepping helpers' ``compile`` stage."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import Tuple

import numpy as np
import pytest

import yasps
from yasps.compiler import invocations
from yasps.compiler.cpu import kernels_compiled
from yasps.ir import kernel_ir
from yasps.sim import (ImplicitEuler, add_affine_body, add_elastic_tets,
                       add_free_vertices, box_tet_mesh, lumped_masses)

REPO = Path(__file__).resolve().parents[2]

#: A soft box and an affine box, built as a user's script would; prints the
#: kernels this process compiled. ``{prefix}`` is replaced by lines placed
#: above the scene code.
SCRIPT = """\
{prefix}
import sys
sys.path.insert(0, {python!r})
import numpy as np
import yasps
from yasps.compiler.cpu import kernels_compiled, requests_lowered
from yasps.sim import (add_affine_body, add_elastic_tets, add_free_vertices,
                       box_tet_mesh, lumped_masses)

verts, tets = box_tet_mesh(1, size=0.2)
masses = lumped_masses(verts, tets, 100.0)
s = yasps.scene("edited")
soft = s.addMesh("soft")
b = add_free_vertices(soft, verts, masses)
add_elastic_tets(soft, b.x, verts, tets, 1e4, 4e4, scale=1e-4)
body = add_affine_body(s.addMesh("rigid"), verts + 1.0, masses,
                       stiffness=1e3, scale=1e-4)
s.addMinimizeTarget([b.x, body.A, body.t])
yasps.compile(s, progress=False)
s.minimizeEnergy()
s.evaluateEnergy()
print(kernels_compiled(), requests_lowered())
"""


def _run(path: Path, cache: Path, profiled: bool = False) -> Tuple[int, int]:
    """Runs the script; returns the kernels it compiled and the compile
    requests that parsed and lowered the scene."""
    command = [sys.executable] + (["-m", "cProfile", "-o", os.devnull]
                                  if profiled else []) + [str(path)]
    env = dict(os.environ, YASPS_CACHE_DIR=str(cache))
    done = subprocess.run(command, env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    compiled, lowered = done.stdout.split()[-2:]
    return int(compiled), int(lowered)


def test_an_edited_renamed_or_profiled_script_compiles_nothing(tmp_path):
    """The kernels of a script's scene are found again by a second process
    after lines and comments were inserted above the scene code and the
    file renamed, and by a third under cProfile: source locations are no
    part of any cache key, and nothing is even parsed. Before, the IR that
    keys the request records carried each attribute's file and line: the
    kernels were found on disk, but only after every request had parsed,
    differentiated and lowered the scene again (33 s instead of 1 s for
    the first steps of a three-body contact scene)."""
    cache = tmp_path / "cache"
    first = tmp_path / "scene.py"
    first.write_text(SCRIPT.format(prefix="", python=str(REPO / "python")))
    assert _run(first, cache)[0] > 0
    edited = tmp_path / "renamed_scene.py"
    prefix = "# A comment first.\n\n" + "x = 1  # and a line of code\n" * 7
    edited.write_text(SCRIPT.format(prefix=prefix,
                                    python=str(REPO / "python")))
    first.unlink()
    assert _run(edited, cache) == (0, 0)
    assert _run(edited, cache, profiled=True) == (0, 0)


def _soft_box(name: str, line_offset: bool = False):
    verts, tets = box_tet_mesh(1, size=0.2)
    s = yasps.scene(name)
    soft = s.addMesh("soft")
    if line_offset:
        b = add_free_vertices(soft, verts, 1.0)
    else:
        b = add_free_vertices(
            soft, verts, 1.0)
    add_elastic_tets(soft, b.x, verts, tets, 1e4, 4e4, scale=1e-4)
    s.addMinimizeTarget([b.x])
    return s, b


def test_kernel_ir_keeps_locations_apart():
    """Two scenes built on different lines have the same kernel IR text
    (what caches are keyed by) and different location definitions, which
    the compiler still parses for its diagnostics."""
    one, _ = _soft_box("located")
    two, _ = _soft_box("located", line_offset=True)
    a, b = kernel_ir(one), kernel_ir(two)
    assert str(a) == str(b)
    assert a.locations != b.locations
    assert "test_compile_ahead.py" in a.locations
    assert "loc(#loc" in str(a) and "test_compile_ahead.py" not in str(a)


def test_an_energy_that_cannot_be_differentiated_is_reported_with_its_line():
    """Building verifies; differentiation comes with the first compilation,
    whose error still names the user's file."""
    s = yasps.scene("p")
    prim = s.addMesh("m").addPrimitive("p", numInstances=1)
    h = prim.addAttribute("h", rows=2, cols=2)
    h.updateValue(np.eye(2).reshape(1, 2, 2))
    e = prim.addAttribute("e", computed_attribute=h.project().trace())
    s.addEnergy(e)
    s.addMinimizeTarget([h])
    with pytest.raises(yasps.IRError,
                       match="(?s)test_compile_ahead.py.*PSD projection "
                             "applies to derivatives"):
        yasps.compile(s, progress=False)
    with pytest.raises(yasps.IRError, match="PSD projection applies"):
        s.minimizeEnergy()


def test_building_a_contact_scene_asks_the_compiler_only_to_verify():
    """Building (contact and friction included) parses and verifies the
    scene once per addMinimizeTarget and differentiates nothing: the
    derivatives come with the first compilation. Before, each
    addMinimizeTarget ran the differentiation pipeline on the whole scene
    (1.4 s for three bodies of 200 vertices)."""
    from yasps.contact import Contact, surface_of
    before = invocations()
    verts, tets = box_tet_mesh(1, size=0.2)
    masses = lumped_masses(verts, tets, 100.0)
    s = yasps.scene("built")
    b = add_free_vertices(s.addMesh("soft"), verts, masses)
    add_elastic_tets(s.soft, b.x, verts, tets, 1e4, 4e4, scale=1e-4)
    body = add_affine_body(s.addMesh("rigid"), verts + 0.5, masses,
                           stiffness=1e3, scale=1e-4)
    union = s.addMesh("all").addPrimitiveUnion("v", [b.primitive,
                                                     body.vertices])
    union.addAttribute("position")
    faces = surface_of(tets)
    Contact(s, union, faces=np.concatenate([faces, faces + len(verts)]),
            dhat=1e-3, kappa=1.0, friction=0.2)
    s.addMinimizeTarget([b.x, body.A, body.t])
    after = invocations()
    asked = {k: after.get(k, 0) - before.get(k, 0) for k in after}
    # Contact computes the world positions of its collision mesh: one
    # kernel without derivatives.
    assert {k: n for k, n in asked.items() if n} == {"verify": 1,
                                                     "compile_cpu": 1}


def test_compile_makes_every_kernel_of_a_newton_step():
    """yasps.compile compiles what evaluating the energy and assembling the
    Newton system need; its summary counts them; a second call finds them
    all in memory; the steps after it compile nothing, and their reports
    time the compiling (here only the check) as ``compile`` alone."""
    verts, tets = box_tet_mesh(1, size=0.2)
    s = yasps.scene("ahead")
    soft = s.addMesh("soft")
    b = add_free_vertices(soft, verts + [0, 0, 1], 1.0)
    add_elastic_tets(soft, b.x, verts, tets, 1e4, 4e4, scale=1e-4)
    s.addMinimizeTarget([b.x])
    first = yasps.compile(s, progress=False)
    # Values of inertia and elasticity; their gradient, projected Hessian
    # (elasticity's unprojected one for compression) and placements.
    assert first.kernels >= 8
    assert first.compiled + first.loaded == first.kernels
    again = yasps.compile(s, progress=False)
    assert (again.kernels, again.compiled) == (first.kernels, 0)
    count, asked = kernels_compiled(), invocations()
    stepper = ImplicitEuler(s, b.x, b.x_hat, dt=0.01)
    report = stepper.step()
    s.evaluateEnergy()
    assert kernels_compiled() == count
    assert invocations().get("compile_cpu", 0) == asked.get("compile_cpu", 0)
    assert "compile" in report.seconds and report.iterations > 0
    total = stepper.run(2, progress=False)
    assert total.seconds["compile"] > 0


def test_a_hundred_frames_with_friction_and_forces_ask_the_compiler_nothing():
    """After the stepper's compile stage, 100 frames of a cloth draped on a
    box with friction, reading the contact forces at every frame, make no
    request of the compiler: the per-size projections that progressive
    projection meets when it first re-projects (frame 22 here) and the
    force queries' kernels were compiled with the scene. Every frame is
    checked for intersections by ipctk on a mesh of its own."""
    import ipctk

    sys.path.insert(0, str(REPO / "examples"))
    import cloth_drape

    drape = cloth_drape.build()
    stepper = drape.stepper()
    stepper.run(1, progress=False)
    asked = dict(invocations())
    V = drape.contact.world()
    mesh = ipctk.CollisionMesh(
        V, ipctk.edges(drape.faces), drape.faces)
    reprojected = 0
    for _ in range(99):
        report = stepper.step(warn=False)
        assert report.converged
        reprojected += report.projection_retries
        forces = drape.contact.forces()
        assert np.isfinite(forces).all()
        assert not ipctk.has_intersections(mesh, drape.contact.world())
    # The run did meet what used to compile while stepping.
    assert reprojected > 0 and np.abs(forces).max() > 0
    assert invocations() == asked


def test_compile_rejects_attributes_of_another_scene():
    one, _ = _soft_box("one")
    _, b = _soft_box("two")
    with pytest.raises(yasps.SceneError, match="not an attribute of scene"):
        yasps.compile(one, also=[b.x], progress=False)



def test_kernel_ir_is_emitted_again_only_when_the_scene_changes():
    """The line search and collision detection evaluate a scene many times
    a Newton iteration: its kernel IR is emitted once per structure, and
    every change of what the IR says (an attribute, a primitive, a
    connectivity, an energy, a target) emits it anew."""
    s, b = _soft_box("changing")
    first = kernel_ir(s)
    assert kernel_ir(s) is first
    assert kernel_ir(s, precision="f32") is not first
    prim = s.soft.v
    changes = [
        lambda: prim.addConstant("c", rows=1),
        lambda: s.soft.addPrimitive("q", numInstances=2),
        lambda: s.soft.q.addConnectivity("q2v", prim, [[0], [1]], 1),
        lambda: s.addEnergy(prim.addAttribute(
            "e2", computed_attribute=prim["c"] * b.x.squaredNorm())),
        lambda: s.addMinimizeTarget([prim.addAttribute("y", rows=1)]),
    ]
    for change in changes:
        before = kernel_ir(s)
        change()
        after = kernel_ir(s)
        assert after != before and kernel_ir(s) is after
    # Values and dynamic counts are no part of it.
    b.x.updateValue(b.x.value + 1.0)
    assert kernel_ir(s) is after
