"""The scenes users wrote by hand, now from the package's helpers alone
(examples/scenes): each scene's code is under 40 lines, and each runs
without an intersection (checked by ipctk on every step): the motor turns
the plate at its rate and friction drags the cloth round; the stack
settles in order; the rotation-vector box lands in the bowl; the Neo-
Hookean ball passes through a hole 60% of its diameter with every tet's
volume positive in every frame (computed here)."""

import inspect
import sys

import ipctk
import numpy as np
import pytest

from conftest import REPO

sys.path.insert(0, str(REPO / "examples" / "scenes"))

import ball_through_hole  # noqa: E402
import box_in_bowl  # noqa: E402
import spinning_plate  # noqa: E402
import stack  # noqa: E402

SCENES = [spinning_plate, stack, box_in_bowl, ball_through_hole]


@pytest.mark.parametrize("scene", SCENES, ids=lambda m: m.__name__)
def test_scene_code_is_under_40_lines(scene):
    """The build function's lines of code (no blank, comment or docstring
    lines)."""
    source = inspect.getsource(scene.build).split("\n")
    code = [line for line in source[2:] if line.strip()
            and not line.strip().startswith("#")]
    assert len(code) < 40


def nearest_rotation_vector(w: np.ndarray, near: np.ndarray) -> np.ndarray:
    """Of ``w`` and the same rotation the other way round, the vector
    nearer ``near`` (undoing a wrap between two steps)."""
    angle = np.linalg.norm(w)
    other = w * (1.0 - 2.0 * np.pi / angle) if angle > 0 else w
    return min((w, other), key=lambda v: np.linalg.norm(v - near))


def stepped(stepper, contact, frames: int, check=None, pieces: int = 1):
    """Steps ``frames`` times, every step converged, each end free of
    intersections by ipctk and each step's motion free of crossings by
    ipctk's CCD (vertices above the contact's half-spaces); ``check()``
    after each. With ``pieces`` > 1 (a rotation-vector body, whose vertices
    move on curves, not on the chords ipctk checks) the motion is followed
    through that many pieces of the straight path of the parameters;
    ``pieces=0`` checks the ends only (a step whose Newton iterations, each
    bounded by CCD, add up to a path far from the straight line between
    its ends)."""
    mesh = ipctk.CollisionMesh(contact.colliding(contact.world()),
                               contact.mesh.edges, contact.mesh.faces)
    planes = contact.halfspaces.planes()
    targets = stepper.targets
    for _ in range(frames):
        start = [t.value.copy() for t in targets]
        assert stepper.step().converged
        final = [t.value.copy() for t in targets]
        end = [value.copy() for value in final]
        if pieces > 1:   # the rotation vector, unwrapped
            end[0] = nearest_rotation_vector(end[0].reshape(3),
                                             start[0].reshape(3)
                                             ).reshape(end[0].shape)
        previous = None
        for j in range(max(pieces, 1) + 1) if pieces else [1]:
            for t, a, b in zip(targets, start, end):
                t.updateValue(a + (j / max(pieces, 1)) * (b - a))
            now = contact.colliding(contact.world())
            assert not ipctk.has_intersections(mesh, now)
            if previous is not None:
                assert ipctk.is_step_collision_free(mesh, previous, now)
            previous = now
        for origin, normal in planes:
            assert ((now - origin) @ normal).min() > 0
        for t, value in zip(targets, final):
            t.updateValue(value)
        if check is not None:
            check()


def test_the_spinning_plate_drags_the_cloth_round():
    stepper, contact, bodies = spinning_plate.build(cells=10)
    cloth = bodies["cloth"].positions
    start = np.arctan2(cloth.value[:, 1, 0], cloth.value[:, 0, 0])
    stepped(stepper, contact, 20)
    plate = stepper.targets[0].value[0]
    turned = np.arctan2(plate[1, 0], plate[0, 0])
    assert turned == pytest.approx(spinning_plate.RATE * 0.2, abs=1e-6)
    now = np.arctan2(cloth.value[:, 1, 0], cloth.value[:, 0, 0])
    assert np.median(np.angle(np.exp(1j * (now - start)))) > 0.1


def test_the_stack_settles_in_order():
    stepper, contact, bodies = stack.build(cells=2)
    stepped(stepper, contact, 40)
    heights = [bodies[k].positions.compute().value[:, 2, 0].mean()
               for k in ("soft", "rigid", "ball")]
    assert heights[0] < heights[1] < heights[2]
    assert bodies["soft"].positions.value[:, 2, 0].min() < 2e-3


def test_the_rotation_vector_box_lands_in_the_bowl():
    stepper, contact, bodies = box_in_bowl.build(subdivisions=2)
    stepped(stepper, contact, 40, pieces=16)
    box = bodies["box"].positions.compute().value[:, :, 0]
    assert np.linalg.norm(box, axis=1).max() < 0.3   # inside the bowl
    assert box[:, 2].max() < 0.0                      # below its rim
    assert np.abs(stepper.targets[0].value).max() <= np.pi


def test_the_ball_passes_the_hole_without_an_inverted_tet():
    stepper, contact, bodies, tets = ball_through_hole.build()
    ball = bodies["ball"].positions

    def volumes_positive():
        corners = ball.value[:, :, 0][tets]
        edges = corners[:, 1:] - corners[:, :1]
        assert np.linalg.det(edges).min() > 0

    # The ball snaps through the hole within a step, in many Newton
    # iterations: its ends are checked, and its tets in every frame.
    stepped(stepper, contact, 12, volumes_positive, pieces=0)
    assert ball.value[:, 2, 0].max() < 0.0              # all through
