"""Contact's ``points``: which vertices on no face or edge take part. With
points=False a tet mesh's inner vertices leave the collision mesh (as in
ipctk's build_from_full_mesh); the pairs, renumbered to the union's
vertices, are ipctk's on the surface-only mesh, the step bound is ipctk's,
and an inner vertex near its own surface is no longer pushed off it."""

import ipctk
import numpy as np
import pytest

import yasps
from yasps.contact import Contact, edges_of, surface_of
from yasps.sim import box_tet_mesh

DHAT = 0.02


def tet_box_and_particles(points, inner_offset=0.0):
    """A 3x3x3-cell tet box (8 inner vertices), a triangle and 20 particles
    just above its top, as one primitive (in that order); the inner vertex
    nearest the top moved up by ``inner_offset``. Returns (scene,
    primitive, contact, faces, inner)."""
    verts, tets = box_tet_mesh(3, size=0.3)
    triangle = np.array([[0.043, 0.061, 0.31], [0.257, 0.112, 0.309],
                         [0.118, 0.263, 0.312]])
    faces = np.vstack([surface_of(tets), [len(verts) + np.arange(3)]])
    inner = np.setdiff1d(np.arange(len(verts)), surface_of(tets))
    top = inner[np.argmax(verts[inner, 2])]
    verts[top, 2] += inner_offset
    rng = np.random.default_rng(3)
    particles = rng.uniform([0.02, 0.02, 0.305], [0.28, 0.28, 0.315], (20, 3))
    V = np.vstack([verts, triangle, particles])
    scene = yasps.scene("points")
    v = scene.addMesh("m").addPrimitive("v", numInstances=len(V))
    x = v.addAttribute("position", rows=3)
    x.updateValue(V[:, :, None])
    scene.addMinimizeTarget(x)
    contact = Contact(scene, v, faces=faces, dhat=DHAT, kappa=1.0,
                      points=points(len(verts) + 3, len(V)))
    return scene, v, contact, faces, inner


def row(kind: str, ids) -> tuple:
    """A pair as (kind, vertex ids), the two edges of an edge-edge pair
    and the two points of a point-point pair unordered (broad phases list
    them either way round)."""
    ids = [int(i) for i in ids]
    if kind == "vv":
        ids = sorted(ids)
    elif kind.startswith("ee"):
        ids = sum(sorted([ids[:2], ids[2:]]), [])
    return kind, tuple(ids)


def pair_rows(contact) -> set:
    """The contact's barrier pairs as rows."""
    return {row(kind, ids) for kind, p in contact.primitives.items()
            for ids in p.connectivities["v"].indices.tolist()}


def reference_rows(mesh: ipctk.CollisionMesh, V: np.ndarray) -> set:
    """ipctk's collision set on ``mesh`` at full positions V, its vertex
    ids renumbered to the full mesh's."""
    from yasps.contact.pairs import collision_pairs
    collisions = ipctk.NormalCollisions()
    collisions.build(mesh, mesh.vertices(V), DHAT)
    full = np.array([mesh.to_full_vertex_id(i)
                     for i in range(mesh.num_vertices)])
    rows = set()
    for kind, pairs in collision_pairs(collisions, mesh.edges,
                                       mesh.faces).items():
        rows |= {row(kind, full[ids]) for ids in pairs.vertices}
    return rows


def test_surface_only_pairs_are_ipctks_on_the_full_mesh():
    def particles_only(box, count):
        mask = np.zeros(count, dtype=bool)
        mask[box:] = True
        return mask

    for points in (lambda box, count: False, particles_only):
        _, _, contact, faces, inner = tet_box_and_particles(points)
        V = contact.world()
        # The reference keeps the box's surface vertices (and the
        # particles where the mask says so), by ipctk's own renumbering.
        include = np.zeros(len(V), dtype=bool)
        include[faces.reshape(-1)] = True
        include[len(V) - 20:] = points is particles_only
        assert not include[inner].any()
        np.testing.assert_array_equal(contact.included,
                                      np.flatnonzero(include))
        edges = edges_of(faces).astype(np.int32)
        reference = ipctk.CollisionMesh(include.tolist(), [False] * len(V), V,
                                        edges, faces.astype(np.int32))
        contact.update()
        got = pair_rows(contact)
        assert got and got == reference_rows(reference, V)
        # Free particles (points=False) meet nothing; kept ones meet the top.
        touched = {i for _, ids in got for i in ids}
        assert bool(touched & set(range(len(V) - 20, len(V)))) == \
            (points is particles_only)
        # The step bound of a motion pushing everything down through the
        # box's top is ipctk's on the same surface mesh.
        step = np.zeros_like(V)
        step[len(V) - 20:, 2] = -0.05
        bound = contact.step_bound([step])
        want = ipctk.compute_collision_free_stepsize(
            reference, reference.vertices(V), reference.vertices(V + step),
            min_distance=1e-9, narrow_phase_ccd=ipctk.AdditiveCCD())
        if points is particles_only:
            assert 0.0 < bound < 1.0
        assert bound == pytest.approx(want, rel=1e-9)
        assert not contact.has_intersections()


def test_inner_vertex_near_its_surface_is_left_alone():
    """An inner vertex within dhat of its own box's top face: with every
    vertex a point, the barrier pairs it with that face; without inner
    points, it has no pair."""
    def everything(box, count):
        return True

    def surface_only(box, count):
        return False

    _, _, all_points, _, inner = tet_box_and_particles(everything, 0.095)
    all_points.update()
    top = inner[np.argmax(all_points.world()[inner, 2])]
    assert any(top in ids for _, ids in pair_rows(all_points))
    assert all_points.included is None
    _, _, surface, _, _ = tet_box_and_particles(surface_only, 0.095)
    surface.update()
    assert not any(top in ids for _, ids in pair_rows(surface))


def test_points_must_be_a_flag_or_a_vertex_mask():
    with pytest.raises(yasps.SceneError, match="boolean mask of 87"):
        tet_box_and_particles(lambda box, count: np.ones(count - 1, bool))
    with pytest.raises(yasps.SceneError, match="boolean mask"):
        tet_box_and_particles(lambda box, count: np.ones(count, int))
