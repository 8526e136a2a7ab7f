"""Which local Hessians assembly projects to PSD.

Projected Newton projects every instance's Hessian, which keeps the system
positive definite but turns Newton's quadratic convergence linear wherever
an energy is truly indefinite (a cloth buckling, a barrier's curvature).
Progressively projected Newton (SymX's ``ProjectionToPD::Progressive``,
STARK's default) projects only the instances that read a DoF block (one
target instance) whose gradient is large, and takes the others exact; the
Newton loop lowers the threshold when a solve breaks down or its direction
does not descend, and raises it after each accepted step."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np


@dataclass(frozen=True)
class GradientThreshold:
    """Project the Hessians of the instances that read a DoF block whose
    gradient has an entry of magnitude ``threshold`` or more; the others
    enter exact. 0 projects every instance, ``inf`` none. Fixed DoFs
    (``fixed``, per DoF, nonzero where fixed) do not count: the solve does
    not move them."""

    threshold: float
    #: the first DoF of each block, and the total (DofLayout.block_offsets)
    block_offsets: np.ndarray
    fixed: Optional[np.ndarray] = None

    def projects_all(self) -> bool:
        return self.threshold <= 0.0

    def projects_none(self) -> bool:
        return self.threshold == float("inf")

    def projected_dofs(self, gradient: np.ndarray) -> np.ndarray:
        """The DoFs whose block's gradient reaches the threshold (a boolean
        mask over the global DoFs)."""
        magnitude = np.abs(gradient)
        if self.fixed is not None:
            magnitude = np.where(self.fixed != 0, 0.0, magnitude)
        starts = self.block_offsets[:-1]
        sizes = np.diff(self.block_offsets)
        largest = np.maximum.reduceat(magnitude, starts) if len(starts) \
            else np.zeros(0)
        return np.repeat(largest >= self.threshold, sizes)


def free_gradient_max(gradient: np.ndarray,
                      fixed: Optional[np.ndarray]) -> float:
    """The largest gradient magnitude over the DoFs that are not fixed."""
    magnitude = np.abs(gradient)
    if fixed is not None:
        magnitude = np.where(fixed != 0, 0.0, magnitude)
    return float(magnitude.max()) if magnitude.size else 0.0
