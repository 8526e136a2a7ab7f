"""Surfaces for contact: the boundary triangles of a tet mesh and the edges
of a triangle mesh."""

from __future__ import annotations

import numpy as np

#: The faces of a tet (a, b, c, d), each oriented outwards for a
#: positively oriented tet.
_TET_FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def surface_of(tets: np.ndarray) -> np.ndarray:
    """The boundary triangles of a tet mesh (M, 4): the faces that belong to
    one tet only, oriented outwards, (F, 3) int32."""
    tets = np.asarray(tets, dtype=np.int64).reshape(-1, 4)
    faces = tets[:, _TET_FACES].reshape(-1, 3)
    keys = np.sort(faces, axis=1)
    _, first, counts = np.unique(keys, axis=0, return_index=True,
                                 return_counts=True)
    return faces[np.sort(first[counts == 1])].astype(np.int32)


def edges_of(faces: np.ndarray) -> np.ndarray:
    """The distinct edges of a triangle mesh (F, 3), (E, 2) int32."""
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    edges = np.sort(faces[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2), axis=1)
    return np.unique(edges, axis=0).astype(np.int32)
