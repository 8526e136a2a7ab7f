"""yasps.contact: IPC's barrier over ipctk's collision sets, as yasps
energies on dynamic pair primitives, against ipctk's BarrierPotential; the
chain rule through affine bodies; short drops checked for intersections by
ipctk, independently of the layer."""

import ipctk
import numpy as np
import pytest

import yasps
from yasps import energies as E
from yasps.contact import Contact, surface_of
from yasps.runtime import cpu_backend
from yasps.sim import (ImplicitEuler, add_affine_inertia, add_elastic_tets,
                       box_tet_mesh)
from yasps.solve import assemble

from conftest import ipctk_collisions

VERTS, TETS = box_tet_mesh(2, 0.5)
FACES = surface_of(TETS)


def rotation(angle: float, axis) -> np.ndarray:
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.cross(np.eye(3), axis)
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def system_arrays(scene):
    """The assembled gradient and dense Hessian."""
    system = assemble(scene, cpu_backend()).system
    g = np.empty(system.size)
    H = np.empty((system.size, system.size))
    system.gradient(g)
    system.dense(H)
    return g, H


def two_soft_boxes(name: str, lower: np.ndarray, upper: np.ndarray):
    """A scene with two boxes of free vertices at ``lower`` and ``upper``
    and the UNION of their vertices: (scene, primitives, positions,
    union)."""
    s = yasps.scene(name)
    prims, positions = [], []
    for mesh, start in (("a", lower), ("b", upper)):
        v = s.addMesh(mesh).addPrimitive("v", numInstances=len(start))
        x = v.addAttribute("position", rows=3)
        x.updateValue(start)
        prims.append(v)
        positions.append(x)
    union = s.addMesh("w").addPrimitiveUnion("v", prims)
    union.addAttribute("position")
    return s, prims, positions, union


def relative(a, b) -> float:
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


@pytest.mark.parametrize("cells, angle, axis, gap, dhat, projection, linear_maps", [
    (2, 0.0, [1, 2, 0.5], 0.02, 0.05, "none", True),
    (2, 0.3, [1, 2, 0.5], 0.02, 0.05, "none", True),
    # Points whose closest point on an edge lies at its end: ipctk keeps
    # them point-edge pairs (its known type), whose Hessian differs from the
    # point-point one there. The boxes turn about their common vertical
    # axis, so a vertex sits exactly over another: closest-feature types
    # tie, and the runtime's detection may split them otherwise than
    # ipctk's (same energy, other Hessians: test_contact_detection.py), so
    # these two take ipctk's detection, whose pairs this test checks.
    (4, 0.3, [0, 0, 1], 0.012, 0.02, "clamp", False),
    (4, 0.3, [0, 0, 1], 0.012, 0.02, "clamp", True),
])
def test_barrier_matches_ipctk(cells, angle, axis, gap, dhat, projection,
                               linear_maps, monkeypatch):
    """Two soft boxes within dhat: axis-aligned (parallel edges: mollified
    edge-edge pairs, end-point types) and turned (generic pairs). Energy,
    gradient and Hessian (unprojected, or projected per pair) equal ipctk's
    BarrierPotential on the same collision set. ipctk clamps each pair's
    full Hessian, as yasps does without ``linear_map_projection``; with it
    (the default), yasps clamps the Hessian in the pair's edge vectors
    instead, whose result is PSD and lies above the unprojected Hessian."""
    monkeypatch.setattr(yasps.config, "linear_map_projection", linear_maps)
    verts, tets = box_tet_mesh(cells, 0.5)
    faces = surface_of(tets)
    turned = (verts - 0.25) @ rotation(angle, axis).T + 0.25
    lift = 0.5 - turned[:, 2].min() + gap
    s, _, (xa, xb), union = two_soft_boxes(
        "pair", verts, turned + ([0.1, 0.05, lift] if cells == 2 else
                                 [0.0, 0.0, lift]))
    contact = Contact(s, union, faces=np.concatenate([faces, faces + len(verts)]),
                      dhat=dhat, kappa=3.0, projection=projection,
                      detection="ipctk" if cells == 4 else "runtime")
    s.addMinimizeTarget([xa, xb])
    counts = contact.update()
    assert sum(counts.values()) > 0
    if angle == 0.0:
        assert counts["ee"] + counts["ee_ev"] + counts["ee_vv"] > 0
    V = contact.world()
    collisions = ipctk_collisions(contact, V)
    potential = ipctk.BarrierPotential(dhat, 3.0)
    want = potential(collisions, contact.mesh, V)
    assert abs(s.evaluateEnergy() - want) <= 1e-10 * abs(want)
    g, H = system_arrays(s)
    assert relative(g, potential.gradient(collisions, contact.mesh, V)) < 1e-10
    method = ipctk.PSDProjectionMethod.NONE if projection == "none" else \
        ipctk.PSDProjectionMethod.CLAMP
    reference = potential.hessian(collisions, contact.mesh, V,
                                  project_hessian_to_psd=method).toarray()
    if projection == "none" or not linear_maps:
        assert relative(H, reference) < 1e-10
        return
    unprojected = potential.hessian(collisions, contact.mesh, V).toarray()
    scale = np.abs(reference).max()
    assert np.linalg.eigvalsh(H).min() >= -1e-10 * scale
    assert np.linalg.eigvalsh(H - unprojected).min() >= -1e-10 * scale
    assert relative(H, reference) > 1e-6, "the pairs need indefinite Hessians"


