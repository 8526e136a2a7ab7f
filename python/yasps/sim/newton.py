"""Implicit time stepping with yasps: a Newton loop with a backtracking line
search and a step bound, and implicit Euler on top of it.

yasps returns Newton directions (``minimizeEnergy``); stepping, line search
and collision handling stay with the user (paper section 3). These helpers
are the usual choices for a first simulation.
"""

from __future__ import annotations

from typing import Callable, List, Optional

import numpy as np

from ..frontend.attribute import Attribute


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
           max_iterations: int = 20, cg_tolerance: float = 1e-4,
           fixed: Optional[np.ndarray] = None) -> NewtonReport:
    """Minimises the scene's energy over its single target ``x`` by Newton's
    method: directions from ``minimizeEnergy``, the step limited by
    ``step_bound(x, p)`` (the largest safe fraction of the step ``p``, e.g.
    to stay clear of obstacles: the hook for a collision-free step), then
    halved until the energy decreases. ``fixed`` (a boolean mask of x's
    instances or entries) excludes DoFs, which keep their values. Stops when
    the largest entry of a step is below ``tolerance``."""
    report = NewtonReport()
    energy = scene.evaluateEnergy()
    report.energies.append(energy)
    for _ in range(max_iterations):
        (dx,) = scene.minimizeEnergy(
            tolerance=cg_tolerance, fixed=None if fixed is None else [fixed])
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


class ImplicitEuler:
    """Implicit Euler time stepping of positions ``x`` (the scene's single
    minimisation target) whose inertia energy pulls towards ``x_hat``:
    every step predicts ``x_hat = x + dt v + dt^2 g`` and minimises the
    energy by :func:`newton`, until the largest displacement of a Newton
    step over ``dt`` is below ``velocity_tolerance`` (paper section 9.1);
    then ``v = (x_new - x_old) / dt``. Fixed vertices (``fixed``, a boolean
    mask of x's instances) are excluded DoFs: they keep their positions.
    """

    def __init__(self, scene, x: Attribute, x_hat: Attribute, dt: float,
                 gravity=(0.0, 0.0, -9.81), velocity_tolerance: float = 1e-2,
                 step_bound: Optional[Callable[[np.ndarray, np.ndarray],
                                               float]] = None,
                 fixed: Optional[np.ndarray] = None,
                 max_iterations: int = 20):
        self.scene, self.x, self.x_hat, self.dt = scene, x, x_hat, float(dt)
        self.gravity = np.asarray(gravity, dtype=float).reshape(1, -1, 1)
        self.velocity_tolerance = velocity_tolerance
        self.step_bound = step_bound
        self.fixed = None if fixed is None else np.asarray(fixed, dtype=bool)
        self.max_iterations = max_iterations
        self.velocity = np.zeros_like(x.value)

    def step(self) -> NewtonReport:
        """Advances one time step; returns the Newton report."""
        previous = self.x.value
        gravity = np.broadcast_to(self.gravity, previous.shape).copy()
        if self.fixed is not None:
            gravity[self.fixed] = 0.0
        self.x_hat.updateValue(previous + self.dt * self.velocity
                               + self.dt * self.dt * gravity)
        report = newton(self.scene, self.x,
                        tolerance=self.velocity_tolerance * self.dt,
                        step_bound=self.step_bound,
                        max_iterations=self.max_iterations, fixed=self.fixed)
        self.velocity = (self.x.value - previous) / self.dt
        return report
