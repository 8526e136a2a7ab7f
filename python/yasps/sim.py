"""Helpers for implicit time stepping with yasps: meshes, and a Newton loop
with a backtracking line search and a step bound.

yasps returns Newton directions (``minimizeEnergy``); stepping, line search
and collision handling stay with the user (paper section 3). These helpers
are the usual choices for a first simulation.
"""

from __future__ import annotations

import itertools
from typing import Callable, List, Optional, Tuple

import numpy as np

from .attribute import Attribute


def box_tet_mesh(n: int, size: float = 1.0) -> Tuple[np.ndarray, np.ndarray]:
    """A cube of n^3 cells split into 6 positively oriented tets each:
    vertices (N, 3) and tets (M, 4) int32."""
    grid = np.array(list(itertools.product(range(n + 1), repeat=3)), float)
    index = {tuple(p.astype(int)): i for i, p in enumerate(grid)}
    tets = []
    for cell in itertools.product(range(n), repeat=3):
        for perm in itertools.permutations(range(3)):
            path = [np.array(cell)]
            for axis in perm:
                step = path[-1].copy()
                step[axis] += 1
                path.append(step)
            tet = [index[tuple(p)] for p in path]
            a, b, c, d = grid[tet]
            if np.linalg.det(np.stack([b - a, c - a, d - a])) < 0:
                tet[2], tet[3] = tet[3], tet[2]
            tets.append(tet)
    return grid * (size / n), np.array(tets, dtype=np.int32)


class NewtonReport:
    """What one Newton solve did."""

    def __init__(self):
        self.iterations = 0
        self.energies: List[float] = []
        self.converged = False

    def __repr__(self) -> str:
        return (f"<NewtonReport {self.iterations} iterations, "
                f"converged={self.converged}>")


def newton(scene, x: Attribute, tolerance: float,
           step_bound: Optional[Callable[[np.ndarray, np.ndarray], float]] = None,
           max_iterations: int = 20, cg_tolerance: float = 1e-4) -> NewtonReport:
    """Minimises the scene's energy over its single target ``x`` by Newton's
    method: directions from ``minimizeEnergy``, the step limited by
    ``step_bound(x, p)`` (the largest safe fraction of the step ``p``, e.g.
    to stay clear of obstacles), then halved until the energy decreases.
    Stops when the largest entry of a step is below ``tolerance``."""
    report = NewtonReport()
    energy = scene.evaluateEnergy()
    report.energies.append(energy)
    for _ in range(max_iterations):
        (dx,) = scene.minimizeEnergy(tolerance=cg_tolerance)
        p = -dx
        current = x.value
        alpha = 1.0 if step_bound is None else min(1.0, step_bound(current, p))
        while alpha > 1e-10:
            x.updateValue(current + alpha * p)
            candidate = scene.evaluateEnergy()
            if candidate <= energy:
                break
            alpha *= 0.5
        else:
            x.updateValue(current)
            break
        energy = candidate
        report.iterations += 1
        report.energies.append(energy)
        if np.abs(alpha * p).max() < tolerance:
            report.converged = True
            break
    return report
