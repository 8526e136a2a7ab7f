"""The paper's scenes (examples/paper) at small scale for a few frames: no
intersection in any frame (ipctk, on positions the test computes itself),
every accepted Newton step lowers the energy, nothing is NaN, and the
physics each scene is about. Also the cage helpers against their
definitions."""

import sys
from pathlib import Path

import ipctk
import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
DATA = REPO.parent / "shared" / "data"
sys.path.insert(0, str(REPO / "examples" / "paper"))

import yasps  # noqa: E402
from yasps.sim import (cage_grid, hex8_gauss_points, hex_tets,  # noqa: E402
                       signed_tet_volumes)

needs_bunny = pytest.mark.skipif(not (DATA / "bunny-1.8k.msh").exists(),
                                 reason="../shared/data/bunny-1.8k.msh missing")


def step_and_check(stepper, bodies, frames: int, check=None):
    """Steps ``frames`` frames; after each: finite positions, energy lowered
    by every accepted step, no intersection among all bodies' surfaces by
    ipctk on a collision mesh of the test's own, and ``check(frame)``."""
    for frame in range(1, frames + 1):
        report = stepper.step()
        assert all(after <= before for before, after in report.step_energies)
        parts, faces, offset = [], [], 0
        for body in bodies.values():
            V = body.now()
            assert np.isfinite(V).all()
            parts.append(V)
            faces.append(body.faces + offset)
            offset += len(V)
        V = np.concatenate(parts)
        F = np.concatenate(faces).astype(np.int32)
        mesh = ipctk.CollisionMesh(V, ipctk.edges(F), F)
        assert not ipctk.has_intersections(mesh, V)
        if check is not None:
            check(frame)


def pinned_corners_stay(stepper, mask_index: int = 0):
    """A check that the first target's pinned vertices do not move."""
    target = stepper.targets[mask_index]
    mask = stepper.fixed[mask_index]
    start = target.value[mask].copy()
    return lambda frame: np.testing.assert_array_equal(target.value[mask],
                                                        start)


@needs_bunny
def test_cloths_on_bunny():
    """9.1: the bunny falls onto the pinned cloth, a cloth layer after it.
    With the cloth of the paper's own script (1 kg over 5 m, its stiffness
    times a 1 mm thickness) the systems are well conditioned: the residual
    bounds the step's error well below 1, and no solve warns. The bunny,
    its bottom 0.6 m over the cloth, lands on it in frame 51 or so."""
    import warnings
    import cloths_on_bunny
    stepper, contact, bodies = cloths_on_bunny.build("small", 1)
    assert stepper.settings.cg_stopping == "preconditioned"
    z0 = bodies["bunny"].now()[:, 2].mean()
    with warnings.catch_warnings():
        warnings.simplefilter("error", yasps.IllConditionedSolve)
        step_and_check(stepper, bodies, 56, pinned_corners_stay(stepper))
        stepper.scene.minimizeEnergy(tolerance=1e-4, fixed=stepper.fixed)
        assert stepper.scene.lastSolve["errorBound"] < 1
    assert bodies["bunny"].now()[:, 2].mean() < z0 - 1.0
    assert sum(contact.update().values()) > 0  # the bunny is on the cloth


@needs_bunny
def test_many_bunnies():
    """9.2: soft and affine bunnies through one UNION; the affine ones stay
    nearly rigid (|A^T A - I| small)."""
    import many_bunnies
    stepper, contact, bodies, affine = many_bunnies.build("small", 2)

    def rigid(frame):
        for body in affine:
            A = body.A.value[0]
            assert np.abs(A.T @ A - np.eye(3)).max() < 1e-3

    corners = pinned_corners_stay(stepper)
    heights = [body.t.value[0, 2, 0] for body in affine]
    step_and_check(stepper, bodies, 4, lambda f: (corners(f), rigid(f)))
    assert affine
    assert all(body.t.value[0, 2, 0] < z for body, z in zip(affine, heights))


