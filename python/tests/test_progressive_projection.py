"""Progressively projected Newton: assembly projects only the local
Hessians the gradient threshold picks, and Newton converges with it.

Every direction is checked against a dense NumPy solve of the system
assembled here from ``energyDerivatives`` (exact and projected local
Hessians, placed by their DoF maps), independently of the runtime's
assembly."""

from __future__ import annotations

import numpy as np
import pytest

import yasps
from yasps.sim import (ImplicitEuler, NewtonSettings, add_elastic_tets,
                       add_free_vertices, box_tet_mesh)


def squeezed_box(mass: float, seed: int = 0, cells: int = 2):
    """A tet box of cells^3 cells (2 by default) with rest shape 1.4x its size (compressed:
    stable Neo-Hookean's local Hessians are indefinite), its vertices
    jittered; inertia of ``mass`` per vertex. Returns (scene, x, x_hat,
    elastic energy)."""
    verts, tets = box_tet_mesh(cells, size=0.2)
    rng = np.random.default_rng(seed)
    start = verts + rng.normal(scale=0.01, size=verts.shape)
    s = yasps.scene("squeezed_box")
    mesh = s.addMesh("box")
    body = add_free_vertices(mesh, start, mass)
    elastic = add_elastic_tets(mesh, body.x, verts * 1.4, tets, 1e4, 4e4,
                               scale=1e-4)
    s.addMinimizeTarget([body.x])
    return s, body.x, body.x_hat, elastic


def clamped(matrix: np.ndarray) -> np.ndarray:
    """A symmetric matrix with its negative eigenvalues set to zero."""
    values, vectors = np.linalg.eigh(matrix)
    return (vectors * np.maximum(values, 0.0)) @ vectors.T


def dense_system(scene, projected_dofs=None, project=None):
    """The gradient and Hessian over every DoF, assembled in NumPy from
    each energy's local derivatives: instances reading a True entry of
    ``projected_dofs`` (all, if None) take their projected Hessian (or
    ``project`` of their exact one on their live DoFs), the others their
    exact one. Also returns how many instances were projected."""
    size = sum(t.owner.numInstances * t.rows * t.cols
               for t in scene.minimizeTargets)
    g, H, projected = np.zeros(size), np.zeros((size, size)), 0
    for energy in scene.energies:
        d = scene.energyDerivatives(energy)
        dofs = d.dofs()
        for i in range(len(dofs)):
            live = dofs[i] >= 0
            index = dofs[i][live]
            chosen = projected_dofs is None or projected_dofs[index].any()
            local = d.hessian[i][np.ix_(live, live)]
            if chosen:
                local = d.projectedHessian[i][np.ix_(live, live)] \
                    if project is None else project(local)
            projected += bool(chosen)
            np.add.at(g, index, d.gradient[i][live])
            np.add.at(H, (index[:, None], index[None, :]), local)
    return g, H, projected


def kernel_runs(monkeypatch) -> list:
    """The paths of the kernels the CPU backend runs from now on, in a
    list that fills as they run."""
    from yasps.runtime.cpu import CpuBackend
    runs = []
    original = CpuBackend.run

    def counting(self, kernels, s, path, *args, **kwargs):
        runs.append(path)
        return original(self, kernels, s, path, *args, **kwargs)

    monkeypatch.setattr(CpuBackend, "run", counting)
    return runs


def blocks_over(g: np.ndarray, threshold: float) -> np.ndarray:
    """DoFs of the 3-blocks whose gradient reaches ``threshold``."""
    return np.repeat(np.abs(g).reshape(-1, 3).max(axis=1) >= threshold, 3)


def solve(scene, threshold):
    dx = scene.minimizeEnergy(tolerance=1e-13, maxIterations=2000,
                              projectionThreshold=threshold)
    return dx[0].reshape(-1)


