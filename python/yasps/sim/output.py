"""Output of simulations: surface meshes per frame for ParaView (VTU files
and a .pvd series per body), off-screen pictures of shaded triangles (by
VTK with a depth buffer, :mod:`.render_vtk`, or matplotlib), and videos of
such pictures.

PyVista, matplotlib, meshio and imageio are imported inside the functions
that use them, so that importing yasps.sim needs none of them, and
matplotlib's global backend is never changed (its pictures draw on their
own Agg canvas)."""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
from ..frontend.errors import ArgumentError

PathArg = Union[str, os.PathLike]
Color = Union[str, Tuple[float, float, float]]
#: One surface to draw: vertices (N, 3), triangles (M, 3) and a colour.
SurfaceMesh = Tuple[np.ndarray, np.ndarray, Color]
#: ((xmin, ymin, zmin), (xmax, ymax, zmax)), as sequences or arrays.
Bounds = Tuple[Union[Sequence[float], np.ndarray],
               Union[Sequence[float], np.ndarray]]

#: The light comes from above, a little from the front left: a fixed world
#: direction, so that shading does not flicker when the view turns.
LIGHT_DIRECTION = np.array([-0.3, -0.5, 1.0]) / np.linalg.norm([-0.3, -0.5, 1.0])
#: Faces turned away from the light keep this much of their colour, so
#: that their shape still shows.
AMBIENT = 0.3


# ------------------------------------------------------------- VTU series


@dataclass
class RecordedFrame:
    """One written frame: its number, its time and each body's VTU file."""
    index: int
    time: float
    files: Dict[str, Path] = field(default_factory=dict)


class SurfaceRecorder:
    """Writes the surfaces of bodies as VTU files (triangle cells, or line
    cells for bodies given segments (M, 2)), one per
    body and frame (``directory/<name>_<frame:04d>.vtu``), and keeps a
    ParaView series ``directory/<name>.pvd`` per body that lists them with
    their times, rewritten after every frame so that it is valid while a
    simulation still runs. ``every``: keep one of every ``every`` calls of
    ``record`` (the first, then every ``every``-th)."""

    def __init__(self, directory: PathArg,
                 faces_by_body: Mapping[str, np.ndarray], every: int = 1):
        if every < 1:
            raise ArgumentError(f"SurfaceRecorder: every must be at least 1, "
                                f"not {every}")
        for name in faces_by_body:
            # The name becomes part of file names.
            if not name or os.sep in name or "/" in name:
                raise ArgumentError(f"SurfaceRecorder: body name {name!r} "
                                    "cannot name a file")
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        # Triangles (M, 3), or polylines as segments (M, 2).
        self.faces_by_body = {}
        for name, F in faces_by_body.items():
            F = np.asarray(F, dtype=np.int64)
            width = F.shape[1] if F.ndim == 2 and F.shape[1] in (2, 3) else 3
            self.faces_by_body[name] = F.reshape(-1, width)
        self.every = every
        self._calls = 0
        self._frames: List[RecordedFrame] = []

    @property
    def frames(self) -> List[RecordedFrame]:
        """The frames written so far, in order."""
        return list(self._frames)

    def series_path(self, name: str) -> Path:
        """The .pvd series file of body ``name``."""
        return self.directory / f"{name}.pvd"

    def record(self, time: float,
               positions_by_body: Mapping[str, np.ndarray]) -> Optional[RecordedFrame]:
        """Writes a frame at ``time`` with each body's vertex positions
        (N, 3), if this call is one that ``every`` keeps. Returns the frame
        written, or None when this call was skipped."""
        missing = set(self.faces_by_body) - set(positions_by_body)
        unknown = set(positions_by_body) - set(self.faces_by_body)
        if missing or unknown:
            raise ArgumentError(f"SurfaceRecorder.record: positions missing for "
                                f"{sorted(missing)}, unknown bodies {sorted(unknown)}")
        call = self._calls
        self._calls += 1
        if call % self.every:
            return None
        frame = RecordedFrame(len(self._frames), float(time))
        for name, faces in self.faces_by_body.items():
            frame.files[name] = self._write_surface(
                name, frame.index, positions_by_body[name], faces)
        self._frames.append(frame)
        for name in self.faces_by_body:
            self._write_series(name)
        return frame

    def _write_surface(self, name: str, index: int, positions: np.ndarray,
                       faces: np.ndarray) -> Path:
        import meshio

        points = np.asarray(positions, dtype=float).reshape(-1, 3)
        if len(faces) and faces.max() >= len(points):
            raise ArgumentError(f"SurfaceRecorder.record: {name!r} has "
                                f"{len(points)} vertices, its faces use vertex "
                                f"{faces.max()}")
        path = self.directory / f"{name}_{index:04d}.vtu"
        cell = "line" if faces.shape[1] == 2 else "triangle"
        meshio.write(path, meshio.Mesh(points, [(cell, faces)]))
        return path

    def _write_series(self, name: str) -> None:
        root = ET.Element("VTKFile", type="Collection", version="0.1",
                          byte_order="LittleEndian")
        collection = ET.SubElement(root, "Collection")
        for frame in self._frames:
            ET.SubElement(collection, "DataSet", timestep=repr(frame.time),
                          group="", part="0", file=frame.files[name].name)
        ET.indent(root)
        path = self.series_path(name)
        # Written beside and renamed, so that a viewer reloading the series
        # while the simulation runs never reads half a file.
        partial = path.with_name(path.name + ".partial")
        ET.ElementTree(root).write(partial, encoding="utf-8",
                                   xml_declaration=True)
        os.replace(partial, path)