def soft_and_affine(scene, lift: float, kappa: float, projection="clamp",
                    friction: float = 0.0):
    """A soft box and, above it, an affine box (x = A rest + t), their
    vertices in one UNION with contact; returns the targets, the affine
    box's rest positions and the contact."""
    soft = scene.addMesh("soft").addPrimitive("v", numInstances=len(VERTS))
    xs = soft.addAttribute("position", rows=3)
    xs.updateValue(VERTS)
    rigid = scene.addMesh("rigid")
    body = rigid.addPrimitive("body", numInstances=1)
    A = body.addAttribute("A", rows=3, cols=3)
    A.updateValue(rotation(0.2, [0.3, 1, 0]))
    t = body.addAttribute("t", rows=3)
    t.updateValue([0.05, 0.02, lift])
    rv = rigid.addPrimitive("v", numInstances=len(VERTS))
    rest = VERTS - 0.25
    rv.addConstant("rest", rows=3).updateValue(rest)
    link = rv.addConnectivity("v2b", body, [0] * len(VERTS), 1)
    rv.addAttribute("position", computed_attribute=rv.addAttribute(
        "A", through=link, source=A).resize(3, 3) * rv["rest"] + rv.addAttribute(
        "t", through=link, source=t).resize(3, 1))
    union = scene.addMesh("w").addPrimitiveUnion("v", [soft, rv])
    union.addAttribute("position")
    contact = Contact(scene, union, faces=np.concatenate(
        [FACES, FACES + len(VERTS)]), dhat=0.05, kappa=kappa,
        projection=projection, friction=friction, eps_v=0.1)
    return (xs, A, t), rest, contact


def test_affine_body_gets_the_chain_rule_of_the_soft_derivatives():
    """Through the UNION, the gradient and Hessian of barrier and friction
    with respect to the soft positions, A and t are J^T g and J^T H J of
    ipctk's BarrierPotential + FrictionPotential on the world positions, J
    the (linear) map from the targets to them (friction lagged at the start,
    then the affine box moved)."""
    s = yasps.scene("mixed")
    (xs, A, t), rest, contact = soft_and_affine(s, 0.79, 2.0, "none",
                                                friction=0.4)
    s.addMinimizeTarget([xs, A, t])
    counts = contact.update(lag=True, dt=0.01)
    assert sum(counts[f"friction{k}"] for k in (2, 3, 4)) > 0
    Vt = contact.world()
    tangential = ipctk.TangentialCollisions()
    potential = ipctk.BarrierPotential(0.05, 2.0)
    tangential.build(contact.mesh, Vt, ipctk_collisions(contact, Vt),
                     potential, 0.4)
    t.updateValue(t.value + [[[2e-3], [-1e-3], [1e-4]]])
    A.updateValue(A.value @ rotation(1e-3, [0, 0, 1]))
    assert sum(contact.update().values()) > 0
    V = contact.world()
    collisions = ipctk_collisions(contact, V)
    friction = ipctk.FrictionPotential(0.1 * 0.01)
    none = ipctk.PSDProjectionMethod.NONE
    gw = potential.gradient(collisions, contact.mesh, V) + \
        friction.gradient(tangential, contact.mesh, V - Vt)
    Hw = (potential.hessian(collisions, contact.mesh, V,
                            project_hessian_to_psd=none)
          + friction.hessian(tangential, contact.mesh, V - Vt,
                             project_hessian_to_psd=none)).toarray()
    n = len(VERTS)
    J = np.zeros((6 * n, 3 * n + 12))
    J[:3 * n, :3 * n] = np.eye(3 * n)
    for i, r in enumerate(rest):
        for row in range(3):
            world = 3 * (n + i) + row
            for col in range(3):
                # A's DoFs are column-major: entry (row, col) at col*3 + row.
                J[world, 3 * n + col * 3 + row] = r[col]
            J[world, 3 * n + 9 + row] = 1.0
    g, H = system_arrays(s)
    assert relative(g, J.T @ gw) < 1e-10
    assert relative(H, J.T @ Hw @ J) < 1e-10


