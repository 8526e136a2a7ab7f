"""IPC's adaptive barrier stiffness (Li et al. 2020, section 4.3), by
ipctk's heuristics: an initial kappa that balances the barrier's gradient
against the other energies', and a doubling whenever the closest distance
keeps shrinking below a small distance.

That distance is yasps' choice: a fraction of dhat (:data:`CLOSE_FRACTION`)
where IPC takes 1e-9 of the scene's diagonal. IPC solves with a direct
solver, which does not mind surfaces pressed to a nanometre; there the
barrier's Hessian is some 1e10 times the inertia's, and PCG's iterations
explode. Doubling kappa while surfaces keep closing below dhat / 10 holds
them near that distance instead (as STARK's contact keeps its own
thickness)."""

from __future__ import annotations

from typing import Callable, Optional

import ipctk
import numpy as np
from ..frontend.errors import ArgumentError


#: kappa doubles (up to IPC's bound, 100 times its minimum) while the
#: closest distance keeps shrinking below this fraction of dhat. At 1e-2
#: it kept the twisting cloth's surfaces 1.2e-5 m apart, with PCG at 195
#: instead of 493-640 iterations per Newton step (docs/benchmarks.md). At
#: 1e-1 contacts settle about as far apart as one Newton tolerance of
#: motion (1e-4 m in the STARK bench), where the log barrier's curvature
#: no longer stalls Newton's last iterations near its tolerance: on the
#: bunny on a pinned cloth at 4,270 vertices 4.87 Newton iterations per
#: frame instead of 7.23 (0.30 instead of 0.42 s per frame, one thread),
#: 2,494 vertices 5.80 instead of 6.15 (60 frames), the twisting cloth
#: 7.21 instead of 7.63 (100 frames), 28,602 vertices 8.10 instead of 8.53
#: at the same time per frame (its CG iterations per Newton 178 instead
#: of 152).
CLOSE_FRACTION = 1e-1


class AdaptiveStiffness:
    """The stiffness state of one contact: ``kappa``, its upper bound and the
    last minimum squared distance seen. ``gradients(kappa)`` gives the
    assembled gradient of the scene's energies with the barrier's stiffness
    set to ``kappa`` (in the targets' DoFs)."""

    def __init__(self, dhat: float, average_mass: float):
        if not average_mass > 0:
            raise ArgumentError(f"adaptive barrier stiffness needs the bodies' "
                                f"average vertex mass > 0, got {average_mass}")
        self.dhat, self.average_mass = float(dhat), float(average_mass)
        self.kappa: Optional[float] = None
        self.max_kappa = 0.0
        self.previous: Optional[float] = None

    def initial(self, diagonal: float,
                gradient: Callable[[float], np.ndarray]) -> float:
        """ipctk's initial stiffness at the current positions."""
        others = gradient(0.0)
        barrier = gradient(1.0) - others
        self.kappa, self.max_kappa = ipctk.initial_barrier_stiffness(
            diagonal, ipctk.ClampedLogBarrier(), self.dhat, self.average_mass,
            others, barrier)
        return self.kappa

    def update(self, min_distance2: float, diagonal: float) -> float:
        """Doubles kappa (up to its bound) when the closest squared distance
        ``min_distance2`` shrank since the last call and both are below
        (CLOSE_FRACTION dhat)^2 (ipctk's rule, with that distance)."""
        if self.previous is not None and np.isfinite(min_distance2):
            self.kappa = ipctk.update_barrier_stiffness(
                self.previous, min_distance2, self.max_kappa, self.kappa,
                diagonal,
                dhat_epsilon_scale=CLOSE_FRACTION * self.dhat / diagonal)
        self.previous = min_distance2
        # Set by initial() (or by a checkpoint) before any update: the
        # contact updates only a kappa it has.
        assert self.kappa is not None
        return self.kappa