# --------------------------------------------------------------- pictures


def face_shades(verts: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Lambert brightness (M,) in [AMBIENT, 1] of each triangle under
    LIGHT_DIRECTION. Two-sided (|n . l|), since cloth and other open
    surfaces show both sides; degenerate triangles get the ambient level."""
    corners = np.asarray(verts, dtype=float)[np.asarray(faces)]
    normals = np.cross(corners[:, 1] - corners[:, 0],
                       corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(normals, axis=1)
    cosine = np.abs(normals @ LIGHT_DIRECTION) / np.where(length > 0, length, 1)
    return AMBIENT + (1 - AMBIENT) * cosine


def _scene_bounds(meshes: Sequence[SurfaceMesh],
                  bounds: Optional[Bounds]) -> Tuple[np.ndarray, np.ndarray]:
    if bounds is not None:
        lower, upper = (np.asarray(b, dtype=float).reshape(3) for b in bounds)
        return lower, upper
    points = np.concatenate([np.asarray(V, dtype=float).reshape(-1, 3)
                             for V, _, _ in meshes])
    return points.min(axis=0), points.max(axis=0)


def _draw(meshes: Sequence[SurfaceMesh], view: Tuple[float, float],
          title: Optional[str], size: Tuple[int, int],
          bounds: Optional[Bounds], axes: bool, dpi: int):
    """A Figure on its own Agg canvas with the shaded meshes."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.colors import to_rgb
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    if not meshes:
        raise ArgumentError("render_surfaces: no meshes to draw")
    figure = Figure(figsize=(size[0] / dpi, size[1] / dpi), dpi=dpi)
    FigureCanvasAgg(figure)
    # The 3-D axes fill the picture: matplotlib's default margins would
    # leave a wide white frame around the scene.
    figure.subplots_adjust(left=0, right=1, bottom=0, top=0.94 if title else 1)
    ax = figure.add_subplot(projection="3d")
    ax.view_init(elev=view[0], azim=view[1])
    # One collection for all meshes: matplotlib depth-sorts the faces
    # within a collection only, so separate ones would occlude wrongly.
    polygons, shaded = [], []
    for verts, faces, color in meshes:
        verts = np.asarray(verts, dtype=float).reshape(-1, 3)
        faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
        polygons.append(verts[faces])
        shaded.append(face_shades(verts, faces)[:, None] * np.array(to_rgb(color)))
    colors = np.concatenate(shaded)
    # Edges in the face colour close the hairline seams that antialiasing
    # leaves between neighbouring triangles.
    ax.add_collection3d(Poly3DCollection(np.concatenate(polygons),
                                         facecolors=colors, edgecolors=colors,
                                         linewidths=0.3))
    lower, upper = _scene_bounds(meshes, bounds)
    extent = upper - lower
    # Equal scaling: the box's sides in proportion to the data's extents;
    # a flat scene still gets a thin box, not a degenerate one.
    floor = max(float(extent.max()), 1e-12) * 0.02
    pad = np.maximum(extent, floor) - extent
    lower, upper = lower - pad / 2, upper + pad / 2
    ax.set_xlim(lower[0], upper[0])
    ax.set_ylim(lower[1], upper[1])
    ax.set_zlim(lower[2], upper[2])
    ax.set_box_aspect(upper - lower)
    if not axes:
        ax.set_axis_off()
    if title:
        ax.set_title(title)
    return figure


#: The renderers of :func:`render_surfaces`: "vtk" (PyVista off-screen,
#: with a depth buffer), "matplotlib" (painter's order: bodies can show
#: through a cloth) or "auto" (VTK where PyVista renders, else matplotlib).
RENDERERS = ("auto", "vtk", "matplotlib")
#: The colour half-spaces are drawn in.
GROUND_COLOR = (0.78, 0.78, 0.76)
#: A half-space is drawn as a square this many times the scene's
#: diagonal across, centred under the scene.
GROUND_SIZE = 1.5


def halfspace_squares(halfspaces: Sequence, lower: np.ndarray,
                      upper: np.ndarray) -> List[SurfaceMesh]:
    """Each half-space ``(origin, normal)`` as a square of its boundary
    plane (two triangles) around the point nearest the centre of [lower,
    upper], GROUND_SIZE times the box's diagonal across."""
    from ..contact.halfspace import tangent_basis

    centre = 0.5 * (lower + upper)
    half = 0.5 * GROUND_SIZE * max(float(np.linalg.norm(upper - lower)), 1e-3)
    squares: List[SurfaceMesh] = []
    for origin, normal in halfspaces:
        n = np.asarray(normal, dtype=float).reshape(3)
        n = n / np.linalg.norm(n)
        o = np.asarray(origin, dtype=float).reshape(3)
        foot = centre - ((centre - o) @ n) * n
        t0, t1 = tangent_basis(n).T
        corners = np.array([foot + half * (a * t0 + b * t1)
                            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
        squares.append((corners, np.array([[0, 1, 2], [0, 2, 3]]),
                        GROUND_COLOR))
    return squares


def _picture(meshes: Sequence[SurfaceMesh], view: Tuple[float, float],
             title: Optional[str], size: Tuple[int, int],
             bounds: Optional[Bounds], axes: bool, halfspaces: Sequence,
             renderer: str) -> Optional[np.ndarray]:
    """The picture by VTK as an array, or None where matplotlib draws it
    (chosen, or VTK missing under "auto")."""
    if renderer not in RENDERERS:
        raise ArgumentError(f"render_surfaces: renderer must be one of "
                            f"{', '.join(RENDERERS)}, got {renderer!r}")
    if not meshes:
        raise ArgumentError("render_surfaces: no meshes to draw")
    from . import render_vtk

    use_vtk = renderer == "vtk" or (renderer == "auto" and not axes
                                    and render_vtk.available())
    if not use_vtk:
        return None
    lower, upper = _scene_bounds(meshes, bounds)
    drawn = list(meshes) + halfspace_squares(halfspaces, lower, upper)
    return render_vtk.picture(drawn, view, title, size, lower, upper)


def render_surfaces(path: PathArg, meshes: Sequence[SurfaceMesh],
                    view: Tuple[float, float] = (25.0, -60.0),
                    title: Optional[str] = None,
                    size: Tuple[int, int] = (800, 600),
                    bounds: Optional[Bounds] = None,
                    axes: bool = False, halfspaces: Sequence = (),
                    renderer: str = "auto") -> Path:
    """Draws triangle meshes ``[(V (N, 3), F (M, 3), colour), ...]`` with
    flat shading off-screen and saves the picture. ``view``: (elevation,
    azimuth) in degrees; ``size``: (width, height) in pixels; ``bounds``:
    ((xmin, ymin, zmin), (xmax, ymax, zmax)) the camera is fitted to,
    fixed across the frames of a video (default: the meshes' own);
    ``halfspaces``: planes ``(origin, normal)`` (as Contact's) drawn as
    ground squares under the scene. ``renderer`` (:data:`RENDERERS`):
    VTK's depth buffer by default where PyVista is installed, matplotlib
    otherwise or with ``axes`` (equally scaled axes drawn), or for vector
    formats (.pdf, .svg). Returns the path."""
    path = Path(path)
    raster = path.suffix.lower() in (".png", ".jpg", ".jpeg", ".bmp")
    image = _picture(meshes, view, title, size, bounds, axes, halfspaces,
                     renderer if raster else "matplotlib")
    if image is not None:
        import imageio.v3 as imageio

        imageio.imwrite(path, image)
        return path
    dpi = 100
    figure = _draw(_with_halfspaces(meshes, bounds, halfspaces), view, title,
                   size, _fitted(meshes, bounds), axes, dpi)
    figure.savefig(path, dpi=dpi)
    return path


def render_surfaces_array(meshes: Sequence[SurfaceMesh],
                          view: Tuple[float, float] = (25.0, -60.0),
                          title: Optional[str] = None,
                          size: Tuple[int, int] = (800, 600),
                          bounds: Optional[Bounds] = None,
                          axes: bool = False, halfspaces: Sequence = (),
                          renderer: str = "auto") -> np.ndarray:
    """``render_surfaces``' picture as an (height, width, 3) uint8 RGB array,
    for ``write_video``."""
    image = _picture(meshes, view, title, size, bounds, axes, halfspaces,
                     renderer)
    if image is not None:
        return image
    figure = _draw(_with_halfspaces(meshes, bounds, halfspaces), view, title,
                   size, _fitted(meshes, bounds), axes, dpi=100)
    figure.canvas.draw()
    return np.array(figure.canvas.buffer_rgba())[..., :3]


def _fitted(meshes: Sequence[SurfaceMesh], bounds: Optional[Bounds]
            ) -> Bounds:
    """The bounds a picture is fitted to: ``bounds``, or the meshes'."""
    return bounds if bounds is not None else _scene_bounds(meshes, None)


def _with_halfspaces(meshes: Sequence[SurfaceMesh], bounds: Optional[Bounds],
                     halfspaces: Sequence) -> List[SurfaceMesh]:
    """The meshes and the half-spaces' squares, for matplotlib (whose axes
    still fit the meshes alone: ``bounds`` or theirs)."""
    if not halfspaces:
        return list(meshes)
    lower, upper = _scene_bounds(meshes, bounds)
    return list(meshes) + halfspace_squares(halfspaces, lower, upper)


# ----------------------------------------------------------------- videos


def ffmpeg_available() -> bool:
    """Whether imageio-ffmpeg and its ffmpeg binary are there."""
    try:
        import imageio_ffmpeg
        imageio_ffmpeg.get_ffmpeg_exe()
    except (ImportError, RuntimeError):
        return False
    return True


def _as_rgb8(image: np.ndarray) -> np.ndarray:
    """An (H, W, 3) uint8 frame from a grey, RGB or RGBA one; floats are
    read as [0, 1]."""
    image = np.asarray(image)
    if image.ndim == 2:
        image = np.repeat(image[..., None], 3, axis=2)
    if image.ndim != 3 or image.shape[2] not in (3, 4):
        raise ArgumentError(f"write_video: a frame of shape {image.shape} is not "
                            "an (H, W), (H, W, 3) or (H, W, 4) image")
    image = image[..., :3]
    if image.dtype != np.uint8:
        image = np.round(np.clip(image, 0.0, 1.0) * 255).astype(np.uint8)
    return image


def _pad_to_even(image: np.ndarray) -> np.ndarray:
    """H.264 in yuv420p needs even sides; padding by the edge pixels keeps
    the picture's scale, where imageio would resize it."""
    height, width = image.shape[:2]
    return np.pad(image, ((0, height % 2), (0, width % 2), (0, 0)), mode="edge")


def write_video(path: PathArg, images: Sequence[np.ndarray],
                fps: float = 25) -> Path:
    """Writes the frames (all of one size) as a video: an MP4 (H.264,
    through imageio-ffmpeg) when ``path`` ends in .mp4 and ffmpeg is
    available, otherwise a GIF at ``path`` with the suffix .gif. Returns
    the path actually written, so a caller sees the fallback from its
    suffix. (GIF keeps frame times in hundredths of a second, and Pillow
    merges identical consecutive frames into one longer frame.)"""
    import imageio.v2 as imageio_v2
    import imageio.v3 as imageio_v3

    frames = [_as_rgb8(image) for image in images]
    if not frames:
        raise ArgumentError("write_video: no frames")
    shapes = {frame.shape for frame in frames}
    if len(shapes) > 1:
        raise ArgumentError(f"write_video: frames of different sizes {sorted(shapes)}")
    path = Path(path)
    if path.suffix.lower() == ".mp4" and ffmpeg_available():
        # macro_block_size=2: the frames are padded to even sides already,
        # so imageio must not resize them to multiples of 16.
        with imageio_v2.get_writer(path, format="FFMPEG", fps=fps,
                                   codec="libx264", macro_block_size=2) as writer:
            for frame in frames:
                # imageio's stub types __enter__ as the base class; the
                # writer it returns (itself) has append_data.
                writer.append_data(  # type: ignore[attr-defined]
                    _pad_to_even(frame))
        return path
    path = path.with_suffix(".gif")
    imageio_v3.imwrite(path, np.stack(frames), plugin="pillow",
                       duration=1000.0 / fps, loop=0)
    return path
