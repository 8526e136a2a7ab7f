"""The runtime's collision detection (yasps.contact.detection) against
ipctk, the independent reference: its collision sets equal ipctk's (pairs,
types, vertex order, weights, mollifier thresholds, smallest distance) on
crumpled sheets; its additive CCD gives ipctk's bound, which ipctk's Tight
Inclusion finds collision free; where closest-feature types tie, the
barrier energy is still ipctk's; meshes it does not cover go to ipctk."""

import ipctk
import numpy as np
import pytest

import yasps
from yasps.contact import Contact
from yasps.contact.detection import (MIN_SEPARATION, IpctkDetection,
                                     RuntimeDetection)
from yasps.contact.pairs import PAIR_TYPES, collision_pairs
from yasps.contact.surface import edges_of
from yasps.runtime.native import native
from yasps.sim import cloth_grid


def crumpled_sheets(seed: int, noise: float):
    """Two 12x12-cell sheets 0.006 apart, every vertex moved by Gaussian
    noise of scale ``noise``: (ipctk mesh, positions)."""
    verts, faces = cloth_grid(12, size=0.5)
    V = np.vstack([verts, verts + [0.013, 0.007, 0.006]])
    F = np.vstack([faces, faces + len(verts)]).astype(np.int32)
    mesh = ipctk.CollisionMesh(V, edges_of(F), F)
    rng = np.random.default_rng(seed)
    return mesh, V + noise * rng.standard_normal(V.shape)


def rows_by_kind(found) -> dict:
    """Pair arrays as sets of (vertices, eps_x, weight) rows per kind, the
    two edges of an edge-edge pair (and the points of a point-point pair)
    unordered: broad phases may list a pair either way round, which also
    changes eps_x's last digit (a product of the two edges' terms), so it
    is compared to 12 digits."""
    out = {}
    for kind, pairs in found.items():
        rows = set()
        for ids, eps, w in zip(pairs.vertices.tolist(), pairs.eps_x,
                               pairs.weight):
            if kind == "vv":
                ids = tuple(sorted(ids))
            elif kind == "ee":
                ids = tuple(sorted([tuple(sorted(ids[:2])),
                                    tuple(sorted(ids[2:]))]))
            elif kind == "ee_vv":
                ids = tuple(sorted([tuple(ids[:2]), tuple(ids[2:])]))
            rows.add((tuple(np.ravel(ids).tolist()), float(f"{eps:.12g}"),
                      float(w)))
        out[kind] = rows
    return out


def step_bounds(detection: RuntimeDetection, V0: np.ndarray,
                V1: np.ndarray):
    """The runtime's additive-CCD bound of V0 -> V1 over its own broad
    phase, and ipctk's over its own: (runtime's, ipctk's)."""
    candidates = detection.candidates(V0, V1, 0.0)
    bound, _ = native().contact_step_bound(detection.native, candidates, V0,
                                           V1, MIN_SEPARATION)
    return bound, ipctk.compute_collision_free_stepsize(
        detection.mesh, V0, V1, min_distance=MIN_SEPARATION,
        narrow_phase_ccd=ipctk.AdditiveCCD())


@pytest.mark.parametrize("seed, noise, dhat", [(0, 0.004, 0.01),
                                               (1, 0.008, 0.02),
                                               (2, 0.002, 0.005)])
def test_collision_sets_equal_ipctks(seed, noise, dhat):
    mesh, V = crumpled_sheets(seed, noise)
    ours, closest2 = RuntimeDetection(mesh, dhat).pairs(V, None)
    reference = ipctk.NormalCollisions()
    reference.build(mesh, V, dhat)
    want = collision_pairs(reference, mesh.edges, mesh.faces)
    got_rows, want_rows = rows_by_kind(ours), rows_by_kind(want)
    assert sum(map(len, want_rows.values())) > 100
    assert {k for k, rows in want_rows.items() if rows} >= {"ev", "fv", "ee"}
    assert got_rows == want_rows
    for kind, pairs in ours.items():
        assert pairs.vertices.shape == (len(pairs.weight),
                                        dict((t.name, t.arity)
                                             for t in PAIR_TYPES)[kind])
    assert closest2 == pytest.approx(
        reference.compute_minimum_distance(mesh, V), rel=1e-12)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_additive_ccd_bound_is_ipctks_and_collision_free(seed):
    mesh, V0 = crumpled_sheets(seed, 0.0005)
    assert not ipctk.has_intersections(mesh, V0)
    rng = np.random.default_rng(10 + seed)
    V1 = V0 + 0.02 * rng.standard_normal(V0.shape)
    bound, want = step_bounds(RuntimeDetection(mesh, 0.01), V0, V1)
    assert ipctk.is_step_collision_free(mesh, V0, V1) is False
    assert 0.0 < bound < 1.0
    assert bound == pytest.approx(want, rel=1e-9)
    assert ipctk.is_step_collision_free(mesh, V0, V0 + bound * (V1 - V0))


