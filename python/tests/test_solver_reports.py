"""What minimizeEnergy says about its solve: the residual recomputed from
the step, a tolerance past round-off, the energy-norm and preconditioned
stopping rules, a warning where a converged residual says little about the
step, a target no energy reads, and the energy and instance behind a NaN.
References: NumPy's dense solve of the assembled system."""

import warnings

import numpy as np
import pytest

import yasps
from yasps.runtime import cpu_backend
from yasps.sim import NewtonSettings, newton
from yasps.solve import assemble

from test_minimize import soft_box, system_arrays


def spring_chain(n: int, ratio: float, loads):
    """Nodes on a line (scalar positions from 0), node 0 hung on a wall; the
    springs alternate stiffness ``ratio`` and 1; ``loads`` (n,) pull the
    nodes (energy -f x). Returns (scene, x)."""
    s = yasps.scene("chain")
    m = s.addMesh("m")
    nodes = m.addPrimitive("nodes", numInstances=n)
    x = nodes.addAttribute("x", rows=1)
    x.updateValue(np.zeros((n, 1)))
    force = nodes.addConstant("f", rows=1)
    force.updateValue(np.asarray(loads, float).reshape(n, 1))
    stiffness = np.where(np.arange(n) % 2 == 0, ratio, 1.0)
    wall = nodes.addConstant("wall", rows=1)
    wall.updateValue(np.r_[stiffness[0], np.zeros(n - 1)].reshape(n, 1))
    s.addEnergy(nodes.addAttribute("load", computed_attribute=
                                   0.5 * wall * x * x - force * x))
    springs = m.addPrimitive("springs", numInstances=n - 1)
    k = springs.addConstant("k", rows=1)
    k.updateValue(stiffness[1:].reshape(-1, 1))
    ends = springs.addAttribute("ends", through=springs.addConnectivity(
        "s2n", nodes, np.stack([np.arange(n - 1), np.arange(1, n)], 1), 2),
        source=x)
    stretch = ends.row(1) - ends.row(0)
    s.addEnergy(springs.addAttribute("spring", computed_attribute=
                                     0.5 * k * stretch * stretch))
    s.addMinimizeTarget(x)
    return s, x


def stiff_load(n: int, ratio: float) -> np.ndarray:
    loads = np.zeros(n)
    loads[0], loads[-1] = ratio, 1.0
    return loads


def exact_step(scene):
    g, H = system_arrays(assemble(scene, cpu_backend()).system)
    return np.linalg.solve(H, g), H


def test_the_reported_residual_is_recomputed_from_the_step():
    s = soft_box()
    (dx,) = s.minimizeEnergy(tolerance=1e-8)
    g, H = system_arrays(assemble(s, cpu_backend()).system)
    step = dx.reshape(-1)   # one 3x1 target: the DoF order
    want = np.linalg.norm(g - H @ step) / np.linalg.norm(g)
    assert s.lastSolve["relativeResidual"] == pytest.approx(want, rel=1e-6)
    assert s.lastSolve["stop"] == "converged"


def test_a_tolerance_past_round_off_is_reported_not_converged():
    s = soft_box()
    with pytest.raises(yasps.SolverError, match="below what round-off") as err:
        s.minimizeEnergy(tolerance=1e-22, maxIterations=100000)
    assert err.value.info["stop"] == "round_off"
    assert err.value.info["residualReplacements"] >= 2
    assert 1e-22 < err.value.info["relativeResidual"] < 1e-10


def test_a_converged_residual_that_says_little_warns():
    """Stiffness ratio 1e8: one iteration meets tolerance 1e-4 with the
    soft end hardly solved; the solve warns."""
    n = 40
    s, _ = spring_chain(n, 1e8, stiff_load(n, 1e8))
    want, _ = exact_step(s)
    with pytest.warns(yasps.IllConditionedSolve, match="diagonal ratio"):
        (dx,) = s.minimizeEnergy(tolerance=1e-4)
    assert s.lastSolve["iterations"] == 1
    error = np.linalg.norm(dx.reshape(-1) - want) / np.linalg.norm(want)
    assert error > 0.9
    assert s.lastSolve["errorBound"] > 1
    # Once per scene: a Newton loop is not flooded.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s.minimizeEnergy(tolerance=1e-4)
    assert s.lastSolve["errorBound"] > 1


