"""A shortened run of the drop demo: the box never goes below the ground,
every accepted Newton step lowers the energy, and the box comes to rest."""

import sys

from conftest import REPO

sys.path.insert(0, str(REPO / "examples"))

import drop  # noqa: E402


def test_box_drops_and_comes_to_rest():
    history = drop.simulate(frames=150, cells=2, verbose=False)
    assert min(frame["lowest"] for frame in history) > 0.0
    # It reached the ground (the barrier acts within 2 cm).
    assert min(frame["lowest"] for frame in history) < 0.02
    for frame in history:
        energies = frame["energies"]
        assert all(b <= a for a, b in zip(energies, energies[1:]))
    assert max(frame["speed"] for frame in history[-10:]) < 0.05


def test_frames_are_written_for_paraview(tmp_path):
    import meshio

    frames = []
    drop.simulate(frames=3, cells=1, verbose=False,
                  on_frame=lambda k, p: frames.append(p.copy()))
    drop.write_outputs(tmp_path, 1, frames)
    mesh = meshio.read(tmp_path / "frame_0002.vtu")
    assert mesh.points.shape == (8, 3) and mesh.cells[0].type == "tetra"
    assert abs(mesh.points - frames[2]).max() == 0.0
    assert (tmp_path / "drop.png").stat().st_size > 0


def test_implicit_euler_with_fixed_vertices():
    """A box hanging by its top vertices: they stay exactly in place (their
    DoFs are excluded), the rest sags under gravity, and every step stops by
    the displacement rule."""
    import numpy as np
    import yasps
    from yasps import energies as E
    from yasps.sim import ImplicitEuler, box_tet_mesh

    verts, tets = box_tet_mesh(1, size=0.2)
    rest = verts[tets]
    dm = np.stack([rest[:, k] - rest[:, 0] for k in (1, 2, 3)], axis=2)
    s = yasps.scene("hang")
    m = s.addMesh("m")
    v = m.addPrimitive("v", numInstances=len(verts))
    t = m.addPrimitive("t", numInstances=len(tets))
    x = v.addAttribute("x", rows=3)
    x.updateValue(verts)
    x_hat = v.addConstant("x_hat", rows=3)
    x_hat.updateValue(verts)
    t.addConstant("inv", rows=3, cols=3).updateValue(np.linalg.inv(dm))
    t.addConstant("vol", rows=1).updateValue(np.abs(np.linalg.det(dm))[:, None] / 6)
    c = t.addAttribute("c", through=t.addConnectivity("t2v", v, tets, 4), source=x)
    dt = 1e-2
    s.addEnergy(t.addAttribute("elastic", computed_attribute=dt * dt * E.stable_neo_hookean(
        E.deformation_gradient(c, t["inv"]), 2e3, 5e3, t["vol"])))
    s.addEnergy(v.addAttribute("inertia", computed_attribute=E.inertia(x, x_hat, 0.1)))
    s.addMinimizeTarget([x])
    top = verts[:, 2] == verts[:, 2].max()
    stepper = ImplicitEuler(s, x, x_hat, dt, fixed=top, velocity_tolerance=1e-3)
    for _ in range(5):
        report = stepper.step()
        assert report.converged
        assert all(b <= a for a, b in zip(report.energies, report.energies[1:]))
    np.testing.assert_array_equal(x.value[top, :, 0], verts[top])
    assert (x.value[~top, 2, 0] < verts[~top, 2] - 1e-4).all()
    assert np.abs(stepper.velocities[0][top]).max() == 0.0
