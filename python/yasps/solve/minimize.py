"""``Scene.minimizeEnergy``: the Newton direction from the assembled system,
solved by PCG on the backend (section 8; block-Jacobi, multilevel or
the cheaper of them, ``config.preconditioner``), with what the solve
says about itself (:mod:`.diagnosis`)."""

from __future__ import annotations

import time
import warnings
from typing import Callable, List, Optional, Union

import numpy as np

from ..frontend.scene import LAST_SOLVE
from .. import config
from ..frontend.attribute import owner_of
from ..frontend.errors import SceneError, YaspsError
from ..runtime import Backend
from . import preconditioner_choice
from .assembly import DofLayout, assemble
from .projection import GradientThreshold, free_gradient_max
from .diagnosis import (ERROR_BOUND_WARNING, IllConditionedSolve,
                        PrecisionWarning, f32_rounding_losses,
                        first_rounding_warning_for,
                        describe_non_finite, first_warning_for,
                        non_finite_sources,
                        residual_error_bound, unread_targets)
from ..frontend.errors import ArgumentError


class SolverError(YaspsError, RuntimeError):
    """PCG did not reach the requested tolerance; ``solution`` holds the
    last iterate (one array per target) and ``info`` the solver report."""

    def __init__(self, message: str, solution: list, info: dict):
        super().__init__(message)
        self.solution = solution
        self.info = info


def checked_fixed_mask(target, mask, where: str) -> np.ndarray:
    """``mask`` as the boolean fixed mask of ``target``: of its instances
    (N,) or of its entries (N, rows, cols), boolean or 0/1 integers; else a
    SceneError that starts with ``where``."""
    n, r, c = target.owner.numInstances, target.rows, target.cols
    given = np.asarray(mask)
    # A float mask (weights, 0.5) is a mistake, not a choice of DoFs.
    if given.dtype != bool and not (np.issubdtype(given.dtype, np.integer)
                                    and np.isin(given, (0, 1)).all()):
        raise SceneError(f"{where}: the fixed mask of {target.describe()} "
                         f"must be boolean (or 0/1 integers), got dtype "
                         f"{given.dtype}")
    if given.shape not in ((n,), (n, r, c)):
        raise SceneError(
            f"{where}: the fixed mask of {target.describe()} has shape "
            f"{given.shape}; expected ({n},) or ({n}, {r}, {c})")
    return given.astype(bool)


def fixed_dof_mask(layout: DofLayout, fixed) -> Optional[np.ndarray]:
    """The per-DoF uint8 mask of ``fixed``: one entry per target (in
    ``addMinimizeTarget``'s order), each None or a mask that
    checked_fixed_mask accepts."""
    if fixed is None:
        return None
    if len(fixed) != len(layout.targets):
        raise SceneError(f"minimizeEnergy: fixed has {len(fixed)} entries but "
                         f"there are {len(layout.targets)} targets (one mask "
                         f"or None per target, in addMinimizeTarget's order)")
    parts = []
    for target, mask in zip(layout.targets, fixed):
        n, r, c = owner_of(target).numInstances, target.rows, target.cols
        if mask is None:
            parts.append(np.zeros(n * r * c, dtype=np.uint8))
            continue
        mask = checked_fixed_mask(target, mask, "minimizeEnergy")
        if mask.shape == (n,):
            mask = np.broadcast_to(mask[:, None, None], (n, r, c))
        # DoFs are column-major within an instance.
        parts.append(np.transpose(mask, (0, 2, 1)).reshape(-1).astype(np.uint8))
    return np.ascontiguousarray(np.concatenate(parts)) if parts else None


#: minimizeEnergy's stopping rules (PCG's PcgStopping).
STOPPING_RULES = ("residual", "energy_norm", "preconditioned")

#: Why a solve failed, for SolverError's message, by PcgStop name.
_STOP_REASONS = {
    "max_iterations": "stopped at its iteration limit",
    "breakdown": "broke down (the projected Hessian is not positive "
                 "definite on the free DoFs)",
    "round_off": "cannot reach the tolerance: the residual recomputed from "
                 "the step stays above it after restarting from it (the "
                 "tolerance is below what round-off allows in this system)",
}


