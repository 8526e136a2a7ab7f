"""yasps.sim's output: VTU frames with a ParaView series, off-screen
pictures and videos."""

import xml.etree.ElementTree as ET

import imageio.v2 as imageio_v2
import imageio.v3 as imageio_v3
import matplotlib
import meshio
import numpy as np
import pytest

from yasps.contact import surface_of
from yasps.sim import (SurfaceRecorder, box_tet_mesh, cloth_grid,
                       render_surfaces, render_surfaces_array, write_video)
from yasps.sim.output import face_shades, ffmpeg_available

CLOTH_V, CLOTH_F = cloth_grid(4)
BOX_V, BOX_T = box_tet_mesh(1, 0.5)
BOX_F = surface_of(BOX_T)


def scene_meshes(drop: float = 0.0):
    """A wavy cloth and a box above it, ``drop`` lower."""
    cloth = CLOTH_V.copy()
    cloth[:, 2] = 0.1 * np.sin(4 * cloth[:, 0])
    return [(cloth, CLOTH_F, "tab:blue"),
            (BOX_V + [-0.25, -0.25, 0.4 - drop], BOX_F, (0.9, 0.5, 0.1))]


def read_series(path):
    """(timestep, file) of each DataSet of a .pvd file."""
    root = ET.parse(path).getroot()
    assert root.tag == "VTKFile" and root.get("type") == "Collection"
    return [(float(d.get("timestep")), d.get("file"))
            for d in root.find("Collection").findall("DataSet")]


# --------------------------------------------------------------- recorder


def test_recorder_writes_frames_and_a_series_per_body(tmp_path):
    recorder = SurfaceRecorder(tmp_path / "out", {"cloth": CLOTH_F, "box": BOX_F})
    times = [0.0, 0.01, 0.02, 0.03]
    for k, t in enumerate(times):
        recorder.record(t, {"cloth": CLOTH_V + [0, 0, -0.1 * k],
                            "box": BOX_V + [0, 0, 0.1 * k]})
    assert [f.index for f in recorder.frames] == [0, 1, 2, 3]
    assert [f.time for f in recorder.frames] == times
    for name in ("cloth", "box"):
        series = read_series(tmp_path / "out" / f"{name}.pvd")
        assert series == [(t, f"{name}_{k:04d}.vtu") for k, t in enumerate(times)]
        assert all((tmp_path / "out" / file).exists() for _, file in series)
    assert not list((tmp_path / "out").glob("*.partial"))
    mesh = meshio.read(tmp_path / "out" / "box_0002.vtu")
    np.testing.assert_allclose(mesh.points, BOX_V + [0, 0, 0.2])
    np.testing.assert_array_equal(mesh.cells_dict["triangle"], BOX_F)
    assert recorder.frames[2].files["box"] == tmp_path / "out" / "box_0002.vtu"


RECORDING_FOREVER = """
import sys
import numpy as np
from yasps.sim import SurfaceRecorder, cloth_grid
verts, faces = cloth_grid(12)
recorder = SurfaceRecorder(sys.argv[1], {"cloth": faces, "copy": faces})
k = 0
while True:
    moved = verts + [0.0, 0.0, -1e-3 * k]
    recorder.record(0.01 * k, {"cloth": moved, "copy": moved})
    if k == 0:
        print("recorded", flush=True)
    k += 1
"""


def test_a_run_killed_while_recording_keeps_every_frame_listed(tmp_path):
    """A process recording frames is killed (SIGKILL) at three moments:
    each time both series are whole, list frames 0, 1, ... in order, and
    every frame they list reads back with its positions (a frame cut short
    by the kill is not listed yet)."""
    import os
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    python = str(Path(__file__).resolve().parents[1])
    verts, faces = cloth_grid(12)
    for k, wait in enumerate((0.1, 0.3, 0.5)):
        out = tmp_path / f"run{k}"
        child = subprocess.Popen(
            [sys.executable, "-c", RECORDING_FOREVER, str(out)],
            stdout=subprocess.PIPE, text=True,
            env=dict(os.environ, PYTHONPATH=python))
        try:
            assert child.stdout is not None
            assert child.stdout.readline().strip() == "recorded"
            time.sleep(wait)
        finally:
            child.send_signal(signal.SIGKILL)
            child.wait()
        for name in ("cloth", "copy"):
            series = read_series(out / f"{name}.pvd")
            assert series == [(pytest.approx(0.01 * i), f"{name}_{i:04d}.vtu")
                              for i in range(len(series))]
            assert len(series) >= 1
            for i, (_, file) in enumerate(series):
                mesh = meshio.read(out / file)
                np.testing.assert_allclose(
                    mesh.points, verts + [0.0, 0.0, -1e-3 * i], atol=1e-12)


def test_recorder_keeps_one_in_every(tmp_path):
    recorder = SurfaceRecorder(tmp_path, {"cloth": CLOTH_F}, every=3)
    written = [recorder.record(0.1 * k, {"cloth": CLOTH_V}) for k in range(7)]
    assert [w is not None for w in written] == [k % 3 == 0 for k in range(7)]
    assert [f.time for f in recorder.frames] == pytest.approx([0.0, 0.3, 0.6])
    assert [t for t, _ in read_series(tmp_path / "cloth.pvd")] == \
        pytest.approx([0.0, 0.3, 0.6])
    assert sorted(p.name for p in tmp_path.glob("*.vtu")) == \
        ["cloth_0000.vtu", "cloth_0001.vtu", "cloth_0002.vtu"]


