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