def test_tied_closest_features_keep_ipctks_energy():
    """A sheet turned about the vertex at its centre and lowered onto
    another: that vertex sits exactly over its twin, where the closest
    features of many pairs tie and the two classifications may split them
    differently. The barrier energy on either set is the same."""
    verts, faces = cloth_grid(6, size=0.3)
    c, s = np.cos(0.5), np.sin(0.5)
    turned = verts @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]).T
    V = np.vstack([verts, turned + [0.0, 0.0, 0.004]])
    F = np.vstack([faces, faces + len(verts)]).astype(np.int32)
    mesh = ipctk.CollisionMesh(V, edges_of(F), F)
    dhat = 0.01
    reference = ipctk.NormalCollisions()
    reference.build(mesh, V, dhat)
    barrier = ipctk.BarrierPotential(dhat, 1.0)
    want = barrier(reference, mesh, V)
    scene = yasps.scene("tie")
    v = scene.addMesh("m").addPrimitive("v", numInstances=len(V))
    x = v.addAttribute("position", rows=3)
    x.updateValue(V[:, :, None])
    scene.addMinimizeTarget(x)
    contact = Contact(scene, v, faces=F, dhat=dhat, kappa=1.0)
    assert isinstance(contact.detection, RuntimeDetection)
    contact.update()
    assert scene.evaluateEnergy() == pytest.approx(want, rel=1e-12)


def test_points_and_rods_equal_ipctks():
    """Points on no edge (a tet mesh's inner vertices are such points) and
    edges on no face (rods) meet each other through vertex-vertex and
    edge-vertex pairs, and the sheets through face-vertex and edge-edge
    ones: the sets and the CCD bound equal ipctk's."""
    mesh, V = crumpled_sheets(0, 0.001)
    rng = np.random.default_rng(7)
    points = rng.uniform([-0.2, -0.2, 0.0], [0.2, 0.2, 0.008], (300, 3))
    rods = rng.uniform([-0.2, -0.2, 0.0], [0.2, 0.2, 0.008], (120, 3))
    V = np.vstack([V, points, rods])
    first_rod = len(V) - len(rods)
    rod_edges = np.arange(first_rod, len(V)).reshape(-1, 2)
    mesh = ipctk.CollisionMesh(V, np.vstack([mesh.edges, rod_edges]),
                               mesh.faces)
    assert mesh.num_codim_vertices == len(points)
    assert mesh.num_codim_edges == len(rod_edges)
    dhat = 0.01
    detection = RuntimeDetection(mesh, dhat)
    candidates = detection.candidates(V, V, 0.5 * dhat)
    assert len(candidates.vertex_vertex) and len(candidates.edge_vertex)
    ours, closest2 = detection.pairs(V, None)
    reference = ipctk.NormalCollisions()
    reference.build(mesh, V, dhat)
    assert rows_by_kind(ours) == rows_by_kind(
        collision_pairs(reference, mesh.edges, mesh.faces))
    assert closest2 == pytest.approx(
        reference.compute_minimum_distance(mesh, V), rel=1e-12)
    bound, want = step_bounds(detection, V,
                              V + 0.01 * rng.standard_normal(V.shape))
    assert bound == pytest.approx(want, rel=1e-9)
    # The closest pair a point and a rod's middle, or two points: the
    # candidates' smallest distance (the CCD's close-range test) sees it.
    for near in (0.5 * (V[first_rod] + V[first_rod + 1]), V[first_rod - 2]):
        V[first_rod - 1] = near + [0.0, 0.0, 3e-7]
        candidates = detection.candidates(V, V, 0.5 * dhat)
        reference.build(mesh, V, dhat)
        # The bound's second value: the candidates' closest at the start.
        _, closest2 = native().contact_step_bound(detection.native,
                                                  candidates, V, V,
                                                  MIN_SEPARATION)
        assert closest2 == pytest.approx(
            reference.compute_minimum_distance(mesh, V), rel=1e-9)
        assert closest2 < 1e-12