def test_newton_takes_the_energy_norm_rule():
    n = 40
    s, x = spring_chain(n, 1e4, stiff_load(n, 1e4))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # Every direction to cg_tolerance: the chain's energy is
        # quadratic, so exact directions converge in three iterations.
        report = newton(s, x, tolerance=1e-12, settings=NewtonSettings(
            max_iterations=3, cg_tolerance=1e-6, cg_stopping="energy_norm",
            cg_forcing=False))
    assert report.converged and s.lastSolve["stopping"] == "energy_norm"


def test_energy_norm_stopping_measures_the_step():
    n = 40
    s, _ = spring_chain(n, 1e4, stiff_load(n, 1e4))
    want, H = exact_step(s)

    def energy_error(dx):
        e = dx.reshape(-1) - want
        return np.sqrt(e @ H @ e / (want @ H @ want))

    with pytest.warns(yasps.IllConditionedSolve):
        (by_residual,) = s.minimizeEnergy(tolerance=1e-4)
    (by_energy,) = s.minimizeEnergy(tolerance=1e-4, stopping="energy_norm")
    assert s.lastSolve["stopping"] == "energy_norm"
    assert s.lastSolve["energyError"] <= 1e-4
    assert energy_error(by_energy) <= 1e-4 < energy_error(by_residual)


def preconditioned_residual(dx, g, H, block=3):
    """sqrt(r^T M^-1 r / g^T M^-1 g) with r = g - H dx and M the
    block-diagonal of H (3x3 blocks: one per vertex of the soft box)."""
    inverse = np.zeros_like(H)
    for start in range(0, len(g), block):
        cut = slice(start, start + block)
        inverse[cut, cut] = np.linalg.inv(H[cut, cut])
    r = g - H @ dx.reshape(-1)
    return np.sqrt((r @ inverse @ r) / (g @ inverse @ g))


def test_the_preconditioned_rule_stops_at_the_first_iterate_that_meets_it():
    """GIPC's and the paper's rule, r^T M^-1 r <= tol^2 g^T M^-1 g, judged
    here with NumPy on the assembled system: the solve stops at the first
    iterate that meets it; one iteration earlier it is not met."""
    s = soft_box()
    g, H = system_arrays(assemble(s, cpu_backend()).system)
    tolerance = 1e-2
    (dx,) = s.minimizeEnergy(tolerance=tolerance, stopping="preconditioned")
    info = s.lastSolve
    assert info["stopping"] == "preconditioned" and info["converged"]
    assert info["preconditionedResidual"] <= tolerance
    assert preconditioned_residual(dx, g, H) == pytest.approx(
        info["preconditionedResidual"], rel=1e-6)
    with pytest.raises(yasps.SolverError) as err:
        s.minimizeEnergy(tolerance=tolerance, stopping="preconditioned",
                         maxIterations=info["iterations"] - 1)
    (early,) = err.value.solution
    assert preconditioned_residual(early, g, H) > tolerance


def test_well_conditioned_solves_do_not_warn():
    s = soft_box()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s.minimizeEnergy(tolerance=1e-6)
    assert s.lastSolve["errorBound"] < 1
    assert s.lastSolve["conditionEstimate"] >= 1


def test_a_target_no_energy_reads_is_an_error():
    s = soft_box()
    idle = s.m.addPrimitive("idle", numInstances=2)
    y = idle.addAttribute("y", rows=3)
    y.updateValue(np.ones((2, 3)))
    s.addMinimizeTarget([y])
    with pytest.raises(yasps.SceneError, match="no energy reads data attribute 'y'.*'m.idle'"):
        s.minimizeEnergy()
    # Fixed, its step is zero by request.
    s.minimizeEnergy(fixed=[None, np.ones(2, dtype=bool)])


def test_a_nan_names_the_energy_and_the_instance():
    s = soft_box()
    v = s.m.v
    bad = np.ones((len(v["x"].value), 1))
    bad[3] = -1.0
    c = v.addConstant("c", rows=1)
    c.updateValue(bad)
    r2 = v["x"].squaredNorm()
    # log(c |x|^2) |x|^2: its gradient at instance 3 holds log(-|x|^2).
    s.addEnergy(v.addAttribute("logs", computed_attribute=(c * r2).log() * r2))
    with pytest.raises(yasps.SolverError,
                       match="local gradient of computed attribute 'logs'.*at instance 3") as err:
        s.minimizeEnergy()
    assert err.value.info["stop"] == "non_finite"


def test_stopping_rules_are_checked():
    with pytest.raises(ValueError, match="stopping must be one of"):
        soft_box().minimizeEnergy(stopping="energy")
