"""Pictures of triangle meshes with a depth buffer: PyVista (VTK) off-screen.

matplotlib's 3-D axes paint whole triangles back to front, so a body under
a cloth shows through it in stripes; VTK draws with OpenGL's depth buffer,
so what is behind stays behind. Without a display VTK renders through EGL
(Mesa's on a machine without a GPU), chosen here before VTK loads unless
``VTK_DEFAULT_OPENGL_WINDOW`` says otherwise. :mod:`.output` falls back to
matplotlib where PyVista is missing or cannot render.
"""

from __future__ import annotations

import os
from typing import Optional, Sequence, Tuple

import numpy as np

#: vtkCornerAnnotation's slot for text centred at the top.
UPPER_EDGE = 7
#: The camera's vertical field of view, in degrees (VTK's default).
VIEW_ANGLE = 30.0
#: How much farther the camera stands than the nearest point from which
#: the scene's bounding box fits the picture.
MARGIN = 1.08


def available() -> bool:
    """Whether PyVista can be imported (it is not a hard dependency)."""
    try:
        _pyvista()
    except ImportError:
        return False
    return True


def _pyvista():
    if not os.environ.get("DISPLAY"):
        # Without X, VTK's default window first tries an X connection and
        # warns; EGL renders off-screen directly.
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW",
                              "vtkEGLRenderWindow")
    import pyvista
    return pyvista


def camera(view: Tuple[float, float], lower: np.ndarray, upper: np.ndarray,
           aspect: float = 4 / 3
           ) -> Tuple[np.ndarray, np.ndarray, Tuple[float, float, float]]:
    """(position, focal point, up) of a camera that looks at the centre of
    the box [lower, upper] from ``view`` = (elevation, azimuth) in degrees,
    as matplotlib's ``view_init`` means them (azimuth about +z from +x),
    as near as it can be with every corner of the box inside a picture of
    this ``aspect`` (width / height), less MARGIN."""
    elevation, azimuth = np.radians(view)
    direction = np.array([np.cos(elevation) * np.cos(azimuth),
                          np.cos(elevation) * np.sin(azimuth),
                          np.sin(elevation)])
    centre = 0.5 * (lower + upper)
    # Looking straight down or up, +z cannot be "up"; +y is.
    up = (0.0, 1.0, 0.0) if abs(direction[2]) > 0.999 else (0.0, 0.0, 1.0)
    right = np.cross(-direction, up)
    right /= np.linalg.norm(right)
    screen_up = np.cross(right, -direction)
    corners = np.array([[(lower, upper)[k >> i & 1][i] for i in range(3)]
                        for k in range(8)]) - centre
    tangent = np.tan(np.radians(VIEW_ANGLE) / 2)
    # A corner at depth z towards the camera, seen from distance D, is in
    # the picture when its offsets fit (D - z) tan(angle / 2).
    needed = corners @ direction + np.maximum(
        np.abs(corners @ screen_up) / tangent,
        np.abs(corners @ right) / (tangent * aspect))
    size = max(float(np.linalg.norm(upper - lower)), 1e-12)
    distance = max(MARGIN * float(needed.max()), 0.5 * size)
    return centre + distance * direction, centre, up


class _Stage:
    """A plotter kept between pictures of the same meshes (a video's
    frames): creating a plotter and its meshes costs several times what
    drawing them does, so later frames only move the points."""

    def __init__(self, pv, meshes: Sequence, size: Tuple[int, int]):
        self.plotter = pv.Plotter(off_screen=True, window_size=tuple(size))
        self.plotter.set_background("white")
        self.surfaces = []
        for verts, faces, color in meshes:
            verts = np.asarray(verts, dtype=float).reshape(-1, 3)
            faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
            cells = np.hstack([np.full((len(faces), 1), 3), faces]).ravel()
            surface = pv.PolyData(verts.copy(), cells)
            self.plotter.add_mesh(surface, color=color, smooth_shading=False)
            self.surfaces.append(surface)
        # One title, whose text changes: adding and removing actors would
        # render the scene again each time.
        self.title = self.plotter.add_text(
            " ", position="upper_edge", font_size=10, color="black")

    @staticmethod
    def key(meshes: Sequence, size: Tuple[int, int]):
        """What a stage is reused for: the picture's size, and per mesh its
        vertex count, triangles and colour."""
        return (tuple(size),) + tuple(
            (np.asarray(verts).size,
             np.asarray(faces, dtype=np.int64).tobytes(), repr(color))
            for verts, faces, color in meshes)

    def draw(self, meshes: Sequence, view, title: Optional[str],
             size: Tuple[int, int], lower: np.ndarray,
             upper: np.ndarray) -> np.ndarray:
        for surface, (verts, _, _) in zip(self.surfaces, meshes):
            surface.points = np.asarray(verts, dtype=float).reshape(-1, 3)
        position, focus, up = camera(view, lower, upper, size[0] / size[1])
        camera_ = self.plotter.camera
        camera_.position, camera_.focal_point = tuple(position), tuple(focus)
        camera_.up, camera_.view_angle = up, VIEW_ANGLE
        self.plotter.reset_camera_clipping_range()
        self.title.SetText(UPPER_EDGE, title or " ")
        self.plotter.render()
        image = self.plotter.screenshot(return_img=True)
        return np.ascontiguousarray(image[..., :3], dtype=np.uint8)

    def close(self) -> None:
        self.plotter.close()


#: The stage of the last picture, reused while its meshes' topology and the
#: picture's size stay (one at a time: a new scene closes the old one).
_last: dict = {}


def picture(meshes: Sequence, view: Tuple[float, float],
            title: Optional[str], size: Tuple[int, int],
            lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """The meshes ``[(V, F, colour), ...]`` flat-shaded with a depth
    buffer, as an (height, width, 3) uint8 array, the camera fitted to
    [lower, upper]. Consecutive pictures of the same triangles (a video's
    frames) reuse one plotter."""
    pv = _pyvista()
    key = _Stage.key(meshes, size)
    stage = _last.get(key)
    if stage is None:
        for old in _last.values():
            old.close()
        _last.clear()
        stage = _last[key] = _Stage(pv, meshes, size)
    return stage.draw(meshes, view, title, size, lower, upper)
