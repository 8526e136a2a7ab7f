"""Meshes for first simulations and tests: a tet box, a cloth grid and its
bending hinges, and tet and surface meshes read from files (Gmsh, VTK, OBJ,
PLY, STL, ... via meshio)."""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from os import PathLike
from typing import Optional, Tuple, Union

import numpy as np
from ..frontend.errors import ArgumentError


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


def cloth_grid(n: int, size: float = 1.0,
               height: float = 0.0) -> Tuple[np.ndarray, np.ndarray]:
    """A square cloth of n x n cells in the plane z = ``height``, centred
    at the origin (x, y in [-size/2, size/2]): vertices ((n+1)^2, 3), vertex
    i + (n+1) j at column i, row j, and triangles (2 n^2, 3) int32, two per
    cell, counter-clockwise seen from +z (normals +z)."""
    if n < 1:
        raise ArgumentError(f"cloth_grid: n must be at least 1, not {n}")
    ticks = np.linspace(-size / 2, size / 2, n + 1)
    x, y = np.meshgrid(ticks, ticks, indexing="xy")
    verts = np.stack([x.ravel(), y.ravel(),
                      np.full(x.size, float(height))], axis=1)
    grid_i, grid_j = np.meshgrid(np.arange(n), np.arange(n), indexing="xy")
    i, j = grid_i.ravel(), grid_j.ravel()
    a = i + (n + 1) * j          # the cell's corners: a b below, c d above
    b, c, d = a + 1, a + n + 1, a + n + 2
    # Alternating the diagonal per cell (a checkerboard) keeps the grid
    # free of a preferred shear direction, which one diagonal everywhere
    # would give the cloth.
    flip = (i + j) % 2 == 1
    first = np.where(flip[:, None], np.stack([a, b, c], 1),
                     np.stack([a, b, d], 1))
    second = np.where(flip[:, None], np.stack([b, d, c], 1),
                      np.stack([a, d, c], 1))
    faces = np.stack([first, second], axis=1).reshape(-1, 3)
    return verts, faces.astype(np.int32)


def cloth_corners(n: int) -> np.ndarray:
    """The indices of the 4 corner vertices of ``cloth_grid(n)``: (-,-),
    (+,-), (-,+), (+,+) in x, y."""
    return np.array([0, n, n * (n + 1), (n + 1) * (n + 1) - 1], dtype=np.int64)


def hinges_of(faces: np.ndarray) -> np.ndarray:
    """Every interior edge of a consistently oriented manifold triangle mesh
    as a hinge (H, 4) int64 in the order ``energies.dihedral_bending``
    reads: x0, x1 the shared edge as it runs in the first triangle (x0, x1,
    x2), x2 and x3 the opposite vertices. The second triangle then runs
    (x1, x0, x3), so n1 = (x1-x0)x(x2-x0) and n2 = (x3-x0)x(x1-x0) are both
    the triangles' own normals and the bending energy is zero on a flat
    mesh. Raises ValueError if a directed edge occurs twice (inconsistent
    orientation, or more than two triangles on an edge)."""
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(faces) == 0:
        return np.zeros((0, 4), dtype=np.int64)
    # Half-edges: edge k of each triangle runs from corner k to k+1, with
    # corner k+2 opposite it.
    start = faces.ravel()
    end = faces[:, [1, 2, 0]].ravel()
    opposite = faces[:, [2, 0, 1]].ravel()
    count = int(faces.max()) + 1
    key = start * count + end
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    if np.any(sorted_key[1:] == sorted_key[:-1]):
        raise ArgumentError("hinges_of: a directed edge occurs in two triangles: "
                            "the mesh is inconsistently oriented or non-manifold")
    # Each interior edge once: from its half-edge with start < end, looking
    # up the reversed half-edge of the neighbouring triangle.
    lower = np.flatnonzero(start < end)
    twin_key = end[lower] * count + start[lower]
    at = np.minimum(np.searchsorted(sorted_key, twin_key), len(key) - 1)
    found = sorted_key[at] == twin_key
    lower, twin = lower[found], order[at[found]]
    return np.stack([start[lower], end[lower], opposite[lower],
                     opposite[twin]], axis=1)


