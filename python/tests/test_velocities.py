"""Initial velocities and the motion they carry: ImplicitEuler's
``velocities``, an affine body's rates from an angular and a linear
velocity (checked against rigid motion v = v_c + w x (x - c) by finite
differences of the vertices' positions), and the kinetic energy, momentum
and angular momentum read back (against sums over the vertices written
here)."""

import numpy as np
import pytest

import yasps
from yasps.sim import (ImplicitEuler, add_affine_body, add_free_vertices,
                       affine_motion, affine_velocity, box_tet_mesh,
                       lumped_masses, vertex_motion)

ANGULAR = np.array([0.3, -1.2, 2.0])
LINEAR = np.array([0.5, 0.1, -0.4])


def tilted_affine_box(name: str):
    """An affine tet box of uneven masses, turned and moved off the
    origin."""
    verts, tets = box_tet_mesh(2, size=0.2)
    masses = lumped_masses(verts, tets, 800.0) * np.linspace(0.5, 1.5,
                                                             len(verts))
    s = yasps.scene(name)
    body = add_affine_body(s.addMesh("rigid"), verts, masses, 1e4,
                           scale=1e-4, translation=(0.3, -0.1, 0.2))
    c, s_ = np.cos(0.4), np.sin(0.4)
    body.A.updateValue(np.array([[[c, -s_, 0.0], [s_, c, 0.0],
                                  [0.0, 0.0, 1.0]]]))
    return s, body, verts, masses


def world(body, verts, A=None, t=None):
    A = body.A.value[0] if A is None else A
    t = body.t.value[0, :, 0] if t is None else t
    return verts @ A.T + t


def test_affine_velocity_is_the_rigid_motion():
    _, body, verts, masses = tilted_affine_box("rigid_motion")
    A_dot, t_dot = affine_velocity(body, ANGULAR, LINEAR)
    assert A_dot.shape == (1, 3, 3) and t_dot.shape == (1, 3, 1)
    h = 1e-7
    x0 = world(body, verts)
    x1 = world(body, verts, body.A.value[0] + h * A_dot[0],
               body.t.value[0, :, 0] + h * t_dot[0, :, 0])
    center = masses @ x0 / masses.sum()
    rigid = LINEAR + np.cross(ANGULAR, x0 - center)
    np.testing.assert_allclose((x1 - x0) / h, rigid, atol=1e-7)
    # About another point: that point moves at the linear velocity.
    point = np.array([1.0, 2.0, 3.0])
    A_dot, t_dot = affine_velocity(body, ANGULAR, LINEAR, about=point)
    moved = A_dot[0] @ np.linalg.solve(body.A.value[0],
                                       point - body.t.value[0, :, 0]) \
        + t_dot[0, :, 0]
    np.testing.assert_allclose(moved, LINEAR, atol=1e-12)


def test_affine_motion_reads_back_what_the_vertices_carry():
    _, body, verts, masses = tilted_affine_box("read_back")
    motion = affine_motion(body, *affine_velocity(body, ANGULAR, LINEAR))
    x = world(body, verts)
    center = masses @ x / masses.sum()
    v = LINEAR + np.cross(ANGULAR, x - center)
    np.testing.assert_allclose(motion.angular, ANGULAR, atol=1e-12)
    np.testing.assert_allclose(motion.linear, LINEAR, atol=1e-12)
    np.testing.assert_allclose(motion.center, center, atol=1e-14)
    assert motion.mass == pytest.approx(masses.sum(), rel=1e-14)
    assert motion.kinetic_energy == pytest.approx(
        0.5 * np.sum(masses * np.sum(v * v, axis=1)), rel=1e-12)
    np.testing.assert_allclose(motion.momentum, masses.sum() * LINEAR,
                               rtol=1e-12)
    # L = I w with the inertia tensor sum m (|r|^2 1 - r r^T) about the
    # centre of mass.
    r = x - center
    inertia = sum(m * (ri @ ri * np.eye(3) - np.outer(ri, ri))
                  for m, ri in zip(masses, r))
    np.testing.assert_allclose(motion.angular_momentum, inertia @ ANGULAR,
                               rtol=1e-12)


def test_vertex_motion_checks_its_sizes():
    with pytest.raises(ValueError, match="2 masses, 3 positions"):
        vertex_motion(np.ones(2), np.zeros((3, 3)), np.zeros((3, 3)))


def test_implicit_euler_starts_from_the_given_velocities():
    """A free affine box spun and thrown with no gravity: its centre moves
    at the given linear velocity, and its angular momentum stays what the
    given spin gave it (its angular velocity precesses, as a free body's
    off its principal axes does; implicit Euler loses under 1% of it in
    20 steps); the stepper's velocities read back that motion."""
    s, body, verts, masses = tilted_affine_box("spin")
    A_dot, t_dot = affine_velocity(body, ANGULAR, LINEAR)
    start = affine_motion(body, A_dot, t_dot)
    s.addMinimizeTarget([body.A, body.t])
    stepper = ImplicitEuler(s, targets=[body.A, body.t],
                            predicted=[body.A_hat, body.t_hat], dt=0.01,
                            gravity=[None, None], velocities=[A_dot, t_dot],
                            velocity_tolerance=1e-6)
    A0 = body.A.value[0].copy()
    for _ in range(20):
        assert stepper.step().converged
    motion = affine_motion(body, *stepper.velocities)
    np.testing.assert_allclose(motion.center - start.center, 0.2 * LINEAR,
                               atol=1e-9)
    np.testing.assert_allclose(motion.momentum, start.momentum, rtol=1e-8)
    np.testing.assert_allclose(motion.angular_momentum,
                               start.angular_momentum,
                               rtol=1e-2, atol=1e-2 * np.linalg.norm(
                                   start.angular_momentum))
    assert motion.kinetic_energy == pytest.approx(start.kinetic_energy,
                                                  rel=2e-2)
    # It did turn, by about |w| T.
    turn = body.A.value[0] @ np.linalg.inv(A0)
    angle = np.arccos(np.clip((np.trace(turn) - 1) / 2, -1, 1))
    assert angle == pytest.approx(0.2 * np.linalg.norm(ANGULAR), rel=0.1)


def test_velocities_must_fit_the_targets():
    verts, tets = box_tet_mesh(1, size=0.1)
    s = yasps.scene("bad_velocities")
    free = add_free_vertices(s.addMesh("m"), verts, 0.1)
    s.addMinimizeTarget([free.x])
    with pytest.raises(yasps.SceneError, match="2 velocities for 1 targets"):
        ImplicitEuler(s, free.x, free.x_hat, 0.01, velocities=[None, None])
    with pytest.raises(yasps.SceneError, match="has shape \\(3,\\)"):
        ImplicitEuler(s, free.x, free.x_hat, 0.01, velocities=np.zeros(3))
    with pytest.raises(yasps.SceneError, match="not finite"):
        ImplicitEuler(s, free.x, free.x_hat, 0.01,
                      velocities=np.full((8, 3), np.nan))
    stepper = ImplicitEuler(s, free.x, free.x_hat, 0.01, gravity=None,
                            velocities=np.tile([1.0, 0.0, 0.0], (8, 1)))
    assert stepper.velocities[0].shape == free.x.value.shape
    stepper.step()
    np.testing.assert_allclose(free.x.value[:, 0, 0] - verts[:, 0], 0.01,
                               atol=1e-9)
