"""Prescribed motion (ImplicitEuler.prescribe): a motor turns an affine box
at its set rate under a soft box that friction drags along, pinned corners
move a cloth, a scripted motion into a surface is stopped short by CCD and
reported, and misuse is refused. Every contact step is checked free of
crossings by ipctk."""

import ipctk
import numpy as np
import pytest

import yasps
from yasps.contact import Contact, surface_of
from yasps.sim import (ImplicitEuler, add_affine_body, add_cloth,
                       add_elastic_tets, add_free_vertices, box_tet_mesh,
                       cloth_corners, cloth_grid, lumped_masses)

from conftest import point_over_triangle

RATE = 3.0  # rad/s


def turn_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def collision_free(contact, steps):
    """Runs ``steps()`` (one time step), checking with ipctk that the
    contact's surfaces do not cross over it."""
    mesh = ipctk.CollisionMesh(contact.world(), contact.mesh.edges,
                               contact.mesh.faces)
    before = contact.world()
    report = steps()
    assert ipctk.is_step_collision_free(mesh, before, contact.world())
    return report


def test_a_motor_keeps_its_rate_through_contact():
    verts, tets = box_tet_mesh(2, size=0.1)
    faces = surface_of(tets)
    s = yasps.scene("motor")
    soft_mesh, plate_mesh = s.addMesh("soft"), s.addMesh("plate")
    centred = verts - [0.05, 0.05, 0.0]
    soft = add_free_vertices(soft_mesh, centred * [0.6, 0.6, 0.6]
                             + [0.02, 0.0, 0.1015], lumped_masses(
                                 verts, tets, 300.0) * 0.216)
    add_elastic_tets(soft_mesh, soft.x, centred * 0.6, tets, 2e4, 5e4,
                     scale=1e-4)
    plate = add_affine_body(plate_mesh, centred, lumped_masses(verts, tets,
                                                               3000.0),
                            1e5, scale=1e-4)
    union = s.addMesh("all").addPrimitiveUnion("v", [soft.primitive,
                                                     plate.vertices])
    union.addAttribute("position")
    contact = Contact(s, union, faces=np.concatenate(
        [faces, faces + len(verts)]), dhat=2e-3, friction=0.5)
    targets = [soft.x, plate.A, plate.t]
    s.addMinimizeTarget(targets)
    stepper = ImplicitEuler(s, targets=targets,
                            predicted=[soft.x_hat, plate.A_hat, plate.t_hat],
                            dt=0.01, gravity=[(0, 0, -9.81), None, None],
                            fixed=[None, None, np.ones(1, bool)],
                            contact=contact)
    A0 = plate.A.value[0].copy()
    stepper.prescribe(plate.A, lambda time: turn_z(RATE * time) @ A0)
    start = soft.x.value[:, :2, 0].copy()
    for _ in range(30):
        report = collision_free(contact, stepper.step)
        assert report.converged and report.prescribed_lag == 0.0
    np.testing.assert_allclose(plate.A.value[0], turn_z(RATE * 0.3) @ A0,
                               atol=1e-6)
    assert stepper.time == pytest.approx(0.3)
    # Friction took the soft box round with the plate (the plate turned
    # 0.9 rad): its vertices' angle about the axis grew.
    angles = np.unwrap(np.arctan2(soft.x.value[:, 1, 0],
                                  soft.x.value[:, 0, 0]) -
                       np.arctan2(start[:, 1], start[:, 0]))
    assert np.median(angles) > 0.1
    assert contact.min_distance() < 2e-3


def test_moving_pins_carry_a_cloth():
    verts, faces = cloth_grid(6, size=0.3)
    s = yasps.scene("pins")
    mesh = s.addMesh("cloth")
    cloth = add_free_vertices(mesh, verts, lumped_masses(verts, faces, 0.2))
    add_cloth(mesh, cloth.x, verts, faces, scale=1e-4, stretch=2e3,
              shear=2e2, bending=1e-3)
    s.addMinimizeTarget(cloth.x)
    stepper = ImplicitEuler(s, cloth.x, cloth.x_hat, dt=0.01)
    corners = np.zeros(len(verts), dtype=bool)
    corners[cloth_corners(6)] = True
    rest = verts[corners]
    stepper.prescribe(cloth.x, lambda time: rest + [0.0, 0.0, 0.5 * time],
                      mask=corners)
    for _ in range(20):
        assert stepper.step().converged
    np.testing.assert_allclose(cloth.x.value[corners, :, 0],
                               rest + [0.0, 0.0, 0.1], atol=1e-12)
    np.testing.assert_allclose(stepper.velocities[0][corners, 2, 0], 0.5,
                               rtol=1e-9)
    # The middle sags below the corners but was lifted with them.
    middle = np.argmin(np.linalg.norm(verts, axis=1))
    assert 0.0 < cloth.x.value[middle, 2, 0] < 0.1


def test_ccd_stops_a_scripted_motion_short_and_says_so():
    """A point scripted to pass through a fixed triangle at 5 m/s, from
    0.2 m above it: it follows for three steps, then CCD stops it above,
    the lag is reported, and it never crosses."""
    stepper, x, contact = point_over_triangle("scripted", 0.2)
    point = np.array([False, False, False, True])
    stepper.prescribe(x, lambda time: [0.05, 0.0, 0.2 - 5.0 * time],
                      mask=point)
    lags = []
    for _ in range(6):
        lags.append(collision_free(contact, stepper.step).prescribed_lag)
        assert x.value[3, 2, 0] > 0.0
    assert lags[0] == 0.0 and lags[-1] > 0.05


def test_prescribe_refuses_misuse():
    verts, tets = box_tet_mesh(1, size=0.1)
    s = yasps.scene("misuse")
    free = add_free_vertices(s.addMesh("m"), verts, 0.1)
    other = add_free_vertices(s.addMesh("o"), verts, 0.1)
    s.addMinimizeTarget([free.x])
    stepper = ImplicitEuler(s, free.x, free.x_hat, 0.01)
    with pytest.raises(yasps.SceneError, match="is not one of the stepper's"):
        stepper.prescribe(other.x, lambda time: verts)
    with pytest.raises(yasps.SceneError, match="a function of time"):
        stepper.prescribe(free.x, verts)
    with pytest.raises(yasps.SceneError, match="holds no entry"):
        stepper.prescribe(free.x, lambda time: verts,
                          mask=np.zeros(8, dtype=bool))
    stepper.prescribe(free.x, lambda time: verts[:2], mask=np.arange(8) < 3)
    with pytest.raises(yasps.SceneError, match="gave 6 values for 9"):
        stepper.step()
