"""Inexact Newton (yasps.sim.forcing): directions far from a step's
solution are solved loosely, the direction that ends a step to the
caller's tolerance, and the steps land where fully solved ones do, with
fewer CG iterations. Every frame is checked by ipctk on positions the test
reads itself."""

import importlib
import sys
from pathlib import Path

import ipctk
import numpy as np
import pytest

import yasps
from yasps.sim import NewtonSettings
from yasps.sim.forcing import LOOSEST, Forcing

# The module (yasps.sim's `newton` attribute is the function).
newton_module = importlib.import_module("yasps.sim.newton")

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "examples"))

import cloth_drape  # noqa: E402


def test_forcing_terms_lie_between_the_tolerances():
    forcing = Forcing(1e-4)
    # The first gradient sets the scale: far from the solution, loosest.
    assert forcing.tolerance(3.0) == LOOSEST
    # r min(0.5, sqrt(r)) with r the gradient over the first.
    assert forcing.tolerance(0.09) == pytest.approx(0.03 * np.sqrt(0.03))
    assert forcing.tolerance(3e-2) == pytest.approx(1e-3)
    assert forcing.tolerance(3e-5) == 1e-4
    assert forcing.tolerance(float("nan")) == 1e-4
    # Gradients that grow stay at the loosest.
    assert forcing.tolerance(30.0) == LOOSEST
    # A caller's tolerance above the loosest is kept throughout.
    assert Forcing(0.1).tolerance(1.0) == 0.1
    # A zero first gradient gives no scale: the caller's tolerance.
    zero = Forcing(1e-4)
    assert zero.tolerance(0.0) == 1e-4 and zero.tolerance(1.0) == 1e-4
    with pytest.raises(ValueError):
        Forcing(-1.0)


def drape_run(monkeypatch, frames: int, **options):
    """The cloth draped over a box for ``frames`` frames: per frame its
    report and the tolerances its PCG solves were given; the cloth's final
    positions. Each frame is checked by ipctk. Block-Jacobi throughout:
    the runs compare CG iterations, which the multilevel preconditioner
    (that "auto" may choose where solves are tight) would count apart."""
    monkeypatch.setattr(yasps.config, "preconditioner", "block-jacobi")
    drape = cloth_drape.build()
    stepper = drape.stepper(**options)
    tolerances = []
    original = newton_module.minimize_energy

    def recording(scene, *args, **kwargs):
        try:
            return original(scene, *args, **kwargs)
        finally:
            tolerances.append(scene.lastSolve["tolerance"])

    monkeypatch.setattr(newton_module, "minimize_energy", recording)
    frames_out = []
    for _ in range(frames):
        start = len(tolerances)
        report = stepper.step(warn=False)
        frames_out.append((report, tolerances[start:]))
        V = np.concatenate([drape.x.value[:, :, 0], drape.box])
        mesh = ipctk.CollisionMesh(V, ipctk.edges(drape.faces), drape.faces)
        assert not ipctk.has_intersections(mesh, V)
    monkeypatch.setattr(newton_module, "minimize_energy", original)
    return frames_out, drape.x.value[:, :, 0].copy()


def test_loose_directions_far_away_and_a_tight_one_at_the_end(monkeypatch):
    forced, x_forced = drape_run(monkeypatch, 12)
    exact, x_exact = drape_run(monkeypatch, 12, settings=NewtonSettings(
        cg_forcing=False))
    loose = 0
    for report, tolerances in forced:
        assert report.converged
        # The direction that ended the step was solved to cg_tolerance.
        assert tolerances[-1] == 1e-4
        assert all(1e-4 <= t <= LOOSEST for t in tolerances)
        loose += sum(t > 1e-4 for t in tolerances)
    assert loose > 12
    assert sum(r.tightened_solves for r, _ in forced) > 0
    for report, tolerances in exact:
        assert report.converged and set(tolerances) == {1e-4}
    # Fewer CG iterations, the same cloth (each step converged to a
    # direction below 1e-2 m/s x dt = 1e-4 m in either run).
    cg_forced = sum(sum(r.cg_iterations) for r, _ in forced)
    cg_exact = sum(sum(r.cg_iterations) for r, _ in exact)
    assert cg_forced < 0.85 * cg_exact
    assert np.abs(x_forced - x_exact).max() < 1e-4