def test_contact_chooses_its_detection():
    verts, faces = cloth_grid(3, size=0.3)
    scene = yasps.scene("choice")
    v = scene.addMesh("m").addPrimitive("v", numInstances=len(verts))
    x = v.addAttribute("position", rows=3)
    x.updateValue(verts[:, :, None])
    scene.addMinimizeTarget(x)
    assert isinstance(Contact(scene, v, faces=faces, kappa=1.0).detection,
                      RuntimeDetection)
    assert isinstance(Contact(scene, v, faces=faces, kappa=1.0, name="c2",
                              detection="ipctk").detection, IpctkDetection)
    with pytest.raises(yasps.SceneError, match="detection must be one of"):
        Contact(scene, v, faces=faces, kappa=1.0, name="c3",
                detection="bvh")


def test_contact_mesh_refuses_bad_input():
    verts, faces = cloth_grid(2, size=0.3)
    edges = edges_of(faces).astype(np.int32)
    with pytest.raises(ValueError, match="not among the edges"):
        native().ContactMesh(verts, edges[1:], faces.astype(np.int32))
    with pytest.raises(ValueError, match="outside"):
        native().ContactMesh(verts, edges + 100, faces.astype(np.int32))
    mesh = native().ContactMesh(verts, edges, faces.astype(np.int32))
    with pytest.raises(ValueError, match="positions"):
        native().contact_candidates(mesh, verts[:3], verts[:3], 0.1)
    broken = verts.copy()
    broken[2, 1] = np.nan
    with pytest.raises(ValueError, match="vertex 2 has a non-finite"):
        native().contact_candidates(mesh, verts, broken, 0.1)


def test_boxes_of_no_width_are_no_crash_and_no_miss():
    """Inflation 0 and nothing moving: points give boxes of no width (the
    grid's cell size fell to 1e-300 and its cell counts overflowed, a
    segmentation fault). Points alone, and two flat sheets whose faces are
    boxes of no height: every pair of boxes that touch is a candidate
    (checked against all pairs in NumPy), and coinciding points are found."""
    # Points alone, two of them at one place.
    points = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [1.0, 2.0, 3.0],
                       [-4.0, 0.5, 2.0]])
    mesh = native().ContactMesh(points, np.zeros((0, 2), np.int32),
                                np.zeros((0, 3), np.int32))
    found = native().contact_candidates(mesh, points, points, 0.0)
    assert {tuple(sorted(r)) for r in found.vertex_vertex.tolist()} == {(1, 2)}
    # All at one point: one cell.
    same = np.zeros((5, 3))
    mesh = native().ContactMesh(same, np.zeros((0, 2), np.int32),
                                np.zeros((0, 3), np.int32))
    found = native().contact_candidates(mesh, same, same, 0.0)
    assert len(found.vertex_vertex) == 10
    # Two flat sheets, the second's vertices on the first's faces' boxes.
    verts, faces = cloth_grid(6, size=1.0)
    V = np.vstack([verts, verts + [1.0 / 12, 1.0 / 12, 0.0]])
    F = np.vstack([faces, faces + len(verts)]).astype(np.int32)
    mesh = native().ContactMesh(V, edges_of(F).astype(np.int32), F)
    found = native().contact_candidates(mesh, V, V, 0.0)
    lo, hi = V[F].min(axis=1), V[F].max(axis=1)
    inside = np.all((V[None, :, :] >= lo[:, None, :])
                    & (V[None, :, :] <= hi[:, None, :]), axis=2)
    incident = np.zeros_like(inside)
    incident[np.repeat(np.arange(len(F)), 3), F.ravel()] = True
    want = {tuple(p) for p in np.argwhere(inside & ~incident).tolist()}
    assert want and want <= {tuple(r) for r in found.face_vertex.tolist()}
    with pytest.raises(ValueError, match="inflation must be a finite"):
        native().contact_candidates(mesh, V, V, -1.0)
    with pytest.raises(ValueError, match="inflation must be a finite"):
        native().contact_candidates(mesh, V, V, float("nan"))
