"""Implicit Euler through non-linear parameterisations: world-space inertia
steps a rigid body parameterised by a rotation vector (its centre follows
implicit Euler's parabola exactly, and a spin about a principal axis turns
by implicit Euler's angles, worked out by hand), the pendulum of angles
steps as its hand-written loop, and a run with world velocities resumes
bit for bit."""

import sys

import numpy as np
import pytest

import yasps
from yasps import SceneError
from yasps.sim import (ImplicitEuler, NewtonSettings, add_rotation_vector_body,
                       newton, rotation_matrices, wrap_rotation_vectors)

from conftest import REPO

sys.path.insert(0, str(REPO / "examples" / "paper"))

DT, G = 0.01, np.array([0.0, 0.0, -9.81])
CORNERS = 0.1 * np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1)
                          for z in (-1, 1)], dtype=float) + [0.3, -0.2, 1.0]


def spinning_cube(name: str, spin: float = 20.0, push=(1.0, 0.0, 2.0)):
    """Eight equal point masses at a cube's corners (inertia the same about
    every axis), spinning about z and thrown: (stepper, body)."""
    s = yasps.scene(name)
    body = add_rotation_vector_body(s.addMesh("cube"), CORNERS, 0.5)
    s.addMinimizeTarget(body.targets)
    stepper = ImplicitEuler(
        s, targets=body.targets, dt=DT, world=[body.inertia],
        world_velocities=[body.world_velocity((0.0, 0.0, spin), push)],
        normalize=[wrap_rotation_vectors, None], velocity_tolerance=1e-7)
    return stepper, body


def implicit_euler_angles(rate: float, steps: int) -> np.ndarray:
    """The angle turned after each step by implicit Euler on a rigid spin
    at ``rate`` (rad/s), by hand: the first step turns by atan(dt rate),
    the closest rotation to the tangent prediction; after it the
    prediction ``2 x_n - x_{n-1}`` of a point turned by phi lies at angle
    atan2(2 sin phi, 2 cos phi - 1), whose nearest rotation is the next."""
    phi, total, out = np.arctan(DT * rate), 0.0, []
    for _ in range(steps):
        total += phi
        out.append(total)
        phi = np.arctan2(2 * np.sin(phi), 2 * np.cos(phi) - 1) - phi
    return np.array(out)


def test_a_spinning_rotation_vector_cube_turns_as_implicit_euler_does():
    stepper, body = spinning_cube("spinning_cube")
    want = implicit_euler_angles(20.0, 60)
    centre, velocity = CORNERS.mean(axis=0), np.array([1.0, 0.0, 2.0])
    for k in range(60):
        report = stepper.step()
        assert report.converged
        # The centre: implicit Euler's parabola, exactly.
        centre, velocity = centre + DT * velocity + DT * DT * G, \
            velocity + DT * G
        x = body.positions.compute().value[:, :, 0]
        np.testing.assert_allclose(x.mean(axis=0), centre, atol=1e-8)
        # The rotation: about z only, by the angle worked out by hand (the
        # vector wrapped back once it passes pi).
        w = body.w.value[0, :, 0]
        assert np.abs(w[:2]).max() < 1e-12 and abs(w[2]) <= np.pi
        turned = np.angle(np.exp(1j * (w[2] - want[k])))
        assert abs(turned) < 1e-6   # Newton stops at 1e-9 m a step
        R = rotation_matrices(w)[0]
        np.testing.assert_allclose(
            x, (CORNERS - body.centre) @ R.T + body.centre
            + body.t.value[0, :, 0], atol=1e-12)
    assert want[-1] > 2 * np.pi  # it turned past the wrap


def test_the_pendulum_steps_as_its_hand_written_loop():
    """ImplicitEuler with the pendulum's world inertia, against the loop a
    user would write: predictions from world positions and velocities by
    hand, then Newton over the angles."""
    import pendulum
    scene, parts = pendulum.build("pendulum_stepper")
    stepper = ImplicitEuler(scene, targets=[parts["phi"], parts["psi"]],
                            dt=pendulum.DT, world=[parts["inertia"]],
                            world_gravity=pendulum.GRAVITY,
                            velocity_tolerance=1e-6, warm_start=False)
    hand, hand_parts = pendulum.build("pendulum_by_hand")
    velocity = np.zeros((2, 3))
    for _ in range(25):
        assert stepper.step().converged
        x = hand_parts["position"].compute().value[:, :, 0].copy()
        hand_parts["inertia"].x_hat.updateValue(
            (x + DT * velocity + DT * DT * pendulum.GRAVITY)[:, :, None])
        newton(hand, [hand_parts["phi"], hand_parts["psi"]],
               tolerance=1e-6 * DT, settings=NewtonSettings(max_iterations=50))
        velocity = (hand_parts["position"].compute().value[:, :, 0] - x) / DT
        np.testing.assert_allclose(
            parts["position"].compute().value,
            hand_parts["position"].compute().value, atol=1e-7)
    assert abs(float(parts["psi"].value[0, 0, 0]) - 0.4) > 0.1


def test_world_velocities_resume_bit_for_bit(tmp_path):
    first, body = spinning_cube("resumed_a")
    for _ in range(5):
        first.step()
    first.save(tmp_path / "cube.npz")
    for _ in range(5):
        first.step()
    second, other = spinning_cube("resumed_b", spin=0.0, push=(0, 0, 0))
    second.restore(tmp_path / "cube.npz")
    for _ in range(5):
        second.step()
    np.testing.assert_array_equal(other.positions.compute().value,
                                  body.positions.compute().value)
    np.testing.assert_array_equal(other.inertia.velocity,
                                  body.inertia.velocity)


def test_a_target_without_prediction_takes_no_gravity():
    s = yasps.scene("no_prediction")
    body = add_rotation_vector_body(s.addMesh("cube"), CORNERS, 0.5)
    s.addMinimizeTarget(body.targets)
    with pytest.raises(SceneError, match="no prediction, so no gravity"):
        ImplicitEuler(s, targets=body.targets, predicted=[None, None],
                      dt=DT, world=[body.inertia], gravity=[None, G])
    with pytest.raises(SceneError, match="world velocities"):
        ImplicitEuler(s, targets=body.targets, dt=DT, world=[body.inertia],
                      world_velocities=[None, None])
