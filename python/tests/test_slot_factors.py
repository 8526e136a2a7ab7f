"""Factored local Hessians with J taken from shared Jacobian tables
(yasps.solve.slots): the same systems as the dense and the padded factored
paths, per-instance storage independent of the widest UNION member, and one
table evaluation per source for every energy that reaches it."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import yasps
from yasps import energies as E
from yasps.runtime import SlotFactoredInputs, cpu_backend
from yasps.sim import cage_grid
from yasps.sim.bodies import add_caged_surface
from yasps.solve import assembly_inputs
from yasps.solve.assembly import assemble

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))
from benchlib.contact_scene import build  # noqa: E402

#: (separate_reduced_hessians, slot_jacobians) of the three paths.
PATHS = {"dense": (False, False), "padded": (True, False),
         "tables": (None, True)}


def system_under(scene, monkeypatch, path):
    """The assembled gradient, dense Hessian and Newton direction."""
    separate, tables = PATHS[path]
    monkeypatch.setattr(yasps.config, "separate_reduced_hessians", separate)
    monkeypatch.setattr(yasps.config, "slot_jacobians", tables)
    system = assemble(scene, cpu_backend()).system
    n = system.size
    g, H = np.zeros(n), np.zeros(n * n)
    system.gradient(g)
    system.dense(H)
    H = H.reshape(n, n)
    dx = scene.minimizeEnergy(tolerance=1e-13)
    # PCG's direction is as close to H^-1 g as H's conditioning allows.
    # (DoFs are the targets' entries column-major, instance after instance.)
    direction = np.concatenate([np.transpose(d, (0, 2, 1)).reshape(-1)
                                for d in dx])
    np.testing.assert_allclose(H @ direction, g, rtol=0,
                               atol=1e-10 * np.abs(g).max())
    return g, H, np.linalg.solve(H, g)


def assert_paths_agree(scene, monkeypatch, reference="dense"):
    """The assembled gradient, Hessian and Newton direction of the padded
    and the tables paths equal ``reference``'s to 1e-12 relative. All
    three project in the leaves' entries: projected through the pairs'
    edge vectors (``linear_map_projection``), the dense path would clamp
    another matrix where the Hessians are indefinite."""
    monkeypatch.setattr(yasps.config, "linear_map_projection", False)
    got = {p: system_under(scene, monkeypatch, p)
           for p in ("padded", "tables", reference)}
    for path in {"padded", "tables"} - {reference}:
        for name, a, b in zip(("gradient", "Hessian", "direction"),
                              got[path], got[reference]):
            assert np.abs(b).max() > 0
            np.testing.assert_allclose(a, b, rtol=0,
                                       atol=1e-12 * np.abs(b).max(),
                                       err_msg=f"{path}: {name}")


@pytest.mark.parametrize("pairs, reference", [(("pp", "pe"), "dense"),
                                              (("pt", "ee"), "padded")])
def test_contact_pairs_on_a_soft_and_affine_union(monkeypatch, pairs,
                                                   reference):
    """PP, PE, PT and EE barriers over soft and affine-body vertices: PP
    and PE against the dense local Hessians, PT and EE against the padded
    factors (whose agreement with the dense path the PP and PE case shows;
    dense, their 48 x 48 Hessians take a minute to compile)."""
    scene, *_ = build(pairs=30, cells=2, pair_types=pairs)
    assert_paths_agree(scene, monkeypatch, reference)
    # By default (the cost rule and tables on), every pair energy uses the
    # tables.
    monkeypatch.setattr(yasps.config, "separate_reduced_hessians", None)
    monkeypatch.setattr(yasps.config, "slot_jacobians", True)
    for energy in scene.energies[-2:]:
        inputs, _ = assembly_inputs(scene, energy, cpu_backend())
        assert isinstance(inputs, SlotFactoredInputs)


def caged_union_scene():
    """A UNION of soft vertices, an affine body's vertices, points trilinear
    in a cage (a JOIN of 8 cage corners behind each) and a static obstacle
    (a constant, no parameters), with PT pairs across all four and an
    energy on the union itself (UNION slots, not JOIN ones)."""
    rng = np.random.default_rng(2)
    s = yasps.scene("caged")
    soft = s.addMesh("soft").addPrimitive("v", numInstances=4)
    xs = soft.addAttribute("x", rows=3)
    xs.updateValue(rng.normal(size=(4, 3)))
    rigid = s.addMesh("rigid")
    body = rigid.addPrimitive("body", numInstances=1)
    A = body.addAttribute("A", rows=3, cols=3)
    A.updateValue(np.eye(3) + rng.normal(scale=0.05, size=(3, 3)))
    t = body.addAttribute("t", rows=3)
    t.updateValue([0.0, 0.0, 2.0])
    rv = rigid.addPrimitive("v", numInstances=4)
    rv.addConstant("rest", rows=3).updateValue(rng.normal(size=(4, 3)))
    v2b = rv.addConnectivity("v2b", body, [0] * 4, 1)
    rv.addAttribute("x", computed_attribute=rv.addAttribute(
        "A", through=v2b, source=A).resize(3, 3) * rv["rest"]
        + rv.addAttribute("t", through=v2b, source=t).resize(3, 1))
    cage_mesh = s.addMesh("cage")
    points = rng.random((5, 3)) * 0.9 + [0.0, 0.0, -3.0]
    cage = cage_grid(points, 1)
    corners = cage_mesh.addPrimitive("c", numInstances=len(cage.vertices))
    cx = corners.addAttribute("x", rows=3)
    cx.updateValue(cage.vertices + rng.normal(scale=0.01,
                                              size=cage.vertices.shape))
    surface = add_caged_surface(cage_mesh, cx, cage)
    surface.addAttribute("x", computed_attribute=surface["position"])
    wall = s.addMesh("wall").addPrimitive("v", numInstances=3)
    wall.addConstant("x", rows=3).updateValue(rng.normal(size=(3, 3)) + 4.0)
    world = s.addMesh("world")
    union = world.addPrimitiveUnion("v", [soft, rv, surface, wall])
    ux = union.addAttribute("x")
    pt = world.addPrimitive("pt", numInstances=24, isDynamic=True)
    tuples = np.argsort(rng.random((24, 16)), axis=1)[:, :4]
    c = pt.addConnectivity("c", union, tuples, 4)
    x = pt.addAttribute("x", through=c, source=ux)
    d2 = E.point_triangle_distance2(*[x.row(k).T for k in range(4)])
    s.addEnergy(pt.addAttribute("b", computed_attribute=E.ipc_barrier(
        0.05 * d2, 1.0, 1.0)), dynamic_instances=True)
    # Quartic in the world positions: a Hessian that is not the identity.
    s.addEnergy(union.addAttribute("well", computed_attribute=(
        ux.squaredNorm() - 1.0) * (ux.squaredNorm() - 1.0)))
    soft.addConstant("x_hat", rows=3).updateValue(xs.value[:, :, 0])
    s.addEnergy(soft.addAttribute("inertia", computed_attribute=E.inertia(
        xs, soft["x_hat"], 1.0)))
    s.addEnergy(body.addAttribute("orth", computed_attribute=
                                  E.abd_orthogonality(A, 1.0)
                                  + 0.5 * (A - np.eye(3)).squaredNorm()
                                  + 0.5 * t.squaredNorm()))
    corners.addConstant("x_hat", rows=3).updateValue(cx.value[:, :, 0])
    s.addEnergy(corners.addAttribute("inertia", computed_attribute=E.inertia(
        cx, corners["x_hat"], 1.0)))
    s.addMinimizeTarget([xs, A, t, cx])
    return s


def test_cages_obstacles_and_union_slots(monkeypatch):
    """Against the padded per-instance J: the dense path would compile a
    96 x 96 point-triangle Hessian for minutes (the reason for factors)."""
    s = caged_union_scene()
    assert_paths_agree(s, monkeypatch, reference="padded")
    monkeypatch.setattr(yasps.config, "separate_reduced_hessians", True)
    monkeypatch.setattr(yasps.config, "slot_jacobians", True)
    for energy in s.energies[:2]:
        inputs, _ = assembly_inputs(s, energy, cpu_backend())
        assert isinstance(inputs, SlotFactoredInputs)


def test_storage_does_not_grow_with_the_widest_member(monkeypatch):
    """Per PT pair, the tables path stores the 12 inner gradient entries
    and the 12 x 12 P, whether the UNION's widest member has 12 parameters
    per vertex (affine) or 24 (a cage cell's 8 corners); the padded J
    grows with it."""
    monkeypatch.setattr(yasps.config, "separate_reduced_hessians", True)
    stored = {}
    for name, scene in (("affine", build(pairs=8)[0]),
                        ("cage", caged_union_scene())):
        pt = next(e for e in scene.energies if e.owner.name == "pt")
        monkeypatch.setattr(yasps.config, "slot_jacobians", True)
        tables, _ = assembly_inputs(scene, pt, cpu_backend())
        monkeypatch.setattr(yasps.config, "slot_jacobians", False)
        padded, _ = assembly_inputs(scene, pt, cpu_backend())
        m = tables.inner_size
        assert tables.gradient.size == tables.count * m
        assert tables.inner_hessian.size == tables.count * m * m
        stored[name] = (tables.slot_factors.stored_per_instance(m),
                        padded.inner_map.size // padded.count)
    assert stored["affine"][0] == stored["cage"][0] == 12 + 144
    assert stored["affine"][1] == 12 * 48 and stored["cage"][1] == 12 * 96


def test_each_table_is_evaluated_once_per_assembly(monkeypatch):
    """The four pair energies reach the affine body's vertices: its
    Jacobian kernel runs once per assembly, whatever reads it."""
    scene, *_ = build(pairs=10)
    backend = cpu_backend()
    runs = []
    original = type(backend).run

    def counting(self, kernels, scene_, path, *args, **kwargs):
        runs.append(path)
        return original(self, kernels, scene_, path, *args, **kwargs)

    monkeypatch.setattr(type(backend), "run", counting)
    assemble(scene, backend)
    assert runs.count("@rigid::@v::@x__jac") == 1
    assert not any(p.endswith("__ij") for p in runs)


def test_a_slot_outside_its_table_is_an_error():
    """A reference past a table's rows is caught by the runtime before any
    arithmetic."""
    scene, *_ = build(pairs=2)
    pe = next(e for e in scene.energies if e.owner.name == "pe")
    inputs, _ = assembly_inputs(scene, pe, cpu_backend())
    system = assemble(scene, cpu_backend()).system
    factors = inputs.slot_factors
    factors.sources[0, 0, 1] = 10 ** 6
    # Static energies come first in the system, then the dynamic ones.
    order = sorted(scene._energies, key=lambda entry: entry[1])
    index = [e for e, _, _ in order].index(pe)
    with pytest.raises(ValueError, match="row 1000000 of a Jacobian table"):
        yasps.runtime.cpu.add_host_arrays(system, index, inputs, (1,))