def no_intersections(mesh: ipctk.CollisionMesh, V: np.ndarray) -> bool:
    return not ipctk.has_intersections(mesh, V)


def test_soft_box_falls_on_an_affine_box():
    """Implicit Euler over the soft positions, A and t with contact: the
    soft box falls onto the affine box (no gravity on it, inertia on A and
    t, orthogonality); every frame is free of intersections (ipctk, on a
    mesh of its own), every accepted Newton step lowers the energy, and
    nothing is NaN. The boxes come within dhat and push each other."""
    dt = 0.01
    s = yasps.scene("fall")
    (xs, A, t), rest, contact = soft_and_affine(s, -0.3, 50.0)
    soft = s.soft.v
    add_elastic_tets(s.soft, xs, VERTS, TETS, 1e4, 4e4, scale=dt * dt)
    xs.updateValue(VERTS + [0.0, 0.0, 0.56])
    x_hat = soft.addConstant("x_hat", rows=3)
    s.addEnergy(soft.addAttribute("inertia", computed_attribute=E.inertia(
        xs, x_hat, 0.5)))
    body = s.rigid.body
    A_hat = body.addConstant("A_hat", rows=3, cols=3)
    t_hat = body.addConstant("t_hat", rows=3)
    s.addEnergy(body.addAttribute("inertia", computed_attribute=E.inertia(
        A, A_hat, 5.0) + E.inertia(t, t_hat, 5.0)))
    s.addEnergy(body.addAttribute("orth", computed_attribute=
                                  E.abd_orthogonality(A, 100.0)))
    t.updateValue([0.25, 0.25, 0.25])
    s.addMinimizeTarget([xs, A, t])
    checker = ipctk.CollisionMesh(contact.world(), contact.mesh.edges,
                                  contact.mesh.faces)
    assert no_intersections(checker, contact.world())
    stepper = ImplicitEuler(s, [xs, A, t], [x_hat, A_hat, t_hat], dt,
                            gravity=[(0, 0, -9.81), None, None], contact=contact)
    closest = np.inf
    for _ in range(12):
        report = stepper.step()
        V = contact.world()
        assert np.isfinite(V).all()
        assert no_intersections(checker, V)
        assert all(after <= before for before, after in report.step_energies)
        assert report.iterations > 0
        closest = min(closest, contact.min_distance())
    assert closest < 0.05
    # The affine box was pushed down by the contact.
    assert t.value[0, 2, 0] < 0.25


def test_adaptive_stiffness_is_ipctks():
    """Without a fixed kappa, the initial stiffness is ipctk's
    initial_barrier_stiffness from the other energies' gradient and the
    barrier's (here both on free vertices, computed independently: the
    inertia's m (x - x_hat) and ipctk's BarrierPotential); changing it
    compiles nothing."""
    s, (a, b), (xa, xb), union = two_soft_boxes(
        "adaptive", VERTS, VERTS + [0.1, 0.05, 0.52])
    hats = []
    for prim, x in ((a, xa), (b, xb)):
        hat = prim.addConstant("x_hat", rows=3)
        hat.updateValue(x.value[:, :, 0] + [0.0, 0.0, -0.01])
        s.addEnergy(prim.addAttribute("inertia", computed_attribute=E.inertia(
            x, hat, 0.3)))
        hats.append(hat)
    contact = Contact(s, union, faces=np.concatenate([FACES, FACES + len(VERTS)]),
                      dhat=0.05, average_mass=0.3)
    s.addMinimizeTarget([xa, xb])
    assert sum(contact.update().values()) > 0
    kappa = contact.adapt_stiffness()
    V = contact.world()
    inertia = 0.3 * (V - np.concatenate([h.value[:, :, 0] for h in hats]))
    barrier = ipctk.BarrierPotential(0.05, 1.0).gradient(
        ipctk_collisions(contact, V), contact.mesh, V)
    diagonal = np.linalg.norm(V.max(axis=0) - V.min(axis=0))
    want, _ = ipctk.initial_barrier_stiffness(
        diagonal, ipctk.ClampedLogBarrier(), 0.05, 0.3, inertia.reshape(-1),
        barrier)
    assert kappa > 0 and abs(kappa - want) <= 1e-12 * want
    assert contact.kappa == kappa
    before = yasps.compiler.invocations()
    contact.adapt_stiffness()
    s.minimizeEnergy()
    assert yasps.compiler.invocations() == before
    with pytest.raises(ValueError, match="average vertex mass"):
        Contact(s, union, faces=FACES, name="other")


