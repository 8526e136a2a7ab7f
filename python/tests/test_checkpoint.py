"""Restarts: a run saved after some steps and resumed, in a fresh scene and
stepper, continues bit for bit as the uninterrupted one (a contact scene
with friction and adaptive stiffness, whose pairs change every step); a
checkpoint of another scene or time step is refused."""

import ipctk
import numpy as np
import pytest

import yasps
from yasps.contact import Contact, surface_of
from yasps.sim import (ImplicitEuler, add_affine_body, add_elastic_tets,
                       add_free_vertices, affine_velocity, box_tet_mesh,
                       lumped_masses)


def spinning_drop(name: str, dt: float = 0.01, cells: int = 2):
    """A soft box dropped, tilted, onto a spinning affine box held by its
    inertia alone, with friction: (stepper, world positions)."""
    verts, tets = box_tet_mesh(cells, size=0.1)
    faces = surface_of(tets)
    s = yasps.scene(name)
    soft_mesh, rigid_mesh = s.addMesh("soft"), s.addMesh("rigid")
    turn = np.array([[1.0, 0.0, 0.0], [0.0, 0.96, -0.28], [0.0, 0.28, 0.96]])
    soft = add_free_vertices(soft_mesh, (verts - 0.05) @ turn.T
                             + [0.06, 0.05, 0.17], lumped_masses(verts, tets,
                                                                 500.0))
    add_elastic_tets(soft_mesh, soft.x, verts, tets, 2e4, 5e4, scale=dt * dt)
    body = add_affine_body(rigid_mesh, verts, lumped_masses(verts, tets,
                                                            3000.0),
                           1e5, scale=dt * dt)
    union = s.addMesh("all").addPrimitiveUnion("v", [soft.primitive,
                                                     body.vertices])
    union.addAttribute("position")
    contact = Contact(s, union, faces=np.concatenate(
        [faces, faces + len(verts)]), dhat=2e-3, friction=0.3)
    targets = [soft.x, body.A, body.t]
    s.addMinimizeTarget(targets)
    stepper = ImplicitEuler(s, targets=targets,
                            predicted=[soft.x_hat, body.A_hat, body.t_hat],
                            dt=dt, gravity=[(0, 0, -9.81), None, None],
                            contact=contact, velocities=[
                                None, *affine_velocity(body, (0, 0, 4.0))])
    return stepper, contact


def test_a_resumed_run_continues_bit_for_bit(tmp_path):
    path = tmp_path / "state.npz"
    stepper, contact = spinning_drop("uninterrupted")
    mesh = ipctk.CollisionMesh(contact.world(), contact.mesh.edges,
                               contact.mesh.faces)
    before = contact.world()
    for frame in range(1, 11):
        stepper.step()
        after = contact.world()
        assert ipctk.is_step_collision_free(mesh, before, after)
        before = after
        if frame == 5:
            stepper.save(path)
    # The box landed and pairs changed over the saved and resumed halves.
    assert contact.adaptive.kappa is not None
    assert sum(p.numInstances for p in contact.primitives.values()) > 0
    want = [t.value.copy() for t in stepper.targets]

    resumed, resumed_contact = spinning_drop("resumed")
    resumed.restore(path)
    for _ in range(5):
        resumed.step()
    for got, expected in zip((t.value for t in resumed.targets), want):
        np.testing.assert_array_equal(got, expected)
    for got, expected in zip(resumed.velocities, stepper.velocities):
        np.testing.assert_array_equal(got, expected)
    assert resumed_contact.kappa == contact.kappa
    assert resumed.time == stepper.time


