"""Meshes for first simulations and tests."""

from __future__ import annotations

import itertools
from typing import Tuple

import numpy as np


def box_tet_mesh(n: int, size: float = 1.0) -> Tuple[np.ndarray, np.ndarray]:
    """A cube of n^3 cells split into 6 positively oriented tets each:
    vertices (N, 3) and tets (M, 4) int32."""
    grid = np.array(list(itertools.product(range(n + 1), repeat=3)), float)
    index = {tuple(p.astype(int)): i for i, p in enumerate(grid)}
    tets = []
    for cell in itertools.product(range(n), repeat=3):
        for perm in itertools.permutations(range(3)):
            path = [np.array(cell)]
            for axis in perm:
                step = path[-1].copy()
                step[axis] += 1
                path.append(step)
            tet = [index[tuple(p)] for p in path]
            a, b, c, d = grid[tet]
            if np.linalg.det(np.stack([b - a, c - a, d - a])) < 0:
                tet[2], tet[3] = tet[3], tet[2]
            tets.append(tet)
    return grid * (size / n), np.array(tets, dtype=np.int32)
