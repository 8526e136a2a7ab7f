"""A step that cannot start: surfaces touching where the barrier is
infinite (a body resting exactly on the ground, boxes stacked face to
face). Newton used to take 0 iterations every frame and advise raising
max_iterations (or failed on a NaN threshold); it now stops at once with a
SceneError naming what touches and what to change."""

import numpy as np
import pytest

import yasps
from yasps.contact import Contact, surface_of
from yasps.sim import (ImplicitEuler, add_elastic_tets, add_free_vertices,
                       box_tet_mesh, lumped_masses)


def boxes(name: str, lifts, ground: bool):
    """Soft 0.1 m boxes with their bottoms at the heights ``lifts``, on a
    ground half-space at z = 0 or none: the stepper."""
    verts, tets = box_tet_mesh(2, size=0.1)
    s = yasps.scene(name)
    mesh = s.addMesh("boxes")
    placed = np.vstack([verts + [0.0, 0.0, z] for z in lifts])
    cells = np.vstack([tets + k * len(verts) for k in range(len(lifts))])
    body = add_free_vertices(mesh, placed, lumped_masses(placed, cells, 500.0))
    add_elastic_tets(mesh, body.x, placed, cells, 2e4, 5e4, scale=1e-4)
    planes = [((0, 0, 0), (0, 0, 1))] if ground else []
    contact = Contact(s, body.primitive, faces=surface_of(cells), dhat=1e-3,
                      halfspaces=planes)
    s.addMinimizeTarget([body.x])
    return ImplicitEuler(s, [body.x], [body.x_hat], dt=0.01,
                         gravity=[(0, 0, -9.81)], contact=contact)


def test_a_body_on_the_ground_is_named():
    stepper = boxes("on_ground", [0.0], ground=True)
    with pytest.raises(yasps.SceneError,
                       match=r"lies on half-space 0 .*start the body above"):
        stepper.step()
    below = boxes("below_ground", [-0.01], ground=True)
    with pytest.raises(yasps.SceneError,
                       match=r"lies 0.01 m below half-space 0"):
        below.step()


def test_boxes_face_to_face_are_named():
    stepper = boxes("stacked", [0.0, 0.1], ground=False)
    with pytest.raises(yasps.SceneError,
                       match=r"total energy at the start .*(touch|crosses)"):
        stepper.step()


def test_a_body_just_above_the_ground_steps():
    stepper = boxes("above_ground", [5e-4], ground=True)
    report = stepper.step()
    assert report.converged and report.iterations > 0
    assert not stepper.contact.has_intersections()
