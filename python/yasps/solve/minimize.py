"""``Scene.minimizeEnergy``: the Newton direction from the assembled system,
solved by block-Jacobi PCG on the backend (section 8)."""

from __future__ import annotations

import time
from typing import Dict, List, Optional

import numpy as np

from ..frontend.errors import YaspsError
from ..runtime import Backend
from .assembly import DofLayout, assemble


class SolverError(YaspsError, RuntimeError):
    """PCG did not reach the requested tolerance; ``solution`` holds the
    last iterate (one array per target) and ``info`` the solver report."""

    def __init__(self, message: str, solution: list, info: dict):
        super().__init__(message)
        self.solution = solution
        self.info = info


def fixed_dof_mask(layout: DofLayout, fixed) -> Optional[np.ndarray]:
    """The per-DoF uint8 mask of ``fixed``: one entry per target (in
    ``addMinimizeTarget``'s order), each None, a boolean mask of its
    instances (N,) or of its entries (N, rows, cols)."""
    if fixed is None:
        return None
    if len(fixed) != len(layout.targets):
        raise ValueError(f"minimizeEnergy: fixed has {len(fixed)} entries but "
                         f"there are {len(layout.targets)} targets")
    parts = []
    for target, mask in zip(layout.targets, fixed):
        n, r, c = target.owner.numInstances, target.rows, target.cols
        if mask is None:
            parts.append(np.zeros(n * r * c, dtype=np.uint8))
            continue
        mask = np.asarray(mask, dtype=bool)
        if mask.shape == (n,):
            mask = np.broadcast_to(mask[:, None, None], (n, r, c))
        if mask.shape != (n, r, c):
            raise ValueError(
                f"minimizeEnergy: the fixed mask of {target.describe()} has "
                f"shape {mask.shape}; expected ({n},) or ({n}, {r}, {c})")
        # DoFs are column-major within an instance.
        parts.append(np.transpose(mask, (0, 2, 1)).reshape(-1).astype(np.uint8))
    return np.ascontiguousarray(np.concatenate(parts)) if parts else None


def minimize_energy(scene, backend: Backend, tolerance: float = 1e-6,
                    maxIterations: int = 1000, threads: Optional[int] = None,
                    fixed: Optional[list] = None) -> List[np.ndarray]:
    """Solves H dx = g for the assembled projected Hessian and gradient,
    with dx = 0 at the ``fixed`` DoFs (see fixed_dof_mask), on ``backend``."""
    if not (tolerance >= 0):
        raise ValueError(f"minimizeEnergy: tolerance must be >= 0, got {tolerance}")
    timings: Dict[str, float] = {}
    report: Dict[str, object] = {}
    system, layout = assemble(scene, backend, threads, timings, report)
    mask = fixed_dof_mask(layout, fixed)
    x = np.zeros(system.size)
    start = time.perf_counter()
    iterations, residual, converged = backend.solve(
        system, x, float(tolerance), int(maxIterations), threads, mask)
    timings["solve"] = time.perf_counter() - start
    info = {"iterations": int(iterations), "relativeResidual": float(residual),
            "converged": bool(converged), "seconds": timings,
            "backend": backend.name, **report}
    scene.lastSolve = info
    solution = layout.split(x)
    if not converged:
        raise SolverError(
            f"minimizeEnergy: PCG stopped after {iterations} iterations at "
            f"relative residual {residual:.3g} (tolerance {tolerance:g}); "
            "the last iterate is in .solution", solution, info)
    return solution