def locality_order(cells: np.ndarray, num_vertices: int) -> np.ndarray:
    """A vertex order that keeps the vertices of each cell (tet, triangle,
    edge: any (M, k) index array) close in number: reverse Cuthill-McKee
    (scipy) on the graph of vertices sharing a cell. Returns ``order``, the
    old index of each new vertex. The Newton system's blocks follow vertex
    numbers; with neighbours numbered close, its products read vectors
    near where they last read, and the threads that split its rows share
    few blocks (on the paper's bunny, whose file numbers its vertices at
    random, PCG on two threads took a fifth less time, docs/benchmarks.md).
    Vertices in no cell come last, in their order."""
    import scipy.sparse as sparse
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    cells = np.asarray(cells, dtype=np.int64)
    k = cells.shape[1] if cells.ndim == 2 else 0
    blocks = [cells[:, [a, b]] for a in range(k) for b in range(k) if a != b]
    pairs = np.concatenate(blocks) if blocks else np.zeros((0, 2), np.int64)
    graph = sparse.csr_matrix((np.ones(len(pairs), dtype=np.int8),
                               (pairs[:, 0], pairs[:, 1])),
                              shape=(num_vertices, num_vertices))
    order = np.asarray(reverse_cuthill_mckee(graph, symmetric_mode=True),
                       dtype=np.int64)
    used = np.zeros(num_vertices, dtype=bool)
    used[cells.reshape(-1)] = True
    return np.concatenate([order[used[order]], np.flatnonzero(~used)])


