"""Triangle surfaces of simple shapes for scenes: a sphere (to fill with
:func:`yasps.sim.tetrahedralize`), an open bowl and a flat ring (obstacles).
Faces are counter-clockwise seen from outside (from +z for the ring)."""

from __future__ import annotations

from typing import Sequence, Tuple

import numpy as np

#: The golden ratio: the icosahedron's vertices are (0, +-1, +-g) and their
#: cyclic permutations.
_G = (1 + 5 ** 0.5) / 2
_ICOSAHEDRON_VERTICES = [
    [-1, _G, 0], [1, _G, 0], [-1, -_G, 0], [1, -_G, 0],
    [0, -1, _G], [0, 1, _G], [0, -1, -_G], [0, 1, -_G],
    [_G, 0, -1], [_G, 0, 1], [-_G, 0, -1], [-_G, 0, 1]]
_ICOSAHEDRON_FACES = [
    [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9],
    [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2],
    [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10],
    [8, 6, 7], [9, 8, 1]]


def sphere_surface(radius: float = 1.0, subdivisions: int = 2,
                   centre: Sequence[float] = (0.0, 0.0, 0.0)
                   ) -> Tuple[np.ndarray, np.ndarray]:
    """An icosphere: the icosahedron with each triangle cut in four
    ``subdivisions`` times, its vertices pushed onto the sphere: (V, F),
    10 * 4^k + 2 vertices, faces outwards."""
    V = [np.array(v, float) / np.linalg.norm(v)
         for v in _ICOSAHEDRON_VERTICES]
    F = [list(f) for f in _ICOSAHEDRON_FACES]
    for _ in range(subdivisions):
        middle, out = {}, []

        def mid(a: int, b: int) -> int:
            key = (min(a, b), max(a, b))
            if key not in middle:
                m = V[a] + V[b]
                V.append(m / np.linalg.norm(m))
                middle[key] = len(V) - 1
            return middle[key]
        for a, b, c in F:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            out += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        F = out
    return (radius * np.array(V) + np.asarray(centre, float),
            np.array(F, dtype=np.int32))


def bowl_surface(radius: float, subdivisions: int = 3,
                 rim: float = 0.0) -> Tuple[np.ndarray, np.ndarray]:
    """An open hemispherical bowl of ``radius`` centred at the origin: the
    triangles of an icosphere whose corners all lie at or below z = ``rim``
    (its rim ragged along the icosphere's edges), with faces turned
    inwards (towards the bowl's inside, where bodies rest). Unused vertices
    are dropped."""
    V, F = sphere_surface(radius, subdivisions)
    F = F[(V[F][:, :, 2] <= rim * radius + 1e-12).all(axis=1)][:, ::-1]
    used, F = np.unique(F, return_inverse=True)
    return V[used], F.reshape(-1, 3).astype(np.int32)


def ring_surface(inner: float, outer: float, segments: int = 32,
                 rings: int = 3, height: float = 0.0
                 ) -> Tuple[np.ndarray, np.ndarray]:
    """A flat ring (a plate with a round hole) in the plane z = ``height``
    between radii ``inner`` and ``outer``: ``rings`` bands of ``segments``
    quads each, split in two; faces turned to +z."""
    radii = np.linspace(inner, outer, rings + 1)
    angles = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    r, a = np.meshgrid(radii, angles, indexing="ij")
    V = np.stack([r.ravel() * np.cos(a.ravel()), r.ravel() * np.sin(a.ravel()),
                  np.full(r.size, float(height))], axis=1)
    faces = []
    for i in range(rings):
        for j in range(segments):
            a0, a1 = i * segments + j, i * segments + (j + 1) % segments
            b0, b1 = a0 + segments, a1 + segments
            faces += [[a0, a1, b1], [a0, b1, b0]]
    return V, np.array(faces, dtype=np.int32)
