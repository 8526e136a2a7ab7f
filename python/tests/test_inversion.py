"""IPC's Neo-Hookean with the inversion step bound: the bound is the first
fraction of a step where a tet keeps a tenth of its volume (against
determinants sampled finely, written here), and a soft box crushed by its
prescribed top far faster than it can give keeps every tet positive, where
stable Neo-Hookean without the bound inverts; the material says whether
its tets are guarded."""

import numpy as np
import pytest

import yasps
from yasps.sim import (ImplicitEuler, add_elastic_tets, add_free_vertices,
                       box_tet_mesh, inversion_free_fraction,
                       lame, lumped_masses, signed_tet_volumes)
from yasps.sim.inversion import ElementsInverted, guarded_step_bound


def volumes(x, tets):
    corners = x[tets]
    edges = np.stack([corners[:, k] - corners[:, 0] for k in (1, 2, 3)],
                     axis=2)
    return np.linalg.det(edges)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_bound_is_the_first_tenth_of_a_volume(seed):
    rng = np.random.default_rng(seed)
    verts, tets = box_tet_mesh(2, size=1.0)
    x = verts + rng.normal(scale=0.05, size=verts.shape)
    p = rng.normal(scale=0.6, size=verts.shape)
    alpha = inversion_free_fraction(x, p, tets)
    start = volumes(x, tets)
    assert (start > 0).all() and 0.0 < alpha < 1.0
    fine = np.linspace(0.0, 1.0, 20001)
    first = min(fine[np.argmax([(volumes(x + a * p, tets) <= 0.1 * start)
                                .any() for a in fine])], 1.0)
    assert alpha == pytest.approx(first, abs=1e-4)
    assert (volumes(x + alpha * p, tets) >= 0.1 * start - 1e-12).all()
    assert inversion_free_fraction(x, 0.01 * p, tets) == 1.0


def crushed_box(material: str, guard=None):
    """A soft box whose top is prescribed to move down 6 cm per 1 cm step
    (its bottom fixed): 12 steps; the smallest volume ratio seen and the
    last step's lag."""
    verts, tets = box_tet_mesh(3, size=0.1)
    s = yasps.scene(f"crush_{material}_{guard}")
    m = s.addMesh("m")
    soft = add_free_vertices(m, verts, lumped_masses(verts, tets, 1000.0))
    mu, lam = lame(1e4, 0.45)
    add_elastic_tets(m, soft.x, verts, tets, mu, lam, scale=1e-4,
                     material=material, guard_inversion=guard)
    s.addMinimizeTarget(soft.x)
    bottom = verts[:, 2] == 0.0
    top = verts[:, 2] == verts[:, 2].max()
    stepper = ImplicitEuler(s, soft.x, soft.x_hat, 0.01, fixed=bottom,
                            gravity=None)
    rest_top = verts[top]
    stepper.prescribe(soft.x, lambda time: rest_top + [0.0, 0.0, -6.0 * time],
                      mask=top)
    rest = signed_tet_volumes(verts, tets)
    smallest, lag = np.inf, 0.0
    for _ in range(12):
        report = stepper.step()
        assert report.converged
        ratio = signed_tet_volumes(soft.x.value[:, :, 0], tets) / rest
        smallest, lag = min(smallest, ratio.min()), report.prescribed_lag
    return smallest, lag


def test_a_crushed_neo_hookean_box_never_inverts():
    """IPC's Neo-Hookean guards its tets without being told; stable
    Neo-Hookean, defined past J = 0, does not."""
    smallest, lag = crushed_box("neo_hookean")
    assert 0.0 < smallest < 0.5
    assert lag > 0.1  # the top could not follow: it would have inverted
    with pytest.warns(ElementsInverted, match="stable_neo_hookean"):
        inverted, _ = crushed_box("stable_neo_hookean")
    assert inverted < 0.0


@pytest.mark.parametrize("material, guard, guarded", [
    ("neo_hookean", None, True), ("neo_hookean", False, False),
    ("stable_neo_hookean", None, False), ("stable_neo_hookean", True, True),
    ("fixed_corotated", None, False)])
def test_materials_say_whether_their_tets_are_guarded(material, guard,
                                                      guarded):
    """The guard follows the material unless overridden, and bounds the
    steps of the tets' own positions only."""
    verts, tets = box_tet_mesh(1, size=0.1)
    s = yasps.scene(f"guard_{material}_{guard}")
    m = s.addMesh("m")
    soft = add_free_vertices(m, verts, lumped_masses(verts, tets, 1000.0))
    other = add_free_vertices(s.addMesh("other"), verts, np.ones(len(verts)))
    add_elastic_tets(m, soft.x, verts, tets, 1.0, 1.0, material=material,
                     guard_inversion=guard)
    crush = np.zeros_like(verts)
    crush[verts[:, 2] > 0, 2] = -0.2   # the top through the bottom
    bound = guarded_step_bound(s, [other.x, soft.x])
    if not guarded:
        assert bound is None
        return
    assert bound([verts, verts], [crush, crush]) < 0.5
    assert guarded_step_bound(s, [other.x]) is None


def test_unknown_materials_and_lame_inputs_are_refused():
    verts, tets = box_tet_mesh(1, size=0.1)
    s = yasps.scene("materials")
    m = s.addMesh("m")
    soft = add_free_vertices(m, verts, 1.0)
    with pytest.raises(yasps.SceneError, match="material must be one of"):
        add_elastic_tets(m, soft.x, verts, tets, 1.0, 1.0, material="rubber")
    with pytest.raises(ValueError, match="Poisson"):
        lame(1e4, 0.5)
    mu, lam = lame(1e4, 0.25)
    assert mu == pytest.approx(4000.0) and lam == pytest.approx(4000.0)