@needs_bunny
@pytest.mark.parametrize("discretization", ["tet4", "hex8"])
def test_caged_bunny(discretization):
    """9.3: the surface follows its cage (the embedding reproduces the
    cage's trilinear map) while both fall."""
    import caged_bunny
    stepper, contact, bodies, cage = caged_bunny.build("small", discretization,
                                                       4)
    corners = stepper.targets[1]
    z0 = corners.value[:, 2, 0].mean()

    def embedded(frame):
        world = bodies["bunny"].now()
        surface = bodies["bunny"].positions.owner
        weights = surface["w"].value[:, :, 0]
        ids = surface.connectivities["p2c"].indices
        want = np.einsum("nk,nkd->nd", weights, corners.value[ids][:, :, :, 0])
        assert np.abs(world - want).max() < 1e-12

    step_and_check(stepper, bodies, 3, embedded)
    assert corners.value[:, 2, 0].mean() < z0


@needs_bunny
def test_mixed_materials():
    """9.4: the fixed strip does not move, the affine ends stay nearly
    rigid, and the soft part lets the ends sag under gravity."""
    import mixed_materials
    stepper, contact, bodies, info = mixed_materials.build("small")
    parts, ends, where, rest = (info[k] for k in ("parts", "ends", "where",
                                                 "rest"))

    def strip_fixed(frame):
        world = bodies["bunny"].now()
        np.testing.assert_array_equal(world[where[parts["fixed"]]],
                                      rest[parts["fixed"]])
        for body in ends.values():
            A = body.A.value[0]
            assert np.abs(A.T @ A - np.eye(3)).max() < 1e-3

    step_and_check(stepper, bodies, 4, strip_fixed)
    soft = stepper.targets[0].value[:, 2, 0]
    assert soft.mean() < rest[parts["soft"], 2].mean()


def test_cage_helpers_against_their_definitions():
    """cage_grid: every point is reproduced by its cell's trilinear weights
    (non-negative, summing to one); hex_tets: 6 positive tets filling each
    cell; hex8_gauss_points: F = I at rest and the weights sum to the cells'
    volume."""
    rng = np.random.default_rng(5)
    points = rng.uniform(-1, 1, (400, 3)) * [1.0, 0.5, 0.3]
    cage = cage_grid(points, 5)
    assert np.abs(cage.embed(cage.vertices) - points).max() < 1e-12
    assert cage.weights.min() >= 0
    assert np.abs(cage.weights.sum(axis=1) - 1).max() < 1e-12
    side = cage.vertices[cage.hexes[0, 1], 0] - cage.vertices[cage.hexes[0, 0], 0]
    volumes = signed_tet_volumes(cage.vertices, hex_tets(cage.hexes))
    assert volumes.min() > 0
    assert volumes.sum() == pytest.approx(len(cage.hexes) * side ** 3, rel=1e-12)
    G, w = hex8_gauss_points(cage.vertices, cage.hexes)
    corners = cage.vertices[np.repeat(cage.hexes, 8, axis=0)]
    F = np.einsum("mkd,mka->mda", corners, G)
    assert np.abs(F - np.eye(3)).max() < 1e-12
    assert w.sum() == pytest.approx(len(cage.hexes) * side ** 3, rel=1e-12)
    # Under a linear map the Gauss points see exactly that map.
    M = np.eye(3) + 0.1 * rng.standard_normal((3, 3))
    F = np.einsum("mkd,mka->mda", corners @ M.T, G)
    assert np.abs(F - M).max() < 1e-12


def test_pendulum_swings():
    """10.7: the masses' positions, nested through three spring angles and
    the lever's, are the NumPy map of those angles in every frame; the
    heavier block tips the lever, so the masses swing; every accepted
    Newton step lowers the energy."""
    import pendulum
    scene, parts = pendulum.build()
    stepper = pendulum.stepper(scene, parts)
    start = parts["position"].compute().value[:, :, 0].copy()
    tilts = []
    for _ in range(30):
        report = stepper.step()
        assert report.converged
        assert all(after <= before for before, after in report.step_energies)
        phi = parts["phi"].value[:, 0, 0]
        psi = float(parts["psi"].value[0, 0, 0])
        world = parts["position"].compute().value[:, :, 0]
        assert np.isfinite(world).all()
        np.testing.assert_allclose(
            world, pendulum.reference_positions(phi, psi), atol=1e-12)
        # The drawn springs end at the blocks.
        points, _ = pendulum.pendulum_lines(phi, psi)
        n = pendulum.SEGMENTS + 1
        np.testing.assert_allclose(points[[2 * n + 1, 3 * n + 3]], world,
                                   atol=1e-12)
        tilts.append(psi)
    assert tilts[-1] - 0.4 > 0.1                      # the lever tips
    moved = parts["position"].compute().value[:, :, 0] - start
    assert np.abs(moved[:, 0]).max() > 0.01           # sideways: a swing


