"""Collision detection per Newton step: the collision sets at line-search
candidates built from the step's swept candidates (yasps.contact.sweep)
equal ipctk's own full builds; the additive-CCD step bound is collision
free by ipctk's independent check; the pair arrays equal each ipctk
collision's own vertices and distance type."""

import ipctk
import numpy as np
import pytest

import yasps
from yasps.contact import Contact
from yasps.contact.pairs import BY_NAME
from yasps.sim import cloth_grid

from conftest import ipctk_collisions

DHAT = 0.01


def two_sheets(gap: float, angle: float = 0.5, shift=(0.0, 0.0)):
    """Two 6x6-cell sheets of free vertices ``gap`` apart, the upper one
    turned by ``angle`` (generic pairs) and shifted in its plane:
    (scene, positions, contact)."""
    verts, faces = cloth_grid(6, size=0.3)
    c, s = np.cos(angle), np.sin(angle)
    turned = verts @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]).T
    start = np.vstack([verts, turned + [shift[0], shift[1], gap]])
    scene = yasps.scene("sheets")
    v = scene.addMesh("m").addPrimitive("v", numInstances=len(start))
    x = v.addAttribute("position", rows=3)
    x.updateValue(start[:, :, None])
    scene.addMinimizeTarget(x)
    contact = Contact(scene, v, faces=np.vstack([faces, faces + len(verts)]),
                      dhat=DHAT, kappa=1.0)
    return scene, x, contact


class RecordedBroadPhases:
    """The contact's broad phase, counting its calls."""

    def __init__(self, broad_phase):
        self.broad_phase, self.calls = broad_phase, 0

    def __call__(self, *args):
        self.calls += 1
        return self.broad_phase(*args)


def collision_set(collisions, mesh) -> set:
    """Each collision as (type, its vertices, weight); the two points of a
    vertex-vertex pair and the two edges of an edge-edge pair unordered
    (broad phases may list a pair either way round)."""
    out = set()
    for group in (collisions.vv_collisions, collisions.ev_collisions,
                  collisions.ee_collisions, collisions.fv_collisions):
        for c in group:
            ids = [int(i) for i in c.vertex_ids(mesh.edges, mesh.faces)
                   if i >= 0]
            if isinstance(c, ipctk.VertexVertexNormalCollision):
                ids = frozenset(ids)
            elif isinstance(c, ipctk.EdgeEdgeNormalCollision):
                ids = frozenset((frozenset(ids[:2]), frozenset(ids[2:])))
            else:
                ids = tuple(ids)
            out.add((type(c).__name__, ids, c.weight))
    return out


def pair_set(contact) -> set:
    """The contact's pairs now as (type, vertices, eps_x, weight) rows, in
    the form of collision_set's (ipctk's classes by pair type)."""
    names = {"vv": "VertexVertexNormalCollision",
             "ev": "EdgeVertexNormalCollision",
             "fv": "FaceVertexNormalCollision"}
    out = set()
    for kind, p in contact.primitives.items():
        rows = p.connectivities["v"].indices.reshape(-1, BY_NAME[kind].arity)
        for ids, w in zip(rows.tolist(), p["weight"].value.reshape(-1)):
            if kind == "vv":
                key = frozenset(ids)
            elif kind.startswith("ee"):
                key = frozenset((frozenset(ids[:2]), frozenset(ids[2:])))
            else:
                key = tuple(ids)
            out.add((names.get(kind, "EdgeEdgeNormalCollision"), key,
                     float(w)))
    return out