def test_contact_checks_its_inputs():
    s = yasps.scene("bad")
    v = s.addMesh("m").addPrimitive("v", numInstances=4)
    v.addAttribute("x", rows=3).updateValue(np.eye(4, 3))
    with pytest.raises(yasps.SceneError, match="has no attribute 'position'"):
        Contact(s, v, faces=[[0, 1, 2]])
    with pytest.raises(yasps.SceneError, match="faces index vertices outside"):
        Contact(s, v, faces=[[0, 1, 7]], position="x", kappa=1.0)
    with pytest.raises(ValueError, match="dhat must be > 0"):
        Contact(s, v, faces=[[0, 1, 2]], position="x", dhat=0.0)


def test_affine_inertia_is_the_vertices_inertia():
    """add_affine_inertia (mass moments on the body) gives the same energy,
    gradient and Hessian in A and t as the vertices' own inertia
    sum m_i/2 |x_i - x_hat_i|^2 through x = A r + t."""
    rng = np.random.default_rng(4)
    masses = rng.uniform(0.5, 2.0, len(VERTS))
    A0, t0 = rotation(0.4, [1, 0, 1]), np.array([0.1, -0.2, 0.3])
    A1 = A0 + rng.normal(scale=0.05, size=(3, 3))
    t1 = t0 + rng.normal(scale=0.05, size=3)

    def scene(moments: bool):
        s = yasps.scene("inertia")
        mesh = s.addMesh("r")
        body = mesh.addPrimitive("body", numInstances=1)
        A = body.addAttribute("A", rows=3, cols=3)
        A.updateValue(A1)
        t = body.addAttribute("t", rows=3)
        t.updateValue(t1)
        A_hat = body.addConstant("A_hat", rows=3, cols=3)
        A_hat.updateValue(A0)
        t_hat = body.addConstant("t_hat", rows=3)
        t_hat.updateValue(t0)
        if moments:
            add_affine_inertia(body, A, t, A_hat, t_hat, VERTS, masses)
        else:
            v = mesh.addPrimitive("v", numInstances=len(VERTS))
            v.addConstant("rest", rows=3).updateValue(VERTS)
            v.addConstant("m", rows=1).updateValue(masses[:, None])
            link = v.addConnectivity("v2b", body, [0] * len(VERTS), 1)
            joined = [v.addAttribute(n, through=link, source=src)
                      for n, src in (("A", A), ("t", t), ("A_hat", A_hat),
                                     ("t_hat", t_hat))]
            x = joined[0].resize(3, 3) * v["rest"] + joined[1].resize(3, 1)
            x_hat = joined[2].resize(3, 3) * v["rest"] + joined[3].resize(3, 1)
            s.addEnergy(v.addAttribute("inertia", computed_attribute=0.5 *
                                       v["m"] * (x - x_hat).squaredNorm()))
        s.addMinimizeTarget([A, t])
        return s

    fast, slow = scene(True), scene(False)
    assert abs(fast.evaluateEnergy() - slow.evaluateEnergy()) <= \
        1e-12 * slow.evaluateEnergy()
    for a, b in zip(system_arrays(fast), system_arrays(slow)):
        assert relative(a, b) < 1e-12
    with pytest.raises(ValueError, match="masses for"):
        add_affine_inertia(fast.r.body, fast.r.body["A"], fast.r.body["t"],
                           fast.r.body["A_hat"], fast.r.body["t_hat"],
                           VERTS, masses[:3], name="other")


def test_stiffness_doubles_while_surfaces_close_below_a_tenth_of_dhat():
    """kappa doubles, up to its bound, only while the closest distance
    keeps shrinking below dhat / 10 (ipctk's update rule at that distance;
    IPC's default, 1e-9 of the diagonal, would leave it unchanged here)."""
    from yasps.contact.stiffness import CLOSE_FRACTION, AdaptiveStiffness
    dhat, diagonal = 1e-3, 1.0
    stiffness = AdaptiveStiffness(dhat, average_mass=1e-3)
    stiffness.kappa, stiffness.max_kappa = 10.0, 35.0
    close = CLOSE_FRACTION * dhat
    kappas = [stiffness.update(d * d, diagonal) for d in
              (2 * close, 0.9 * close, 0.5 * close, 0.6 * close, 0.4 * close,
               0.3 * close, 0.2 * close)]
    assert kappas == [10.0, 10.0, 20.0, 20.0, 35.0, 35.0, 35.0]
    assert ipctk.update_barrier_stiffness(
        (0.5 * close) ** 2, (0.4 * close) ** 2, 35.0, 10.0, diagonal) == 10.0
