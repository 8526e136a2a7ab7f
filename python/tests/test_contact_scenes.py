"""Short contact simulations through yasps.contact and yasps.sim: a soft box
dropped on another resting on the ground, a cloth draped over a static box
(an obstacle member of the UNION), and the README demo (soft, affine and
cloth in one UNION). Every frame is checked by ipctk on positions the test
reads from the targets itself, every accepted Newton step lowers the
energy, and nothing is NaN."""

import subprocess
import sys
from pathlib import Path

import ipctk
import numpy as np

import yasps
from yasps.sim import ImplicitEuler, add_free_vertices

from conftest import ipctk_collisions

REPO = Path(__file__).resolve().parents[2]
DT = 0.01

sys.path.insert(0, str(REPO / "examples"))

import cloth_drape  # noqa: E402
import soft_boxes  # noqa: E402


def check_frame(report, V: np.ndarray, faces: np.ndarray) -> None:
    """No NaN, energy lowered by every accepted step, and no intersection
    by ipctk on a collision mesh of the test's own."""
    assert np.isfinite(V).all()
    assert all(after <= before for before, after in report.step_energies)
    mesh = ipctk.CollisionMesh(V, ipctk.edges(faces), faces)
    assert not ipctk.has_intersections(mesh, V)


def test_soft_box_dropped_on_a_soft_box_on_the_ground():
    """Two soft boxes, one on the ground (a half-space), one falling onto
    it: they touch (pairs between them), stay apart, and the lower one stays
    above the ground."""
    boxes = soft_boxes.build()
    xs, contact, both = boxes.xs, boxes.contact, boxes.faces
    verts_per_box = len(xs[0].value)
    stepper = boxes.stepper()
    between = 0
    for _ in range(12):
        report = stepper.step()
        V = np.concatenate([x.value[:, :, 0] for x in xs])
        check_frame(report, V, both)
        assert V[:, 2].min() > 0.0
        ids = [c.vertex_ids(contact.mesh.edges, contact.mesh.faces)
               for c in ipctk_collisions(contact).fv_collisions]
        between += sum(min(i) < verts_per_box <= max(i) for i in ids)
    assert between > 0
    # Resting on it, pressed into its top: below its top corners, well above
    # its middle.
    assert xs[1].value[:, 2, 0].min() > 0.15


def test_cloth_draped_over_a_static_box():
    """A cloth falls on a box whose vertices are constants (an obstacle in
    the UNION): it comes to rest on the box's top face, hanging over its
    edges, without going through."""
    drape = cloth_drape.build()
    x, bv, faces = drape.x, drape.box, drape.faces
    stepper = drape.stepper()
    frames = []

    def check(frame, report):
        frames.append(frame)
        check_frame(report, np.concatenate([x.value[:, :, 0], bv]), faces)

    total = stepper.run(15, on_frame=check, progress=False)
    assert frames == list(range(1, 16))
    assert total.iterations == len(total.step_energies) > 15
    xc = x.value[:, :, 0]
    on_top = (np.abs(xc[:, 0]) < 0.08) & (np.abs(xc[:, 1]) < 0.08)
    assert on_top.any()
    # Held by the box's top (z = 0.2; lifted a little where the cloth
    # buckles over the box's edges), while the rim falls past.
    assert np.all(xc[on_top, 2] > 0.2)
    assert np.all(xc[on_top, 2] < 0.2 + 0.03)
    assert xc[:, 2].min() < 0.15


def test_readme_contact_demo_runs_small(tmp_path):
    """The README demo (soft, affine and cloth through one UNION, friction,
    pictures and video) at a small size: it exits cleanly, reports no
    intersections and writes its series, pictures and video."""
    out = subprocess.run(
        [sys.executable, str(REPO / "examples" / "contact_demo.py"),
         "--frames", "3", "--cloth", "6", "--box", "1", "--output",
         str(tmp_path)], capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "no intersections" in out.stdout
    for name in ("cloth.pvd", "soft.pvd", "rigid.pvd", "frame_0003.png"):
        assert (tmp_path / name).stat().st_size > 0
    assert list(tmp_path.glob("contact.*"))


def test_implicit_euler_takes_targets_and_predictions_by_name():
    """ImplicitEuler(scene, targets=[...], predicted=[...], dt=...) steps
    exactly as the positional form (they are the same parameters, so
    giving both is Python's own TypeError); leaving one out is an error
    that says what to give."""
    import pytest

    def run(by_name: bool):
        s = yasps.scene("named")
        parts = [add_free_vertices(s.addMesh(f"m{k}"), np.eye(3) + k, 0.1)
                 for k in range(2)]
        xs, hats = [p.x for p in parts], [p.x_hat for p in parts]
        s.addMinimizeTarget(xs)
        stepper = (ImplicitEuler(s, targets=xs, predicted=hats, dt=DT,
                                 gravity=[(0, 0, -9.81), None])
                   if by_name else
                   ImplicitEuler(s, xs, hats, DT,
                                 gravity=[(0, 0, -9.81), None]))
        stepper.step()
        return s, xs, hats, np.concatenate([x.value for x in xs])

    s, xs, hats, named = run(True)
    *_, positional = run(False)
    np.testing.assert_array_equal(named, positional)
    # The first mesh fell, the second (no gravity) did not move.
    assert (named[:3, 2, 0] < np.eye(3)[:, 2]).all()
    np.testing.assert_array_equal(named[3:, :, 0], np.eye(3) + 1)
    with pytest.raises(TypeError, match="multiple values"):
        ImplicitEuler(s, xs, hats, DT, targets=xs,  # type: ignore[misc]
                      predicted=hats)
    with pytest.raises(yasps.SceneError, match="predicted="):
        ImplicitEuler(s, targets=xs, dt=DT)