def test_line_search_collision_sets_use_the_step_candidates():
    """Along a step that presses the sheets together and slides them, the
    pairs at every candidate come from the step's candidates (no new broad
    phase) and are exactly ipctk's own full build there. The sheets are
    shifted off the symmetric layout, where a vertex sits exactly over
    another and closest-feature types tie (test_contact_detection checks
    that case by energy)."""
    scene, x, contact = two_sheets(gap=0.004, shift=(0.0013, 0.0007))
    recorded = RecordedBroadPhases(contact.detection.candidates)
    contact.detection.candidates = recorded
    rng = np.random.default_rng(3)
    step = np.zeros_like(x.value)
    half = len(step) // 2
    step[half:, 2, 0] = -0.006
    step[half:, :2, 0] = 0.02 * rng.standard_normal((half, 2))
    start = x.value.copy()
    bound, _ = contact.step_bound_and_length([step])
    assert 0.0 < bound < 1.0
    assert recorded.calls == 1
    for alpha in (0.0, 0.3, 0.5 * bound, bound):
        x.updateValue(start + alpha * step)
        contact.update()
        reference = ipctk_collisions(contact)
        assert not reference.empty()
        assert pair_set(contact) == collision_set(reference, contact.mesh)
    assert recorded.calls == 1
    # Positions outside the swept boxes get a broad phase of their own.
    x.updateValue(start + 2.0 * step)
    contact.update()
    assert recorded.calls == 2
    assert pair_set(contact) == collision_set(ipctk_collisions(contact),
                                              contact.mesh)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_additive_ccd_bound_is_collision_free(seed):
    """Random steps that would push the sheets through each other: the
    bound stops short, ipctk's own CCD finds the bounded step free of
    collisions, and the surfaces keep a positive distance there."""
    scene, x, contact = two_sheets(gap=0.003)
    rng = np.random.default_rng(seed)
    step = 0.01 * rng.standard_normal(x.value.shape)
    step[len(step) // 2:, 2, 0] -= 0.01
    V0 = contact.world()
    bound = contact.step_bound([step])
    V1 = V0 + step[:, :, 0]
    assert ipctk.is_step_collision_free(contact.mesh, V0, V1) is False
    assert 0.0 < bound < 1.0
    V = V0 + bound * (V1 - V0)
    assert ipctk.is_step_collision_free(contact.mesh, V0, V)
    assert not ipctk.has_intersections(contact.mesh, V)
    x.updateValue(x.value + bound * step)
    assert contact.min_distance() > 0.0


def reference_pair(collision, mesh):
    """One ipctk collision's pair type and vertices in that type's order,
    spelled out per collision from its class and known distance type."""
    ids = list(collision.vertex_ids(mesh.edges, mesh.faces))
    if isinstance(collision, ipctk.VertexVertexNormalCollision):
        return "vv", ids[:2]
    if isinstance(collision, ipctk.EdgeVertexNormalCollision):
        assert collision.known_dtype() == ipctk.PointEdgeDistanceType.P_E
        return "ev", ids[:3]
    if isinstance(collision, ipctk.FaceVertexNormalCollision):
        assert collision.known_dtype() == ipctk.PointTriangleDistanceType.P_T
        return "fv", ids
    T = ipctk.EdgeEdgeDistanceType
    a0, a1, b0, b1 = ids
    return {T.EA_EB: ("ee", [a0, a1, b0, b1]),
            T.EA0_EB0: ("ee_vv", [a0, a1, b0, b1]),
            T.EA0_EB1: ("ee_vv", [a0, a1, b1, b0]),
            T.EA1_EB0: ("ee_vv", [a1, a0, b0, b1]),
            T.EA1_EB1: ("ee_vv", [a1, a0, b1, b0]),
            T.EA0_EB: ("ee_ev", [a0, a1, b0, b1]),
            T.EA1_EB: ("ee_ev", [a1, a0, b0, b1]),
            T.EA_EB0: ("ee_ev", [b0, b1, a0, a1]),
            T.EA_EB1: ("ee_ev", [b1, b0, a0, a1])}[collision.known_dtype()]


@pytest.mark.parametrize("angle, shift, kinds", [
    (0.5, (0.0, 0.0), {"ev", "fv", "ee"}),
    (0.0, (0.025, 0.0), {"ev", "ee", "ee_ev"}),
    (0.0, (0.05, 0.05), {"vv", "ev", "fv", "ee", "ee_ev", "ee_vv"})])
def test_pair_arrays_match_each_collision(angle, shift, kinds):
    """Turned sheets (generic pairs) and parallel ones shifted by half a
    cell or a whole one (parallel edges, mollified end-point types; vertices
    over vertices): the arrays per pair type hold exactly each collision's
    vertices, eps_x and weight."""
    from yasps.contact.pairs import collision_pairs
    scene, x, contact = two_sheets(gap=0.004, angle=angle, shift=shift)
    collisions = ipctk_collisions(contact)
    want = {}
    for group in (collisions.vv_collisions, collisions.ev_collisions,
                  collisions.ee_collisions, collisions.fv_collisions):
        for c in group:
            kind, ids = reference_pair(c, contact.mesh)
            eps = c.eps_x if isinstance(c, ipctk.EdgeEdgeNormalCollision) \
                else 1.0
            want.setdefault(kind, []).append((*ids, eps, c.weight))
    got = collision_pairs(collisions, contact.mesh.edges, contact.mesh.faces)
    assert {k for k, pairs in got.items() if len(pairs.vertices)} == \
        set(want) >= kinds
    for kind, pairs in got.items():
        rows = [(*v, e, w) for v, e, w in zip(pairs.vertices.tolist(),
                                               pairs.eps_x, pairs.weight)]
        assert sorted(rows) == sorted(want.get(kind, []))


@pytest.mark.parametrize("gap, floor", [(1e-5, 1e-9), (4e-9, 1e-9),
                                        (6e-10, 3e-10)])
def test_ccd_keeps_surfaces_apart(gap, floor):
    """A sheet pushed straight through another stops at least
    MIN_SEPARATION (1e-9 m) from it, or at half the gap where the sheets
    start closer than twice that: distances never shrink geometrically
    towards rounding. ipctk measures the distance at the bound."""
    from yasps.contact import MIN_SEPARATION
    assert MIN_SEPARATION == 1e-9
    scene, x, contact = two_sheets(gap=gap, angle=0.3)
    step = np.zeros_like(x.value)
    step[len(step) // 2:, 2, 0] = -0.01
    bound = contact.step_bound([step])
    assert 0.0 < bound < 1.0
    x.updateValue(x.value + bound * step)
    V = contact.world()
    close = ipctk.NormalCollisions()
    close.build(contact.mesh, V, DHAT)
    distance = np.sqrt(close.compute_minimum_distance(contact.mesh, V))
    assert floor <= distance < gap