def test_mat_twist():
    """E.1: the held edges turn as prescribed (CCD permitting) and the
    cloth between them twists with them: rows at x = +-1/4 turn about x in
    their edge's direction, by less than the edge."""
    import mat_twist
    stepper, contact, bodies, twister = mat_twist.build("small")
    rest = stepper.targets[0].value[:, :, 0].copy()
    step_and_check(stepper, bodies, 12, lambda frame: None)
    assert twister.wanted == pytest.approx(12 * mat_twist.SPEED * stepper.dt)
    assert twister.angle == pytest.approx(twister.wanted)
    np.testing.assert_allclose(
        stepper.targets[0].value[twister.held, :, 0],
        twister.positions(stepper.time), atol=1e-12)
    x = stepper.targets[0].value[:, :, 0]
    for side in (-1.0, 1.0):
        row = np.abs(rest[:, 0] - side * 0.25) < 0.03
        ends = row & (np.abs(rest[:, 1]) > 0.4)
        y, z = x[ends, 1], x[ends, 2]
        # The row's direction in the y-z plane, from its two far ends.
        order = np.argsort(rest[ends, 1])
        dy, dz = y[order[-1]] - y[order[0]], z[order[-1]] - z[order[0]]
        angle = np.arctan2(dz, dy) * side
        assert 0.05 * twister.angle < angle < twister.angle



def spherical_triangle_areas(P, faces):
    """Solid angles of the triangles of unit points P (Van Oosterom and
    Strackee), signed by orientation."""
    a, b, c = (P[faces[:, k]] for k in range(3))
    numerator = np.einsum("ij,ij->i", a, np.cross(b, c))
    denominator = (1 + np.einsum("ij,ij->i", a, b) + np.einsum("ij,ij->i", b, c)
                   + np.einsum("ij,ij->i", c, a))
    return 2 * np.arctan2(numerator, denominator)


@needs_bunny
def test_repulsive_curve(tmp_path):
    """9.5: the bunny's surface maps one-to-one onto the sphere (triangles
    facing outwards whose solid angles cover it exactly once), the
    relaxation lowers its energy at every step, sphere vertices map back
    onto the bunny's; the curve stays on the sphere, grows, never touches
    itself in any frame (ipctk on the test's own edge mesh), lowers its
    energy at every accepted step, and maps onto the bunny's surface
    (ipctk's point-triangle distances)."""
    import warnings
    from types import SimpleNamespace
    import repulsive_curve as rc
    with warnings.catch_warnings():
        # The sphere map's barriers spread its Hessian's diagonal over ~7e6:
        # minimizeEnergy warns that the residual bound is loose there.
        warnings.simplefilter("ignore", yasps.IllConditionedSolve)
        summary = rc.simulate_curve(SimpleNamespace(
            frames=4, scale="small", output=tmp_path, no_video=True))
    mapping, curve = summary.mapping, summary.curve
    S = mapping.sphere
    np.testing.assert_allclose(np.linalg.norm(S, axis=1), 1.0, atol=1e-12)
    solid = spherical_triangle_areas(S, mapping.faces)
    assert (solid > 0).all()
    assert abs(solid.sum() - 4 * np.pi) < 1e-9
    np.testing.assert_allclose(mapping.to_surface(S), mapping.surface,
                               atol=1e-12)
    assert (mapping.vertex_density() > 0).all()
    r = summary.report
    assert r.iterations > 0
    assert all(after <= before for before, after in r.step_energies)
    assert len(summary.positions) == 4
    edges = curve.edges.astype(np.int32)
    for P in summary.positions:
        assert np.isfinite(P).all()
        np.testing.assert_allclose(np.linalg.norm(P, axis=1), 1.0,
                                   atol=1e-12)
        mesh = ipctk.CollisionMesh(P, edges, np.zeros((0, 3), np.int32))
        collisions = ipctk.NormalCollisions()
        collisions.build(mesh, P, 0.5)
        assert collisions.compute_minimum_distance(mesh, P) > 0
    assert not summary.intersections
    assert summary.lengths[-1] > 1.2 * summary.lengths[0]
    P = curve.points()
    on_bunny = mapping.to_surface(P)
    T = mapping.surface[mapping.faces]
    for point in on_bunny:
        closest = min(ipctk.point_triangle_distance(point, *t) for t in T)
        assert closest < 1e-20   # squared distance
