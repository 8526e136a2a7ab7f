"""Tet meshes of closed surfaces, by TetGen or fTetWild (their PyPI packages
``tetgen`` and ``pytetwild``, imported only here).

TetGen builds a constrained Delaunay tetrahedralisation: with
``keep_surface`` (the default) the boundary of the tets is the input
surface itself, triangle for triangle, so a body keeps the shape its
contact surface was given; it needs a closed, non-self-intersecting
surface. fTetWild accepts any triangle soup (holes, self-intersections)
and returns a mesh whose surface lies within a small envelope of the input
(``epsilon`` times the bounding box's diagonal), not on it. TetGen is
AGPL-licensed, fTetWild MPL: the user's choice of package decides.
"""

from __future__ import annotations

import os
import tempfile
from typing import Optional, Tuple

import numpy as np

from ..frontend.errors import SceneError
from ..contact.surface import edges_of
from .meshes import orient_tets

#: The tetrahedralisers: "tetgen", "ftetwild", or "auto" (TetGen where it
#: is installed and the surface is closed, else fTetWild).
METHODS = ("auto", "tetgen", "ftetwild")


def open_edges(faces: np.ndarray) -> int:
    """How many edges of the triangles lie on one triangle only, or on
    more than two (0 for a closed manifold surface)."""
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return int(np.count_nonzero(counts != 2))


def _installed(module: str) -> bool:
    try:
        __import__(module)
    except ImportError:
        return False
    return True


def tetrahedralize(vertices: np.ndarray, faces: np.ndarray,
                   max_volume: Optional[float] = None,
                   min_ratio: float = 1.5, keep_surface: bool = True,
                   edge_length: Optional[float] = None,
                   method: str = "auto") -> Tuple[np.ndarray, np.ndarray]:
    """Tets filling the closed triangle surface ``(vertices (N, 3), faces
    (M, 3))``: ``(V (K, 3), T (L, 4))``, every tet positively oriented and
    every vertex used.

    TetGen (``method="tetgen"``): quality tets (radius-edge ratio at most
    ``min_ratio``) of about ``max_volume`` or less if given (TetGen's
    target: on a sphere most met it and the largest, at the surface, were
    within twice it); with
    ``keep_surface`` no point is added on the surface, whose triangles are
    then the tets' boundary. fTetWild (``"ftetwild"``): tets of about
    ``edge_length`` (default: a twentieth of the bounding box's diagonal),
    for surfaces TetGen refuses. Raises :class:`yasps.SceneError` for a
    surface TetGen cannot fill (naming its open edges) or an unknown
    method, ImportError naming the package that is missing."""
    if method not in METHODS:
        raise SceneError(f"tetrahedralize: method must be one of "
                         f"{', '.join(METHODS)}, got {method!r}")
    V = np.ascontiguousarray(vertices, dtype=float).reshape(-1, 3)
    F = np.ascontiguousarray(faces, dtype=np.int32).reshape(-1, 3)
    if not len(F):
        raise SceneError("tetrahedralize: no triangles")
    if F.min() < 0 or F.max() >= len(V):
        raise SceneError(f"tetrahedralize: faces index vertices outside "
                         f"0..{len(V) - 1}")
    unclosed = open_edges(F)
    if method == "auto":
        method = "tetgen" if _installed("tetgen") and not unclosed \
            else "ftetwild"
    if method == "tetgen":
        if unclosed:
            raise SceneError(
                f"tetrahedralize: the surface is not closed ({unclosed} of "
                f"its {len(edges_of(F))} edges are not shared by exactly two "
                f"triangles); TetGen needs a closed surface: close it, or "
                f"use method='ftetwild'")
        out_v, out_t = _tetgen(V, F, max_volume, min_ratio, keep_surface)
    else:
        out_v, out_t = _ftetwild(V, F, edge_length)
    return _compact(out_v, orient_tets(out_v, out_t))


def _tetgen(V: np.ndarray, F: np.ndarray, max_volume: Optional[float],
            min_ratio: float, keep_surface: bool
            ) -> Tuple[np.ndarray, np.ndarray]:
    try:
        import tetgen
    except ImportError as error:
        raise ImportError("tetrahedralize: method 'tetgen' needs the "
                          "'tetgen' package (pip install tetgen)") from error
    mesher = tetgen.TetGen(V, F)
    try:
        nodes, tets = mesher.tetrahedralize(
            quality=True, minratio=float(min_ratio), nobisect=keep_surface,
            fixedvolume=max_volume is not None,
            maxvolume=-1.0 if max_volume is None else float(max_volume),
            quiet=True)[:2]
    except RuntimeError as error:
        raise SceneError(f"tetrahedralize: TetGen could not fill the "
                         f"surface (self-intersecting? try "
                         f"method='ftetwild'): {error}") from error
    return np.asarray(nodes, dtype=float), np.asarray(tets, dtype=np.int64)


def _ftetwild(V: np.ndarray, F: np.ndarray, edge_length: Optional[float]
              ) -> Tuple[np.ndarray, np.ndarray]:
    try:
        import pytetwild
    except ImportError as error:
        raise ImportError("tetrahedralize: method 'ftetwild' needs the "
                          "'pytetwild' package (pip install pytetwild)"
                          ) from error
    # fTetWild writes its tracked surface (__tracked_surface.stl) into the
    # working folder: run it in a folder of its own, not the user's.
    here = os.getcwd()
    with tempfile.TemporaryDirectory() as scratch:
        os.chdir(scratch)
        try:
            nodes, tets = pytetwild.tetrahedralize(
                V, F, edge_length_abs=edge_length, quiet=True)
        finally:
            os.chdir(here)
    return np.asarray(nodes, dtype=float), np.asarray(tets, dtype=np.int64)


def _compact(V: np.ndarray, T: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """The mesh without vertices that no tet uses."""
    used = np.zeros(len(V), dtype=bool)
    used[T.reshape(-1)] = True
    if used.all():
        return V, T
    renumber = np.cumsum(used) - 1
    return np.ascontiguousarray(V[used]), renumber[T]
