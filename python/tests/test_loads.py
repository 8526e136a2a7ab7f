"""External forces: a load spread over a box's vertices accelerates its
centre as implicit Euler does under F / M, on free vertices, an affine
body (which it does not turn, spread by mass) and a rotation-vector body;
a load at one corner turns a body; changing loads compiles nothing."""

import numpy as np
import pytest

import yasps
from yasps import SceneError
from yasps.sim import (ImplicitEuler, add_affine_body, add_free_vertices,
                       add_loads, add_rotation_vector_body, box_tet_mesh,
                       lumped_masses)

DT = 0.01
VERTS, TETS = box_tet_mesh(2, 0.2)
MASSES = lumped_masses(VERTS, TETS, 1000.0)
FORCE = np.array([3.0, -1.0, 2.0])


def centre_under(force: np.ndarray, steps: int) -> np.ndarray:
    """Implicit Euler's centre of mass from rest under ``force`` alone."""
    c, v = (MASSES[:, None] * VERTS).sum(0) / MASSES.sum(), np.zeros(3)
    for _ in range(steps):
        v = v + DT * force / MASSES.sum()
        c = c + DT * v
    return c


def centre(positions) -> np.ndarray:
    x = positions.compute().value[:, :, 0]
    return (MASSES[:, None] * x).sum(0) / MASSES.sum()


@pytest.mark.parametrize("body", ["free", "affine", "rotation"])
def test_a_load_moves_the_centre_as_implicit_euler_does(body):
    s = yasps.scene(f"loaded_{body}")
    mesh = s.addMesh("box")
    if body == "free":
        part = add_free_vertices(mesh, VERTS, MASSES)
        targets, options = [part.x], dict(predicted=[part.x_hat])
        positions = part.x
    elif body == "affine":
        part = add_affine_body(mesh, VERTS, MASSES, 1e5, scale=DT * DT)
        targets = [part.A, part.t]
        options = dict(predicted=[part.A_hat, part.t_hat])
        positions = part.vertices["position"]
    else:
        part = add_rotation_vector_body(mesh, VERTS, MASSES)
        targets, options = part.targets, dict(world=[part.inertia],
                                              world_gravity=None)
        positions = part.positions
    s.addMinimizeTarget(targets)
    loads = add_loads(positions, scale=DT * DT)
    loads.set_total(FORCE, weights=MASSES)
    np.testing.assert_allclose(loads.total, FORCE, rtol=1e-14)
    stepper = ImplicitEuler(s, targets=targets, dt=DT,
                            gravity=[None] * len(targets)
                            if body != "rotation" else None,
                            velocity_tolerance=1e-7, **options)
    for _ in range(20):
        assert stepper.step().converged
    np.testing.assert_allclose(centre(positions), centre_under(FORCE, 20),
                               atol=1e-9)
    if body == "affine":   # spread by mass: no turn
        np.testing.assert_allclose(part.A.value[0], np.eye(3), atol=1e-9)


def test_a_load_at_one_corner_turns_the_body_and_recompiles_nothing():
    s = yasps.scene("corner_load")
    part = add_rotation_vector_body(s.addMesh("box"), VERTS, MASSES)
    s.addMinimizeTarget(part.targets)
    loads = add_loads(part.positions, scale=DT * DT)
    corner = np.zeros(len(VERTS), dtype=bool)
    corner[np.argmax(VERTS.sum(axis=1))] = True
    stepper = ImplicitEuler(s, targets=part.targets, dt=DT,
                            world=[part.inertia], world_gravity=None,
                            velocity_tolerance=1e-7)
    stepper.step()
    compiled = yasps.compile(s, progress=False).compiled
    loads.set([0.0, 0.0, 5.0], mask=corner)
    for _ in range(5):
        stepper.step()
    assert yasps.compile(s, progress=False).compiled == 0 == compiled
    w = part.w.value[0, :, 0]
    # The push at the (+,+,+) corner along z turns the box about an axis
    # in the x-y plane: r x f = (y f, -x f, 0).
    assert np.linalg.norm(w) > 1e-4 and abs(w[2]) < 1e-9
    assert w[0] > 0 > w[1]


def test_loads_refuse_bad_shapes():
    s = yasps.scene("bad_loads")
    part = add_free_vertices(s.addMesh("box"), VERTS, MASSES)
    loads = add_loads(part.x)
    with pytest.raises(SceneError, match="one 3-vector or"):
        loads.set(np.zeros((2, 3)))
    with pytest.raises(SceneError, match="boolean array"):
        loads.set(FORCE, mask=[0, 1])
    with pytest.raises(SceneError, match="already has"):
        add_loads(part.x)