def test_exact_projected_and_mixed_directions_match_dense_solves():
    scene, x, *_ = squeezed_box(mass=1.0)
    g, H_exact, _ = dense_system(scene, np.zeros(10**4, bool))
    _, H_full, instances = dense_system(scene)
    # The box's elastic Hessians are indefinite: projection changes them.
    assert np.linalg.norm(H_exact - H_full) > 1e-3 * np.linalg.norm(H_full)
    # Inertia keeps the exact system positive definite at this point.
    assert np.linalg.eigvalsh(H_exact).min() > 0
    for threshold, H in ((float("inf"), H_exact), (None, H_full),
                         (0.0, H_full)):
        np.testing.assert_allclose(solve(scene, threshold),
                                   np.linalg.solve(H, g), rtol=1e-8,
                                   atol=1e-12)
    assert scene.lastSolve["projectedInstances"] == \
        scene.lastSolve["instances"] == instances
    # Between the two: the blocks of the largest gradients only.
    threshold = 0.5 * np.abs(g).max()
    chosen = blocks_over(g, threshold)
    assert 0 < chosen.sum() < chosen.size
    _, H_mixed, projected = dense_system(scene, chosen)
    assert 0 < projected < instances
    assert np.linalg.norm(H_mixed - H_full) > 1e-6 * np.linalg.norm(H_full)
    # At a new point (the exact system assembled, then the chosen
    # instances' projections added) and again at the same point (one
    # assembly, the gradient known).
    x.updateValue(x.value)
    for _ in range(2):
        np.testing.assert_allclose(solve(scene, threshold),
                                   np.linalg.solve(H_mixed, g), rtol=1e-8,
                                   atol=1e-12)
    info = scene.lastSolve
    assert info["projectedInstances"] == projected
    assert info["descends"]
    assert info["gradientMax"] == pytest.approx(np.abs(g).max(), rel=1e-12)


def test_few_chosen_instances_are_projected_alone(monkeypatch):
    """Where the threshold picks at most a quarter of an energy's instances
    (ROWS_FRACTION), only those are projected, each from its exact Hessian
    with its negative eigenvalues clamped (NumPy's eigh here), and the
    projection kernel over all instances does not run."""
    from yasps.solve.derivatives import ROWS_FRACTION
    scene, x, _, elastic = squeezed_box(mass=1.0, seed=3, cells=3)
    g, _, _ = dense_system(scene, np.zeros(10**4, bool))
    blocks = np.abs(g).reshape(-1, 3).max(axis=1)
    threshold = np.sort(blocks)[-1] * (1 - 1e-9)   # the largest block only
    chosen = blocks_over(g, threshold)
    _, H_mixed, projected = dense_system(scene, chosen, project=clamped)
    tets = len(scene.energyDerivatives(elastic).dofs())
    # The tets around one vertex, and that vertex's inertia.
    assert 1 < projected <= ROWS_FRACTION * tets
    runs = kernel_runs(monkeypatch)
    x.updateValue(x.value)
    np.testing.assert_allclose(solve(scene, threshold),
                               np.linalg.solve(H_mixed, g), rtol=1e-8,
                               atol=1e-12)
    assert scene.lastSolve["projectedInstances"] == projected
    assert any(p.endswith("__hess") for p in runs)
    assert not any(p.endswith("__hess_proj") for p in runs)


def test_fixed_dofs_do_not_choose_projections():
    """A fixed DoF's gradient (the solve does not move it) picks nothing."""
    scene, x, *_ = squeezed_box(mass=1.0)
    g, _, _ = dense_system(scene)
    blocks = np.abs(g).reshape(-1, 3).max(axis=1)
    fixed = np.zeros(len(blocks), bool)
    fixed[np.argmax(blocks)] = True
    threshold = np.sort(blocks)[-1] * (1 - 1e-9)   # the largest block only
    scene.minimizeEnergy(tolerance=1e-10, projectionThreshold=threshold,
                         fixed=[fixed])
    assert scene.lastSolve["projectedInstances"] == 0
    assert scene.lastSolve["gradientMax"] < blocks.max()
    scene.minimizeEnergy(tolerance=1e-10, projectionThreshold=threshold)
    assert scene.lastSolve["projectedInstances"] > 0


def test_negative_threshold_is_refused():
    scene, *_ = squeezed_box(mass=1.0)
    with pytest.raises(yasps.SceneError, match="projectionThreshold"):
        scene.minimizeEnergy(projectionThreshold=-1.0)


