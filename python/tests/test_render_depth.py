"""Pictures with depth: VTK off-screen (the default renderer) hides a box
under a cloth entirely, draws half-spaces as ground, and fits the camera
to the scene; matplotlib stays as the fallback."""

import numpy as np
import pytest

from yasps.contact import surface_of
from yasps.sim import box_tet_mesh, cloth_grid, render_surfaces_array
from yasps.sim import render_vtk

pytestmark = pytest.mark.skipif(not render_vtk.available(),
                                reason="PyVista is not installed")

# One cell: large faces, whose painter's order puts them over the cloth.
BOX_V, BOX_T = box_tet_mesh(1, 0.5)
BOX = (BOX_V - [0.25, 0.25, 0.0], surface_of(BOX_T), (0.9, 0.1, 0.1))
CLOTH_V, CLOTH_F = cloth_grid(12)
#: a 2 m cloth 2 cm above the box
CLOTH = (CLOTH_V * [2.0, 2.0, 1.0] + [0.0, 0.0, 0.52], CLOTH_F,
         (0.1, 0.3, 0.8))
VIEW, SIZE = (55.0, -60.0), (240, 180)


def red(image: np.ndarray) -> np.ndarray:
    rgb = image.astype(int)
    return (rgb[..., 0] > 120) & (rgb[..., 1] < 60) & (rgb[..., 2] < 60)


def drape(cloth):
    """The cloth with its rim bent down past the box's top, so that from
    this view only the cloth can be seen where the box is."""
    V, F, color = cloth
    V = V.copy()
    rim = np.maximum(np.abs(V[:, 0]), np.abs(V[:, 1])) > 0.4
    V[rim, 2] -= 0.5 * (np.maximum(np.abs(V[rim, 0]), np.abs(V[rim, 1]))
                        - 0.4)
    return V, F, color


def test_a_cloth_over_a_box_hides_every_pixel_of_it():
    bounds = ((-1.0, -1.0, 0.0), (1.0, 1.0, 0.7))
    alone = render_surfaces_array([BOX], view=VIEW, size=SIZE, bounds=bounds)
    assert red(alone).sum() > 500
    covered = render_surfaces_array([BOX, drape(CLOTH)], view=VIEW, size=SIZE,
                                    bounds=bounds)
    assert red(covered).sum() == 0
    # The cloth itself is there, where the box was.
    blue = (covered[..., 2] > 120) & (covered[..., 0] < 80)
    assert blue[red(alone)].mean() > 0.99
    # What the depth buffer fixes: matplotlib's painter's order draws some
    # of the box's large faces over the cloth.
    painted = render_surfaces_array([BOX, drape(CLOTH)], view=VIEW,
                                    size=SIZE, bounds=bounds,
                                    renderer="matplotlib")
    assert red(painted).sum() > 0


def test_half_spaces_are_drawn_as_ground():
    ground = [((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))]
    plain = render_surfaces_array([BOX], view=VIEW, size=SIZE)
    grounded = render_surfaces_array([BOX], view=VIEW, size=SIZE,
                                     halfspaces=ground)

    def grey(image):
        rgb = image.astype(int)
        return (np.ptp(rgb, axis=-1) < 20) & (rgb[..., 0] > 90) & \
            (rgb[..., 0] < 240)

    assert grey(plain).sum() < 0.01 * plain[..., 0].size
    assert grey(grounded).sum() > 0.2 * grounded[..., 0].size
    # The box stands on the ground, in front of it.
    assert red(grounded).sum() == pytest.approx(red(plain).sum(), rel=0.02)


def test_the_camera_fits_the_scene():
    """Without bounds the camera frames the meshes: the box fills a good
    part of the picture and touches none of its borders, at any size."""
    for size in ((160, 120), (200, 200)):
        image = render_surfaces_array([BOX], view=VIEW, size=size)
        rows, cols = np.nonzero(red(image))
        assert len(rows) > 0.1 * image[..., 0].size
        assert rows.min() > 0 and cols.min() > 0
        assert rows.max() < size[1] - 1 and cols.max() < size[0] - 1


def test_matplotlib_stays_the_fallback():
    image = render_surfaces_array([BOX], view=VIEW, size=SIZE,
                                  renderer="matplotlib",
                                  halfspaces=[((0, 0, 0), (0, 0, 1))])
    assert image.shape == (180, 240, 3) and red(image).sum() > 100
    with pytest.raises(ValueError, match="renderer must be one of"):
        render_surfaces_array([BOX], renderer="povray")


def test_frames_of_the_same_meshes_are_drawn_afresh():
    """A video's frames reuse one plotter: a frame drawn after another of
    the same meshes, moved, equals the same frame drawn first, title and
    all; a moved box is drawn where it is."""
    bounds = ((-1.0, -1.0, -0.5), (1.0, 1.0, 1.0))
    moved = (BOX[0] + [0.0, 0.0, -0.4], BOX[1], BOX[2])
    first = render_surfaces_array([BOX], view=VIEW, size=SIZE,
                                  bounds=bounds, title="first")
    other = render_surfaces_array([moved], view=VIEW, size=SIZE,
                                  bounds=bounds, title="other")
    again = render_surfaces_array([BOX], view=VIEW, size=SIZE,
                                  bounds=bounds, title="first")
    np.testing.assert_array_equal(again, first)
    assert not np.array_equal(other, first)
    rows = [np.nonzero(red(image))[0].mean() for image in (first, other)]
    assert rows[1] > rows[0] + 5      # lower in the picture
