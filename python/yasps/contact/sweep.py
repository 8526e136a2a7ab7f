"""The broad phase of one Newton step, shared by its CCD and line search.

IPC's line search tries positions on the straight path from the iterate to
the full Newton step. One broad phase over that path's swept boxes, each
inflated by half the barrier's reach, finds every pair that can come within
dhat anywhere on it: two primitives closer than dhat at some point of the
path have boxes closer than dhat there, and those boxes lie inside their
swept ones. So the CCD bound and the collision set at every line-search
candidate are narrow phases over the same candidates, as in IPC's own
solver, instead of a broad phase each.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

#: How far (a fraction of dhat) positions may stray outside a step's swept
#: boxes and still use its candidates (the round-off of x + alpha p through
#: the world-position kernels).
SLACK = 1e-3

#: A broad phase: (V0, V1, inflation radius) -> candidates.
BroadPhase = Callable[[np.ndarray, np.ndarray, float], Any]


class Sweep:
    """The candidate pairs of the straight motion V0 -> V1 (vertex
    positions (N, 3)) by ``broad_phase``, for barriers of reach ``dhat``."""

    def __init__(self, broad_phase: BroadPhase, V0: np.ndarray,
                 V1: np.ndarray, dhat: float):
        slack = SLACK * dhat
        self.lower = np.minimum(V0, V1) - slack
        self.upper = np.maximum(V0, V1) + slack
        # Each box grows by dhat / 2 plus the slack its own vertices may
        # stray: pairs closer than dhat then always overlap.
        self.candidates = broad_phase(V0, V1, 0.5 * dhat + slack)

    def holds(self, V: np.ndarray) -> bool:
        """Whether the candidates cover positions V: every vertex inside
        its swept box, up to the slack."""
        return bool((V >= self.lower).all() and (V <= self.upper).all())
