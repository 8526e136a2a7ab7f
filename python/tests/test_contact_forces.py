"""Contact forces out: Contact.forces gives minus the gradient of the
barrier and of the lagged friction with respect to each vertex's world
position, equal to ipctk's BarrierPotential and FrictionPotential gradients
whether the vertices are free or an affine body's; summed over a box at
rest on the ground they carry its weight."""

import ipctk
import numpy as np
import pytest

import yasps
from yasps import SceneError
from yasps.contact import Contact, surface_of
from yasps.sim import (ImplicitEuler, add_affine_body, add_free_vertices,
                       box_tet_mesh, lumped_masses)

from test_contact import relative, rotation


def box_over_box(name: str, affine: bool):
    """A box of free vertices and, 0.02 above it and turned, a box of free
    vertices or an affine body: (scene, contact, upper targets, lower and
    upper rest vertices)."""
    verts, tets = box_tet_mesh(2, 0.5)
    faces = surface_of(tets)
    turned = (verts - 0.25) @ rotation(0.3, [1, 2, 0.5]).T + 0.25
    upper = turned + [0.1, 0.05, 0.5 - turned[:, 2].min() + 0.02]
    s = yasps.scene(name)
    masses = lumped_masses(verts, tets, 1000.0)
    lower = add_free_vertices(s.addMesh("a"), verts, masses)
    if affine:
        body = add_affine_body(s.addMesh("b"), upper, masses, 1e4)
        prims, targets = [lower.primitive, body.vertices], [body.A, body.t]
    else:
        free = add_free_vertices(s.addMesh("b"), upper, masses)
        prims, targets = [lower.primitive, free.primitive], [free.x]
    union = s.addMesh("w").addPrimitiveUnion("v", prims)
    union.addAttribute("position")
    s.addMinimizeTarget([lower.x] + targets)
    contact = Contact(s, union, faces=np.concatenate(
        [faces, faces + len(verts)]), dhat=0.05, kappa=3.0,
        friction=0.3, eps_v=0.1)
    return s, contact, targets


@pytest.mark.parametrize("affine", [False, True])
def test_forces_equal_ipctk_gradients(affine):
    """Normal and friction forces, per vertex and per body, against
    ipctk's potentials on the same collision and tangential sets (the
    friction lagged at the start, then the upper body moved a little)."""
    s, contact, targets = box_over_box(f"forces_{int(affine)}", affine)
    dt, dhat, kappa, mu, eps_v = 0.01, 0.05, 3.0, 0.3, 0.1
    contact.update(lag=True, dt=dt)
    Vt = contact.world()
    barrier = ipctk.BarrierPotential(dhat, kappa)
    lagged = ipctk.NormalCollisions()
    lagged.build(contact.mesh, Vt, dhat)
    tangential = ipctk.TangentialCollisions()
    tangential.build(contact.mesh, Vt, lagged, barrier, mu)
    assert len(lagged) > 0 and len(tangential) > 0
    friction = ipctk.FrictionPotential(eps_v * dt)
    # Move the upper body tangentially, past friction's threshold.
    last = targets[-1]
    last.updateValue(last.value + np.array([2e-3, -1e-3, 0.0]).reshape(
        (1,) + last.value.shape[1:]) if not affine else
        last.value + np.array([[2e-3], [-1e-3], [0.0]]))
    V = contact.world()
    collisions = ipctk.NormalCollisions()
    collisions.build(contact.mesh, V, dhat)
    normal = -barrier.gradient(collisions, contact.mesh, V).reshape(-1, 3)
    sliding = -friction.gradient(tangential, contact.mesh,
                                 V - Vt).reshape(-1, 3)
    assert np.abs(sliding).max() > 0
    assert relative(contact.forces("normal"), normal) < 1e-10
    assert relative(contact.forces("friction"), sliding) < 1e-10
    assert relative(contact.forces(), normal + sliding) < 1e-10
    half = len(V) // 2
    bodies = contact.forces("normal", per="body")
    assert bodies.shape == (2, 3)
    assert relative(bodies, np.stack([normal[:half].sum(0),
                                      normal[half:].sum(0)])) < 1e-10
    # Newton's third law: the barrier's forces on the two bodies cancel.
    assert np.abs(bodies.sum(0)).max() <= 1e-10 * np.abs(bodies).max()