def test_indefinite_exact_system_projects_more_and_converges():
    """Light vertices: the exact system is indefinite, CG breaks down or
    does not descend, and Newton projects more until it can go on; it
    converges to the minimiser that projected Newton finds."""
    results = {}
    for projection in ("progressive", "full"):
        scene, x, x_hat, _ = squeezed_box(mass=1e-4)
        if projection == "progressive":
            g, H_exact, _ = dense_system(scene, np.zeros(10**4, bool))
            assert np.linalg.eigvalsh(H_exact).min() < 0
        stepper = ImplicitEuler(scene, x, x_hat, dt=0.01, gravity=None,
                                velocity_tolerance=1e-4,
                                settings=NewtonSettings(
                                    max_iterations=100, projection=projection,
                                    cg_tolerance=1e-8))
        report = stepper.step()
        assert report.converged
        assert all(b <= a for a, b in report.step_energies)
        results[projection] = (x.value.copy(), report)
    progressive, full = results["progressive"][1], results["full"][1]
    assert progressive.projection_retries > 0
    assert full.projection_retries == 0
    np.testing.assert_allclose(results["progressive"][0],
                               results["full"][0], atol=1e-5)
    # Exact Hessians where they are safe: fewer Newton iterations.
    assert progressive.iterations < full.iterations


def test_unknown_projection_is_refused():
    scene, x, x_hat, _ = squeezed_box(mass=1.0)
    with pytest.raises(yasps.ArgumentError, match="projection must be one of"):
        NewtonSettings(projection="sometimes")


@pytest.mark.usefixtures("one_preconditioner")
def test_a_retry_at_the_same_point_reuses_the_derivatives(monkeypatch):
    """Another projection at the same point runs no derivative kernel
    again; any new value (even an equal one) or setting does."""
    scene, x, *_ = squeezed_box(mass=1.0)
    runs = kernel_runs(monkeypatch)
    first = solve(scene, float("inf"))
    assert any(p.endswith("__hess") for p in runs)
    runs.clear()
    g, _, _ = dense_system(scene)
    runs.clear()
    threshold = 0.5 * np.abs(g).max()
    mixed = solve(scene, threshold)
    assert [p for p in runs if "__" in p and not p.endswith("__hess_proj")] \
        == []
    x.updateValue(x.value)
    runs.clear()
    np.testing.assert_array_equal(solve(scene, float("inf")), first)
    assert any(p.endswith("__hess") for p in runs)
    runs.clear()
    monkeypatch.setattr(yasps.config, "compress_local_hessians", False)
    np.testing.assert_allclose(solve(scene, threshold), mixed, rtol=1e-12,
                               atol=1e-15)
    assert any(p.endswith("__grad") for p in runs)


def test_retries_at_the_same_point_add_only_the_new_projections(
        monkeypatch):
    """Progressive projection's retries at one point lower the threshold:
    each adds the projections of the newly chosen instances to the system
    assembled there (no re-assembly), and each solve matches a dense one
    of the system with exactly those instances projected. A threshold that
    rises again, or projects every instance, assembles anew."""
    from yasps.solve import assembly
    scene, x, *_ = squeezed_box(mass=1.0, cells=3)
    assemblies = []
    original = assembly._assemble_inputs

    def counting(*args, **kwargs):
        assemblies.append(1)
        return original(*args, **kwargs)

    monkeypatch.setattr(assembly, "_assemble_inputs", counting)
    g, _, _ = dense_system(scene, np.zeros(10**4, bool))
    largest = np.abs(g).max()
    projected_counts = []
    # Between the blocks' largest gradient entries: each retry chooses more.
    blocks = np.abs(g).reshape(-1, 3).max(axis=1)
    thresholds = [float("inf")] + list(np.quantile(blocks, (0.9, 0.7, 0.4)))
    for k, threshold in enumerate(thresholds):
        chosen = blocks_over(g, threshold)
        _, H, projected = dense_system(scene, chosen)
        np.testing.assert_allclose(solve(scene, threshold),
                                   np.linalg.solve(H, g), rtol=1e-8,
                                   atol=1e-12)
        assert scene.lastSolve["projectedInstances"] == projected
        projected_counts.append(projected)
        # The first solve assembles the exact system; the retries add.
        assert len(assemblies) == 1
    assert 0 == projected_counts[0] < projected_counts[1] < \
        projected_counts[-1] < scene.lastSolve["instances"]
    for threshold in (largest * 0.5, 0.0):
        chosen = None if threshold == 0.0 else blocks_over(g, threshold)
        _, H, projected = dense_system(scene, chosen)
        np.testing.assert_allclose(solve(scene, threshold),
                                   np.linalg.solve(H, g), rtol=1e-8,
                                   atol=1e-12)
        assert scene.lastSolve["projectedInstances"] == projected
    assert len(assemblies) == 3