def reorder_mesh(verts: np.ndarray, cells: np.ndarray,
                 order: Optional[np.ndarray] = None
                 ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The mesh with its vertices in ``order`` (default
    :func:`locality_order`) and its cells renumbered and sorted by their
    lowest vertex (so that kernels over the cells gather nearby vertices):
    (vertices, cells, order), ``order`` giving each new vertex's old index
    (per-vertex data ``a`` of the old mesh is ``a[order]`` on the new one).
    Each cell keeps its vertices' order, hence its orientation."""
    verts, cells = np.asarray(verts), np.asarray(cells)
    if order is None:
        order = locality_order(cells, len(verts))
    order = np.asarray(order, dtype=np.int64)
    if not np.array_equal(np.sort(order), np.arange(len(verts))):
        raise ArgumentError(f"reorder_mesh: order must be a permutation of the "
                            f"{len(verts)} vertices")
    new_index = np.empty(len(order), dtype=np.int64)
    new_index[order] = np.arange(len(order))
    renumbered = new_index[cells]
    if len(renumbered):
        renumbered = renumbered[np.argsort(renumbered.min(axis=1),
                                           kind="stable")]
    return verts[order], renumbered.astype(cells.dtype), order


def read_tet_mesh(path: Union[str, PathLike],
                  file_format: Optional[str] = None,
                  reorder: bool = True) -> Tuple[np.ndarray, np.ndarray]:
    """Reads the tetrahedra of a mesh file (Gmsh .msh, .vtu, ... anything
    meshio reads; ``file_format`` names meshio's reader where the suffix
    does not): vertices (N, 3) float and tets (M, 4) int32, every tet
    positively oriented (two vertices swapped where its signed volume is
    negative). Points no tet uses (Gmsh keeps geometry nodes) are dropped,
    since they would be vertices without mass. With ``reorder`` (default)
    vertices and tets come in :func:`reorder_mesh`'s locality order, which
    mesh generators and files often scatter; ``reorder=False`` keeps the
    file's order of tets and of the points they use.
    Raises ValueError naming the file and its cell types when it has no
    (linear) tetra cells."""
    import meshio  # here, so that importing yasps.sim does not need meshio

    mesh = meshio.read(path, file_format=file_format)
    blocks = [block.data for block in mesh.cells if block.type == "tetra"]
    if not blocks:
        found = sorted({block.type for block in mesh.cells}) or ["none"]
        raise ArgumentError(f"read_tet_mesh: {path} has no tetra cells (cell "
                            f"types found: {', '.join(found)})")
    if mesh.points.shape[1] != 3:
        raise ArgumentError(f"read_tet_mesh: {path} has {mesh.points.shape[1]}-D "
                            "points; tets need 3-D ones")
    tets = np.concatenate(blocks).astype(np.int64)
    used, tets = np.unique(tets, return_inverse=True)
    verts = np.asarray(mesh.points, dtype=float)[used]
    tets = orient_tets(verts, tets.reshape(-1, 4)).astype(np.int32)
    if reorder:
        verts, tets, _ = reorder_mesh(verts, tets)
    return verts, tets


def read_surface_mesh(path: Union[str, PathLike],
                      file_format: Optional[str] = None,
                      merge: bool = True) -> Tuple[np.ndarray, np.ndarray]:
    """Reads the triangles of a surface mesh file (OBJ, PLY, STL, OFF, VTK,
    ... anything meshio reads; ``file_format`` names meshio's reader where
    the suffix does not), for obstacles, shells and cloth: vertices (N, 3)
    float and triangles (M, 3) int32, each in the file's orientation. Quads
    are split into two triangles. With ``merge`` (default), points at
    identical coordinates become one vertex (STL stores every triangle's
    corners apart, which would leave each triangle a mesh of its own);
    points no triangle uses are dropped. Raises ValueError naming the file
    and its cell types when it has no triangles or quads."""
    import meshio  # here, so that importing yasps.sim does not need meshio

    mesh = meshio.read(path, file_format=file_format)
    blocks = [block.data for block in mesh.cells if block.type == "triangle"]
    blocks += [block.data[:, [0, 1, 2, 0, 2, 3]].reshape(-1, 3)
               for block in mesh.cells if block.type == "quad"]
    if not blocks:
        found = sorted({block.type for block in mesh.cells}) or ["none"]
        raise ArgumentError(f"read_surface_mesh: {path} has no triangles or "
                            f"quads (cell types found: {', '.join(found)})")
    points = np.asarray(mesh.points, dtype=float)
    if points.shape[1] == 2:
        points = np.hstack([points, np.zeros((len(points), 1))])
    faces = np.concatenate(blocks).astype(np.int64)
    if merge:
        # The distinct points in the order they first appear.
        _, first, inverse = np.unique(points, axis=0, return_index=True,
                                      return_inverse=True)
        order = np.argsort(first)
        rank = np.empty_like(order)
        rank[order] = np.arange(len(order))
        faces = rank[inverse.reshape(-1)][faces]
        points = points[first[order]]
    used, faces = np.unique(faces, return_inverse=True)
    return points[used], faces.reshape(-1, 3).astype(np.int32)


def signed_tet_volumes(verts: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """The signed volume (M,) of each tet (a, b, c, d): det[b-a, c-a, d-a]/6,
    positive when b, c, d turn counter-clockwise seen from outside a."""
    corners = np.asarray(verts, dtype=float)[np.asarray(tets)]
    edges = corners[:, 1:] - corners[:, :1]
    return np.linalg.det(edges) / 6


def orient_tets(verts: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """A copy of ``tets`` (M, 4) with the last two vertices swapped where a
    tet's signed volume is negative, so that every tet is positive."""
    tets = np.array(tets, copy=True)
    inverted = signed_tet_volumes(verts, tets) < 0
    tets[inverted] = tets[inverted][:, [0, 1, 3, 2]]
    return tets


#: The corners of a hexahedral cell as (x, y, z) offsets in {0, 1}, in the
#: order corner index = x + 2 y + 4 z.
HEX_CORNERS = np.array([[c & 1, (c >> 1) & 1, (c >> 2) & 1] for c in range(8)])


def trilinear_weights(local: np.ndarray) -> np.ndarray:
    """(N, 8) weights of the 8 corners of a unit cell at local coordinates
    ``local`` (N, 3) in [0, 1]^3, in HEX_CORNERS order."""
    local = np.asarray(local, dtype=float).reshape(-1, 1, 3)
    factors = np.where(HEX_CORNERS[None] == 1, local, 1.0 - local)
    return factors.prod(axis=2)


@dataclass
class Cage:
    """A uniform grid of cells around some points: the cells that hold a
    point (``hexes``, (M, 8) into ``vertices``, HEX_CORNERS order), and per
    point the cell it lies in and its trilinear ``weights`` (N, 8) of that
    cell's corners."""
    vertices: np.ndarray
    hexes: np.ndarray
    cell_of: np.ndarray
    weights: np.ndarray

    def corners_of_points(self) -> np.ndarray:
        """(N, 8): the cage vertices each point is trilinear in."""
        return self.hexes[self.cell_of]

    def embed(self, positions: np.ndarray) -> np.ndarray:
        """The points' positions for cage vertex ``positions`` (V, 3)."""
        return np.einsum("nk,nkd->nd", self.weights,
                         positions[self.corners_of_points()])


def cage_grid(points: np.ndarray, cells: int, margin: float = 1e-3) -> Cage:
    """The cage of ``points`` (N, 3): their bounding box (grown by
    ``margin`` of its diagonal) cut into ``cells`` cells along its longest
    side (cubes), only the cells holding a point kept (paper 9.3, appendix
    G: each point is trilinear in the 8 corners of its cell)."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    lo, hi = points.min(axis=0), points.max(axis=0)
    pad = margin * np.linalg.norm(hi - lo)
    lo, hi = lo - pad, hi + pad
    h = (hi - lo).max() / cells
    shape = np.maximum(np.ceil((hi - lo) / h).astype(int), 1)
    scaled = (points - lo) / h
    cell = np.minimum(np.floor(scaled).astype(int), shape - 1)
    keys = np.ravel_multi_index(cell.T, shape)
    active, cell_of = np.unique(keys, return_inverse=True)
    origin = np.stack(np.unravel_index(active, shape), axis=1)
    corner_grid = origin[:, None, :] + HEX_CORNERS[None]
    corner_keys = np.ravel_multi_index(corner_grid.reshape(-1, 3).T, shape + 1)
    used, hexes = np.unique(corner_keys, return_inverse=True)
    vertices = lo + h * np.stack(np.unravel_index(used, shape + 1), axis=1)
    weights = trilinear_weights(scaled - origin[cell_of])
    return Cage(vertices, hexes.reshape(-1, 8).astype(np.int64),
                cell_of.reshape(-1), weights)


def hex_tets(hexes: np.ndarray) -> np.ndarray:
    """Each hexahedral cell (M, 8, HEX_CORNERS order, axis-aligned) as the
    6 positively oriented tets around its main diagonal (6M, 4)."""
    tets = []
    for perm in itertools.permutations(range(3)):
        path = [np.zeros(3, dtype=int)]
        for axis in perm:
            step = path[-1].copy()
            step[axis] = 1
            path.append(step)
        corners = [int(p[0] + 2 * p[1] + 4 * p[2]) for p in path]
        # The path's tet is positive when the axis permutation is even.
        sign = np.linalg.det(np.eye(3)[list(perm)])
        if sign < 0:
            corners[2], corners[3] = corners[3], corners[2]
        tets.append(corners)
    return np.asarray(hexes)[:, tets].reshape(-1, 4)


def zigzag_spring(top, angle: float, segments: int,
                  length: float) -> np.ndarray:
    """The corners (segments + 1, 3) of a zigzag spring hanging straight
    down (-z) from ``top`` (3,) in the x-z plane: ``segments`` segments of
    ``length``, alternately ``angle`` to either side of the vertical, so
    that its end is ``segments * length * cos(angle)`` below ``top``."""
    top = np.asarray(top, dtype=float).reshape(3)
    sides = np.where(np.arange(segments) % 2 == 0, 1.0, -1.0)
    steps = np.stack([sides * length * np.sin(angle), np.zeros(segments),
                      np.full(segments, -length * np.cos(angle))], axis=1)
    return np.vstack([top, top + np.cumsum(steps, axis=0)])


def polyline_segments(lengths) -> np.ndarray:
    """The segments (M, 2) joining consecutive points of polylines of the
    given point counts, laid out one after the other."""
    out, start = [], 0
    for count in lengths:
        out += [[start + k, start + k + 1] for k in range(count - 1)]
        start += count
    return np.asarray(out, dtype=np.int64).reshape(-1, 2)



def tube_mesh(points: np.ndarray, radius: float, sides: int = 6,
              closed: bool = True):
    """A tube of ``radius`` around the polyline ``points`` (M, 3), closed by
    default, for drawing curves with the triangle renderer: a ring of
    ``sides`` vertices around each point, turned to its tangent; (vertices
    (M * sides, 3), triangles (int64))."""
    P = np.asarray(points, dtype=float).reshape(-1, 3)
    m = len(P)
    if m < 2 or sides < 3:
        raise ArgumentError(f"tube_mesh: needs 2 points and 3 sides, got {m} "
                            f"points and {sides} sides")
    after = np.roll(P, -1, axis=0) if closed else np.r_[P[1:], P[-1:]]
    before = np.roll(P, 1, axis=0) if closed else np.r_[P[:1], P[:-1]]
    tangent = after - before
    tangent /= np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True),
                          1e-300)
    helper = np.where(np.abs(tangent[:, [2]]) < 0.9, [[0.0, 0.0, 1.0]],
                      [[1.0, 0.0, 0.0]])
    normal = np.cross(tangent, helper)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    binormal = np.cross(tangent, normal)
    angle = 2 * np.pi * np.arange(sides) / sides
    ring = (np.cos(angle)[None, :, None] * normal[:, None]
            + np.sin(angle)[None, :, None] * binormal[:, None])
    verts = (P[:, None] + radius * ring).reshape(-1, 3)
    segments = m if closed else m - 1
    i = np.arange(segments)[:, None]
    j = np.arange(sides)[None, :]
    a = i * sides + j
    b = i * sides + (j + 1) % sides
    c = ((i + 1) % m) * sides + j
    d = ((i + 1) % m) * sides + (j + 1) % sides
    faces = np.concatenate([np.stack([a, c, b], -1).reshape(-1, 3),
                            np.stack([b, c, d], -1).reshape(-1, 3)])
    return verts, faces.astype(np.int64)
