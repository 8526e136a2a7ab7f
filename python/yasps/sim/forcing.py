"""How tightly Newton's linear solves are solved: the forcing terms of an
inexact Newton method (Eisenstat and Walker 1996).

Far from a time step's solution a Newton direction only has to point the
right way; a PCG solve to a relative residual of 1e-4 there buys accuracy
the next iteration throws away. The forcing term loosens the solve's
tolerance while the gradient is still large against where the step started
and tightens it to the caller's tolerance as the gradient falls, as STARK
(SymX's Newton) does with its absolute residual: its PCG stops at relative
residual ``max(1e-4, min(1e-2, r min(0.5, sqrt(r))))``, ``r`` the gradient's
largest entry. Here ``r`` is that entry over its value at the step's first
iteration, so the rule does not depend on the scene's units.

Newton's stopping rule judges a direction's length; a loose solve could end
a step early. :func:`yasps.sim.newton` therefore re-solves a direction that
would stop it at the caller's own tolerance (see its ``cg_forcing``).
"""

from __future__ import annotations

import math
from typing import Optional

from ..frontend.errors import ArgumentError

#: The loosest relative residual a direction is solved to (SymX's cap).
LOOSEST = 1e-2


class Forcing:
    """The relative residual of each Newton iteration's PCG solve, between
    ``tightest`` (the caller's ``cg_tolerance``) and ``loosest``."""

    def __init__(self, tightest: float, loosest: float = LOOSEST):
        if not (0 <= tightest):
            raise ArgumentError(f"Forcing: tightest must be >= 0, got {tightest}")
        self.tightest = float(tightest)
        self.loosest = max(float(loosest), self.tightest)
        self._first: Optional[float] = None

    def tolerance(self, gradient_max: float) -> float:
        """The tolerance of a solve whose gradient's largest free entry is
        ``gradient_max`` (the first call of a step fixes the scale)."""
        if self._first is None:
            self._first = gradient_max
        if not (self._first > 0) or not math.isfinite(gradient_max):
            return self.tightest
        r = gradient_max / self._first
        eta = r * min(0.5, math.sqrt(r))
        return min(self.loosest, max(self.tightest, eta))