def test_a_checkpoint_of_another_scene_or_step_is_refused(tmp_path):
    path = tmp_path / "state.npz"
    stepper, _ = spinning_drop("saved")
    stepper.step()
    stepper.save(path)
    other_dt, _ = spinning_drop("other_dt", dt=0.005)
    with pytest.raises(yasps.SceneError, match="dt = 0.01"):
        other_dt.restore(path)
    finer, _ = spinning_drop("finer", cells=3)
    with pytest.raises(yasps.SceneError, match="'finer' is not the one saved"):
        finer.restore(path)
    (tmp_path / "junk.npz").write_bytes(b"")
    np.savez(tmp_path / "junk.npz", x=np.zeros(1))
    with pytest.raises(yasps.SceneError, match="not a yasps checkpoint"):
        stepper.restore(tmp_path / "junk.npz")


def test_a_name_without_its_suffix_round_trips(tmp_path):
    """save("state") writes state.npz (as NumPy names it) and restore
    ("state") reads it; a name with another suffix gets .npz added, and
    either spelling restores."""
    stepper, _ = spinning_drop("suffix_saved")
    stepper.step()
    assert stepper.save(tmp_path / "state") == tmp_path / "state.npz"
    assert stepper.save(str(tmp_path / "run.ckpt")) == \
        tmp_path / "run.ckpt.npz"
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "run.ckpt.npz", "state.npz"]
    for name in ("state", "state.npz", "run.ckpt", "run.ckpt.npz"):
        resumed, _ = spinning_drop("suffix_" + name.replace(".", "_"))
        resumed.restore(tmp_path / name)
        assert resumed.time == stepper.time
        for got, want in zip(resumed.targets, stepper.targets):
            np.testing.assert_array_equal(got.value, want.value)


def test_a_missing_or_cut_checkpoint_is_a_checkpoint_error(tmp_path):
    """No file (with or without .npz), half a file and a file of other bytes
    are CheckpointErrors naming the path (OSErrors too, as before)."""
    stepper, _ = spinning_drop("cut")
    with pytest.raises(yasps.CheckpointError,
                       match="no checkpoint at .*nothing nor .*nothing.npz"):
        stepper.restore(tmp_path / "nothing")
    whole = stepper.save(tmp_path / "whole").read_bytes()
    (tmp_path / "half.npz").write_bytes(whole[:len(whole) // 2])
    (tmp_path / "text.npz").write_text("not a checkpoint")
    for name in ("half", "text"):
        with pytest.raises(yasps.CheckpointError,
                           match=f"{name}.npz cannot be read") as error:
            stepper.restore(tmp_path / name)
        assert isinstance(error.value, OSError)


SAVING_FOREVER = """
import sys
sys.path.insert(0, {tests!r})
from test_checkpoint import spinning_drop
stepper, _ = spinning_drop("killed", cells={cells})
stepper.save({path!r})
print("saved", flush=True)
while True:
    # Every later save differs from the first in its time.
    stepper.time += 1.0
    stepper.save({path!r})
"""


def test_a_save_killed_midway_leaves_a_whole_checkpoint(tmp_path):
    """A process saving over and over is killed (SIGKILL, nothing to clean
    up), four times at different moments: each time the checkpoint
    restores, the first save's or a later whole one. (Written in place, as
    np.savez did, it was cut short in about half of such kills.)"""
    import os
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    cells, path = 12, tmp_path / "state"
    tests = str(Path(__file__).resolve().parent)
    resumed, _ = spinning_drop("after_kill", cells=cells)
    for wait in (0.2, 0.35, 0.5, 0.65):
        child = subprocess.Popen(
            [sys.executable, "-c", SAVING_FOREVER.format(
                tests=tests, cells=cells, path=str(path))],
            stdout=subprocess.PIPE, text=True,
            env=dict(os.environ, PYTHONPATH=str(Path(tests).parent)))
        try:
            assert child.stdout is not None
            assert child.stdout.readline().strip() == "saved"
            time.sleep(wait)
        finally:
            child.send_signal(signal.SIGKILL)
            child.wait()
        resumed.restore(path)
        assert resumed.time == float(int(resumed.time)) >= 0.0