def test_recorder_checks_its_bodies_and_positions(tmp_path):
    recorder = SurfaceRecorder(tmp_path, {"cloth": CLOTH_F})
    with pytest.raises(ValueError, match="missing.*cloth"):
        recorder.record(0.0, {"box": BOX_V})
    with pytest.raises(ValueError, match="vertices"):
        recorder.record(0.0, {"cloth": CLOTH_V[:5]})
    with pytest.raises(ValueError, match="name"):
        SurfaceRecorder(tmp_path, {"a/b": CLOTH_F})
    with pytest.raises(ValueError, match="every"):
        SurfaceRecorder(tmp_path, {"cloth": CLOTH_F}, every=0)


# --------------------------------------------------------------- pictures


def test_face_shades_follow_the_normals():
    verts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    shades = face_shades(verts, np.array([[0, 1, 2], [0, 2, 1], [0, 1, 3]]))
    # Both sides of a face are lit alike, and a face turned from the light
    # is darker, but not black.
    assert shades[0] == pytest.approx(shades[1])
    assert 0.3 <= shades[2] < shades[0] <= 1


def test_render_surfaces_writes_a_picture_that_is_not_uniform(tmp_path):
    backend = matplotlib.get_backend()
    path = render_surfaces(tmp_path / "scene.png", scene_meshes(), title="drop",
                           size=(320, 240))
    assert path == tmp_path / "scene.png" and path.stat().st_size > 0
    image = imageio_v3.imread(path)
    assert image.shape[:2] == (240, 320)
    rgb = image[..., :3].reshape(-1, 3).astype(int)
    assert len(np.unique(rgb, axis=0)) > 10
    # The box's orange and the cloth's blue are both there.
    assert np.any((rgb[:, 0] > 150) & (rgb[:, 2] < 80))
    assert np.any((rgb[:, 2] > 100) & (rgb[:, 0] < 60))
    assert matplotlib.get_backend() == backend


def test_render_surfaces_array_is_the_picture(tmp_path):
    image = render_surfaces_array(scene_meshes(), size=(200, 150))
    assert image.shape == (150, 200, 3) and image.dtype == np.uint8
    saved = imageio_v3.imread(render_surfaces(tmp_path / "same.png",
                                              scene_meshes(), size=(200, 150)))
    np.testing.assert_array_equal(saved[..., :3], image)


def test_fixed_bounds_keep_the_scale_across_frames():
    """With the same bounds, a lower box is drawn lower; its orange pixels
    move down the picture."""
    bounds = ((-0.6, -0.6, -0.2), (0.6, 0.6, 1.0))

    def orange_rows(drop):
        image = render_surfaces_array(scene_meshes(drop)[1:], size=(160, 160),
                                      bounds=bounds).astype(int)
        rows, _ = np.nonzero((image[..., 0] > 150) & (image[..., 2] < 80))
        return rows.mean()

    assert orange_rows(0.3) > orange_rows(0.0) + 5


def test_render_surfaces_needs_meshes(tmp_path):
    with pytest.raises(ValueError, match="no meshes"):
        render_surfaces(tmp_path / "none.png", [])


# ----------------------------------------------------------------- videos


def frames(count: int = 4):
    """Distinct frames (Pillow merges identical consecutive GIF frames),
    with odd sides for H.264's even-size padding."""
    return [render_surfaces_array(scene_meshes(0.05 * k), size=(121, 91))
            for k in range(count)]


def test_write_video_gif(tmp_path):
    images = frames()
    path = write_video(tmp_path / "drop.gif", images, fps=10)
    assert path == tmp_path / "drop.gif"
    read = imageio_v3.imread(path, index=None)
    assert read.shape[:3] == (4, 91, 121)


@pytest.mark.skipif(not ffmpeg_available(), reason="no ffmpeg")
def test_write_video_mp4(tmp_path):
    images = frames()
    path = write_video(tmp_path / "drop.mp4", images, fps=10)
    assert path == tmp_path / "drop.mp4"
    with imageio_v2.get_reader(path, format="FFMPEG") as reader:
        assert reader.count_frames() == 4
        first = reader.get_data(0)
    # Padded to even sides, not resized.
    assert first.shape == (92, 122, 3)
    assert np.abs(first[:91, :121].astype(int) - images[0]).mean() < 8


def test_write_video_falls_back_to_gif_for_other_suffixes(tmp_path):
    path = write_video(tmp_path / "drop.webm", frames(2))
    assert path == tmp_path / "drop.gif" and path.exists()
    assert not (tmp_path / "drop.webm").exists()


def test_write_video_checks_its_frames(tmp_path):
    with pytest.raises(ValueError, match="no frames"):
        write_video(tmp_path / "a.gif", [])
    with pytest.raises(ValueError, match="different sizes"):
        write_video(tmp_path / "a.gif", [np.zeros((4, 4, 3)), np.zeros((4, 6, 3))])


def test_write_video_mp4_without_ffmpeg_writes_a_gif(tmp_path, monkeypatch):
    from yasps.sim import output
    monkeypatch.setattr(output, "ffmpeg_available", lambda: False)
    path = write_video(tmp_path / "drop.mp4", frames(2))
    assert path == tmp_path / "drop.gif"
    assert imageio_v3.imread(path, index=None).shape[0] == 2