def minimize_energy(scene, backend: Backend,
                    tolerance: Union[float, Callable[[float], float]] = 1e-6,
                    maxIterations: int = 1000, threads: Optional[int] = None,
                    fixed: Optional[list] = None,
                    stopping: str = "residual",
                    projection_threshold: Optional[float] = None,
                    warn_conditioning: bool = True) -> List[np.ndarray]:
    """Solves H dx = g for the assembled projected Hessian and gradient,
    with dx = 0 at the ``fixed`` DoFs (see fixed_dof_mask), on ``backend``;
    ``tolerance``: PCG's relative tolerance, or a function giving it from
    the gradient's largest free entry (an inexact Newton method's forcing
    term, :mod:`yasps.sim.forcing`);
    ``stopping``: one of STOPPING_RULES; ``projection_threshold``: project
    only the instances that read a DoF block whose free gradient reaches it
    (:class:`GradientThreshold`; None: all). ``warn_conditioning=False``
    (Newton loops, which judge their directions themselves) leaves out the
    IllConditionedSolve warning; ``lastSolve['errorBound']`` still has it."""
    if not callable(tolerance) and not (tolerance >= 0):
        raise ArgumentError(f"minimizeEnergy: tolerance must be >= 0, got {tolerance}")
    if stopping not in STOPPING_RULES:
        raise ArgumentError(f"minimizeEnergy: stopping must be one of "
                            f"{', '.join(STOPPING_RULES)}, got {stopping!r}")
    if projection_threshold is not None and not (projection_threshold >= 0):
        raise SceneError(f"minimizeEnergy: projectionThreshold must be >= 0 "
                         f"(or None: project every instance), got "
                         f"{projection_threshold}")
    projection = None
    if projection_threshold is not None:
        early = DofLayout(scene.minimizeTargets)
        projection = GradientThreshold(float(projection_threshold),
                                       early.block_offsets,
                                       fixed_dof_mask(early, fixed))
    assembly = assemble(scene, backend, threads, projection)
    system, layout = assembly.system, assembly.layout
    timings = dict(assembly.seconds)
    contributions = assembly.contributions
    mask = fixed_dof_mask(layout, fixed)
    unread = unread_targets(layout, assembly.read_dofs, mask)
    if unread:
        raise SceneError(
            f"minimizeEnergy: no energy reads {', '.join(unread)}: its Newton "
            "step would be zero without meaning it. Register an energy that "
            "depends on it (inertia, elasticity, ...), fix it, or leave it "
            "out of addMinimizeTarget")
    if config.resolve_precision(scene.precision) == "f32" and \
            first_rounding_warning_for(scene):
        losses = f32_rounding_losses(layout)
        if losses:
            described = ", ".join(f"{name} ({loss:.1e} of its extent)"
                                  for name, loss in losses)
            warnings.warn(
                f"minimizeEnergy: f32 kernels round {described} to f32: the "
                "targets lie far from the origin for their extent, and "
                "their elements' edge vectors lose digits accordingly. "
                "Translate the scene toward the origin or compute it in "
                "f64 (warned once per scene)", PrecisionWarning,
                stacklevel=4)
    gradient_max = None
    if projection is not None or callable(tolerance):
        # What progressively projected Newton and a forcing term decide by:
        # the gradient's scale.
        gradient = np.empty(system.size)
        system.gradient(gradient)
        gradient_max = free_gradient_max(gradient, mask)
    if callable(tolerance):
        assert gradient_max is not None  # computed above for a callable
        tolerance = tolerance(gradient_max)
        if not (tolerance >= 0):
            raise ArgumentError(f"minimizeEnergy: the tolerance function gave "
                                f"{tolerance}, not a number >= 0")
    x = np.zeros(system.size)
    start = time.perf_counter()
    requested = config.resolve_preconditioner()
    if requested == preconditioner_choice.AUTO and \
            not backend.chooses_preconditioner:
        requested = preconditioner_choice.BLOCK_JACOBI
    pcg, preconditioner, trial_iterations = preconditioner_choice.solve(
        scene, requested, int(maxIterations),
        lambda chosen, cap: backend.solve(system, x, float(tolerance), cap,
                                          threads, mask, stopping, chosen),
        float(tolerance), stopping)
    timings["solve"] = time.perf_counter() - start
    stop = pcg.stop.name
    bound = residual_error_bound(pcg)
    info = {"iterations": int(pcg.iterations),
            "relativeResidual": float(pcg.relative_residual),
            "converged": bool(pcg.converged), "stop": stop,
            "stopping": stopping,
            "energyError": float(pcg.energy_error),
            "preconditionedResidual": float(pcg.preconditioned_residual),
            "conditionEstimate": float(pcg.condition_estimate),
            "diagonalRatio": float(pcg.diagonal_ratio),
            "errorBound": bound,
            "residualReplacements": int(pcg.residual_replacements),
            "preconditionerLevels": int(pcg.levels),
            "preconditioner": preconditioner,
            "trialIterations": trial_iterations,
            "tolerance": float(tolerance),
            "seconds": timings, "backend": backend.name,
            **assembly.report()}
    if gradient_max is not None:
        info["gradientMax"] = gradient_max
    if projection is not None:
        # Whether the direction descends (H may be indefinite).
        info["descends"] = bool(float(gradient @ x) > 0.0)
    scene.state.set(LAST_SOLVE, info)
    solution = layout.split(x)
    if stop == "non_finite":
        raise SolverError(
            "minimizeEnergy: " + describe_non_finite(
                non_finite_sources(contributions)) +
            "; no step was computed", solution, info)
    if not pcg.converged:
        raise SolverError(
            f"minimizeEnergy: PCG {_STOP_REASONS[stop]}, after "
            f"{pcg.iterations} iterations at relative residual "
            f"{pcg.relative_residual:.3g} (tolerance {tolerance:g}); the last "
            "iterate is in .solution", solution, info)
    if warn_conditioning and stopping == "residual" and \
            bound > ERROR_BOUND_WARNING and first_warning_for(scene):
        warnings.warn(
            f"minimizeEnergy: PCG converged to relative residual "
            f"{pcg.relative_residual:.3g}, but the Hessian's conditioning "
            f"(diagonal ratio {pcg.diagonal_ratio:.3g}, CG's estimate "
            f"{pcg.condition_estimate:.3g}) means the residual bounds the "
            f"step's relative error only by {bound:.3g}; use "
            "stopping='energy_norm' or a smaller tolerance (warned once per "
            "scene; lastSolve['errorBound'] has it for every solve)",
            IllConditionedSolve, stacklevel=4)
    return solution