def test_a_box_at_rest_on_the_ground_carries_its_weight():
    """An affine box dropped 1 mm onto a half-space ground, settled: its
    normal contact forces sum to m g within 0.5%, pointing up, and never
    does a vertex cross the ground."""
    verts, tets = box_tet_mesh(2, 0.1)
    masses = lumped_masses(verts, tets, 1000.0)
    s = yasps.scene("box_at_rest")
    dt, g = 0.01, 9.81
    body = add_affine_body(s.addMesh("box"), verts + [0.0, 0.0, 1e-3],
                           masses, 1e5, scale=dt * dt)
    s.addMinimizeTarget([body.A, body.t])
    contact = Contact(s, body.vertices, faces=surface_of(tets), dhat=1e-3,
                      halfspaces=[((0, 0, 0), (0, 0, 1))])
    stepper = ImplicitEuler(s, targets=[body.A, body.t],
                            predicted=[body.A_hat, body.t_hat], dt=dt,
                            gravity=[None, (0, 0, -g)], contact=contact,
                            velocity_tolerance=1e-6)
    # The ground for ipctk: a large triangle at z = 0.
    ground = np.array([[-10.0, -10.0, 0.0], [10.0, -10.0, 0.0],
                       [0.0, 10.0, 0.0]])
    faces = np.vstack([surface_of(tets), [[0, 1, 2]] + np.int32(len(verts))])
    mesh = ipctk.CollisionMesh(np.vstack([verts, ground]),
                               ipctk.edges(faces), faces)
    for _ in range(60):
        stepper.step()
        V = contact.world()
        assert V[:, 2].min() > 0.0
        assert not ipctk.has_intersections(mesh, np.vstack([V, ground]))
    weight = masses.sum() * g
    total = contact.forces("normal", per="body")[0]
    assert total[2] == pytest.approx(weight, rel=5e-3)
    assert np.abs(total[:2]).max() < 5e-3 * weight
    np.testing.assert_array_equal(contact.forces("friction"), 0.0)


def test_forces_reject_unknown_kinds():
    _, contact, _ = box_over_box("forces_kinds", False)
    with pytest.raises(ValueError, match="kind must be one of"):
        contact.forces("tangential")
    with pytest.raises(ValueError, match="per must be"):
        contact.forces(per="member")


def test_relative_lengths_are_fractions_of_the_scene_size():
    """dhat, eps_v and the velocity tolerance as Relative fractions of the
    bounding box's diagonal, as IPC's scene files state them."""
    from yasps.sim import Relative
    s, contact, _ = box_over_box("relative_lengths", False)
    size = contact.size
    verts, _ = box_tet_mesh(2, 0.5)
    assert size > np.linalg.norm(verts.max(0) - verts.min(0))
    relative = Contact(s, contact.vertices, dhat=Relative(1e-3),
                       eps_v=Relative(2e-3), kappa=1.0, name="relative")
    assert relative.dhat == pytest.approx(1e-3 * size, rel=1e-15)
    assert relative.eps_v == pytest.approx(2e-3 * size, rel=1e-15)
    stepper = ImplicitEuler(s, targets=s.minimizeTargets, dt=0.01,
                            predicted=[None, None], world=[],
                            velocity_tolerance=Relative(1e-2),
                            contact=relative)
    assert stepper.velocity_tolerance == pytest.approx(1e-2 * size)
    with pytest.raises(SceneError, match="Relative velocity_tolerance"):
        ImplicitEuler(s, targets=s.minimizeTargets, dt=0.01,
                      predicted=[None, None],
                      velocity_tolerance=Relative(1e-2))
    with pytest.raises(ValueError, match="fraction must be > 0"):
        Relative(0.0)
