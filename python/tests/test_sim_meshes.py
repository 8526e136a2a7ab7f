"""yasps.sim's meshes: the cloth grid, its bending hinges (checked with a
numpy dihedral energy and through yasps' own dihedral_bending) and tet
meshes read from files."""

from pathlib import Path

import meshio
import numpy as np
import pytest

import yasps
from yasps import energies as E
from yasps.contact import surface_of
from yasps.sim import (box_tet_mesh, cloth_corners, cloth_grid, hinges_of,
                       locality_order, read_surface_mesh, read_tet_mesh,
                       reorder_mesh, signed_tet_volumes)

from conftest import REPO

# The paper's meshes sit beside the checkout, in ../shared/data.
BUNNY = REPO.parent / "shared" / "data" / "bunny-1.8k.msh"


def triangle_normals(verts: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted normals (twice the area long)."""
    c = verts[faces]
    return np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])


def interior_edges(faces: np.ndarray) -> set:
    """The undirected edges in exactly two triangles, counted independently
    of hinges_of (with a dictionary)."""
    count = {}
    for tri in faces.tolist():
        for k in range(3):
            edge = frozenset((tri[k], tri[(k + 1) % 3]))
            count[edge] = count.get(edge, 0) + 1
    return {edge for edge, c in count.items() if c == 2}


def bending(verts: np.ndarray, hinges: np.ndarray, stiffness: float = 1.0,
            rest_length: float = 1.0) -> np.ndarray:
    """energies.dihedral_bending in numpy: k l0 |n1/|n1| - n2/|n2||^2."""
    x0, x1, x2, x3 = (verts[hinges[:, i]] for i in range(4))
    n1 = np.cross(x1 - x0, x2 - x0)
    n2 = np.cross(x3 - x0, x1 - x0)
    d = (n1 / np.linalg.norm(n1, axis=1, keepdims=True)
         - n2 / np.linalg.norm(n2, axis=1, keepdims=True))
    return stiffness * rest_length * (d * d).sum(axis=1)


def lifted_centre(n: int, lift: float = 0.1):
    """cloth_grid(n) with its middle vertex raised by ``lift``, and that
    vertex's index."""
    verts, faces = cloth_grid(n)
    centre = (n // 2) * (n + 2)
    verts = verts.copy()
    verts[centre, 2] += lift
    return verts, faces, centre


# ------------------------------------------------------------------ cloth


def test_cloth_grid_counts_bounds_orientation_and_area():
    n, size, height = 5, 2.0, 0.3
    verts, faces = cloth_grid(n, size, height)
    assert verts.shape == ((n + 1) ** 2, 3)
    assert faces.shape == (2 * n * n, 3) and faces.dtype == np.int32
    np.testing.assert_array_equal(verts[:, 2], height)
    np.testing.assert_allclose(verts[:, :2].min(axis=0), -size / 2)
    np.testing.assert_allclose(verts[:, :2].max(axis=0), size / 2)
    np.testing.assert_allclose(verts[:, :2].mean(axis=0), 0, atol=1e-15)
    normals = triangle_normals(verts, faces)
    assert np.all(normals[:, 2] > 0)
    np.testing.assert_allclose(normals[:, :2], 0, atol=1e-15)
    # Every triangle is half a cell, and together they cover the square.
    np.testing.assert_allclose(normals[:, 2] / 2, (size / n) ** 2 / 2)
    np.testing.assert_allclose(normals[:, 2].sum() / 2, size * size)
    assert len({tuple(sorted(t)) for t in faces.tolist()}) == len(faces)
    assert set(np.unique(faces)) == set(range(len(verts)))


def test_cloth_corners_are_the_square_corners():
    n, size = 4, 3.0
    verts, _ = cloth_grid(n, size)
    corners = verts[cloth_corners(n), :2]
    h = size / 2
    np.testing.assert_allclose(corners, [[-h, -h], [h, -h], [-h, h], [h, h]])


def test_cloth_grid_rejects_no_cells():
    with pytest.raises(ValueError, match="at least 1"):
        cloth_grid(0)


# ----------------------------------------------------------------- hinges


@pytest.mark.parametrize("n", [1, 2, 5])
def test_hinges_are_the_interior_edges_with_their_two_triangles(n):
    _, faces = cloth_grid(n)
    hinges = hinges_of(faces)
    assert hinges.dtype == np.int64 and hinges.shape[1] == 4
    edges = {frozenset(h[:2]) for h in hinges.tolist()}
    assert len(edges) == len(hinges)
    assert edges == interior_edges(faces)
    triangles = {frozenset(t) for t in faces.tolist()}
    for x0, x1, x2, x3 in hinges.tolist():
        assert frozenset((x0, x1, x2)) in triangles
        assert frozenset((x0, x1, x3)) in triangles
        assert x2 != x3


def test_hinges_of_a_closed_surface_are_all_its_edges():
    faces = surface_of(box_tet_mesh(2)[1])
    assert len(hinges_of(faces)) == 3 * len(faces) // 2


def test_bending_is_zero_on_the_flat_grid_and_positive_when_lifted():
    verts, faces = cloth_grid(4)
    hinges = hinges_of(faces)
    np.testing.assert_allclose(bending(verts, hinges), 0, atol=1e-28)
    # The orientation is what matters, not the plane: a turned grid too.
    turn = np.linalg.qr(np.random.default_rng(3).normal(size=(3, 3)))[0]
    np.testing.assert_allclose(bending(verts @ turn.T + 0.2, hinges), 0,
                               atol=1e-24)
    lifted, _, centre = lifted_centre(4)
    energy = bending(lifted, hinges)
    # Only hinges with the lifted vertex on them bend; all those where it
    # is an opposite vertex do (one triangle tilts, the other stays flat).
    # Where it is on the shared edge, both triangles tilt and may stay
    # coplanar.
    touches = np.any(hinges == centre, axis=1)
    opposite = np.any(hinges[:, 2:] == centre, axis=1)
    # The centre is where four diagonals meet: 8 triangles round it, each
    # with an interior edge opposite it.
    assert opposite.sum() == 8
    assert np.all(energy[opposite] > 1e-3)
    np.testing.assert_allclose(energy[~touches], 0, atol=1e-28)


def test_hinges_of_rejects_inconsistent_orientation():
    faces = np.array([[0, 1, 2], [0, 1, 3]])  # edge 0->1 in both
    with pytest.raises(ValueError, match="inconsistently oriented"):
        hinges_of(faces)


def test_hinges_of_no_faces():
    assert hinges_of(np.zeros((0, 3), int)).shape == (0, 4)


def bending_scene(verts: np.ndarray, hinges: np.ndarray, stiffness: float):
    s = yasps.scene("bend")
    m = s.addMesh("cloth")
    v = m.addPrimitive("v", numInstances=len(verts))
    x = v.addAttribute("position", rows=3)
    x.updateValue(verts)
    h = m.addPrimitive("h", numInstances=len(hinges))
    corners = h.addAttribute("corners", through=h.addConnectivity(
        "h2v", v, hinges, 4), source=x)
    s.addEnergy(h.addAttribute("bend", computed_attribute=E.dihedral_bending(
        corners, 1.0, stiffness)))
    return s, x


def test_yasps_dihedral_bending_on_the_hinges():
    """Through yasps' own energy: zero on the flat grid, the numpy value
    (positive) with the centre lifted."""
    verts, faces = cloth_grid(4)
    hinges = hinges_of(faces)
    s, x = bending_scene(verts, hinges, stiffness=2.0)
    assert abs(s.evaluateEnergy()) < 1e-24
    lifted, _, _ = lifted_centre(4)
    x.updateValue(lifted)
    want = bending(lifted, hinges, stiffness=2.0).sum()
    assert want > 1e-2
    np.testing.assert_allclose(s.evaluateEnergy(), want, rtol=1e-12)


# -------------------------------------------------------------- tet files


def write_tets(path: Path, verts: np.ndarray, tets: np.ndarray,
               file_format: str) -> None:
    cell_data = {}
    if file_format.startswith("gmsh"):
        # Gmsh wants physical and geometrical tags per cell.
        tags = np.ones(len(tets), dtype=np.int32)
        cell_data = {"gmsh:physical": [tags], "gmsh:geometrical": [tags]}
    meshio.write(path, meshio.Mesh(verts, [("tetra", tets)], cell_data=cell_data),
                 file_format=file_format)


@pytest.mark.parametrize("suffix, file_format", [
    (".vtu", "vtu"), (".msh", "gmsh22"), (".msh", "gmsh")])
def test_read_tet_mesh_round_trip(tmp_path, suffix, file_format):
    verts, tets = box_tet_mesh(2, 0.5)
    path = tmp_path / f"box{suffix}"
    write_tets(path, verts, tets, file_format)
    read_verts, read_tets = read_tet_mesh(path, reorder=False)
    assert read_tets.dtype == np.int32
    np.testing.assert_allclose(read_verts, verts)
    np.testing.assert_array_equal(read_tets, tets)


def test_read_tet_mesh_turns_inverted_tets_and_drops_unused_points(tmp_path):
    verts, tets = box_tet_mesh(1)
    inverted = tets.copy()
    inverted[[0, 3]] = inverted[[0, 3]][:, [1, 0, 2, 3]]
    assert np.sum(signed_tet_volumes(verts, inverted) < 0) == 2
    # A point no tet uses, first, so that the indices must shift.
    points = np.concatenate([[[9.0, 9.0, 9.0]], verts])
    path = tmp_path / "inverted.vtu"
    write_tets(path, points, inverted + 1, "vtu")
    read_verts, read_tets = read_tet_mesh(path, reorder=False)
    np.testing.assert_allclose(read_verts, verts)
    volumes = signed_tet_volumes(read_verts, read_tets)
    assert np.all(volumes > 0)
    np.testing.assert_allclose(volumes, signed_tet_volumes(verts, tets))
    # The same tets, each still with its own four vertices.
    assert [set(t) for t in read_tets.tolist()] == [set(t) for t in tets.tolist()]


def test_read_tet_mesh_without_tets_names_the_file_and_cell_types(tmp_path):
    verts, faces = cloth_grid(2)
    path = tmp_path / "cloth.vtu"
    meshio.write(path, meshio.Mesh(verts, [("triangle", faces)]))
    with pytest.raises(ValueError, match=r"cloth\.vtu.*triangle"):
        read_tet_mesh(path)


@pytest.mark.skipif(not BUNNY.exists(), reason=f"{BUNNY} is not here")
def test_read_the_bunny():
    verts, tets = read_tet_mesh(BUNNY)
    assert verts.shape == (1869, 3) and tets.shape == (7356, 4)
    assert np.all(signed_tet_volumes(verts, tets) > 0)
    # A closed surface: every boundary edge in two boundary triangles.
    faces = surface_of(tets)
    assert len(hinges_of(faces)) == 3 * len(faces) // 2


def tets_by_coordinates(verts, tets) -> set:
    """Each tet as its four vertices' coordinates, in the tet's order."""
    return {tuple(map(tuple, np.round(verts[t], 12))) for t in tets}


def index_spread(tets) -> float:
    """The mean gap between the vertex numbers of a tet's vertices."""
    return float(np.mean(tets.max(axis=1) - tets.min(axis=1)))


def test_reorder_mesh_gathers_scattered_numbers_and_keeps_the_tets():
    verts, tets = box_tet_mesh(5, 0.5)
    shuffle = np.random.default_rng(0).permutation(len(verts))
    scattered_verts = verts[shuffle]
    inverse = np.empty_like(shuffle)
    inverse[shuffle] = np.arange(len(shuffle))
    scattered = inverse[tets]
    new_verts, new_tets, order = reorder_mesh(scattered_verts, scattered)
    np.testing.assert_array_equal(np.sort(order), np.arange(len(verts)))
    np.testing.assert_array_equal(new_verts, scattered_verts[order])
    # The same oriented tets, numbered as close as the box's own layered
    # numbering (a third of the shuffle's spread), sorted by lowest vertex.
    assert tets_by_coordinates(new_verts, new_tets) == \
        tets_by_coordinates(verts, tets)
    assert np.all(signed_tet_volumes(new_verts, new_tets) > 0)
    assert index_spread(new_tets) <= index_spread(tets)
    assert index_spread(new_tets) < 0.35 * index_spread(scattered)
    assert np.all(np.diff(new_tets.min(axis=1)) >= 0)
    assert new_tets.dtype == scattered.dtype
    with pytest.raises(ValueError, match="permutation of the 216"):
        reorder_mesh(verts, tets, order=np.zeros(len(verts), dtype=int))


def test_locality_order_puts_unused_vertices_last():
    order = locality_order(np.array([[3, 1, 4]]), 6)
    assert sorted(order[:3].tolist()) == [1, 3, 4]
    assert order[3:].tolist() == [0, 2, 5]


def test_read_tet_mesh_reorders_by_default(tmp_path):
    verts, tets = box_tet_mesh(4, 0.5)
    shuffle = np.random.default_rng(1).permutation(len(verts))
    inverse = np.empty_like(shuffle)
    inverse[shuffle] = np.arange(len(shuffle))
    path = tmp_path / "scattered.vtu"
    write_tets(path, verts[shuffle], inverse[tets], "vtu")
    read_verts, read_tets = read_tet_mesh(path)
    file_verts, file_tets = read_tet_mesh(path, reorder=False)
    assert tets_by_coordinates(read_verts, read_tets) == \
        tets_by_coordinates(file_verts, file_tets)
    assert index_spread(read_tets) <= index_spread(tets)
    assert index_spread(read_tets) < 0.35 * index_spread(file_tets)


def triangles_by_coordinates(verts, faces) -> set:
    """Each triangle as its corners' coordinates, from its lowest corner on
    (the same oriented triangle whatever corner a file starts at)."""
    out = set()
    for f in faces:
        corners = [tuple(np.round(verts[i], 6)) for i in f]
        k = corners.index(min(corners))
        out.add(tuple(corners[k:] + corners[:k]))
    return out


# meshio's STL reader multiplies a uint32 count that overflows, harmlessly.
@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
@pytest.mark.parametrize("suffix", [".obj", ".ply", ".stl", ".off"])
def test_read_surface_mesh_round_trip(tmp_path, suffix):
    verts, faces = cloth_grid(3, size=0.5)
    path = tmp_path / f"cloth{suffix}"
    meshio.write(path, meshio.Mesh(verts, [("triangle", faces)]))
    read_verts, read_faces = read_surface_mesh(path)
    assert read_faces.dtype == np.int32 and read_verts.shape == verts.shape
    assert triangles_by_coordinates(read_verts, read_faces) == \
        triangles_by_coordinates(verts, faces)


def test_read_surface_mesh_merges_a_triangle_soup_and_splits_quads(tmp_path):
    verts, faces = cloth_grid(2, size=0.5)
    soup = tmp_path / "soup.vtu"
    meshio.write(soup, meshio.Mesh(verts[faces].reshape(-1, 3),
                                   [("triangle", np.arange(3 * len(faces))
                                     .reshape(-1, 3))]))
    read_verts, read_faces = read_surface_mesh(soup)
    assert len(read_verts) == len(verts)
    assert triangles_by_coordinates(read_verts, read_faces) == \
        triangles_by_coordinates(verts, faces)
    apart, _ = read_surface_mesh(soup, merge=False)
    assert len(apart) == 3 * len(faces)
    quad = tmp_path / "quad.vtu"
    square = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    meshio.write(quad, meshio.Mesh(square, [("quad", [[0, 1, 2, 3]])]))
    _, split = read_surface_mesh(quad)
    assert split.tolist() == [[0, 1, 2], [0, 2, 3]]
    lines = tmp_path / "lines.vtu"
    meshio.write(lines, meshio.Mesh(square, [("line", [[0, 1]])]))
    with pytest.raises(ValueError, match=r"lines\.vtu.*line"):
        read_surface_mesh(lines)
