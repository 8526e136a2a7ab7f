"""What a Newton solve reports (:class:`NewtonReport`) and the warning for a
solve that stopped unconverged."""

from __future__ import annotations

from typing import Dict, List, Tuple

from ..deprecation import add_renamed_members

#: The stages of a Newton iteration that a report times; ``compile`` is the
#: kernels' compilation (or their loading from the caches), done before the
#: first iteration so that no other stage includes it.
STAGES = ("compile", "collisions", "ccd", "derivatives", "assembly", "pcg",
          "energy")


class NewtonNotConverged(UserWarning):
    """Newton stopped at its iteration cap (or with a step too small to
    lower the energy) before its direction fell below the tolerance: the
    step's result is not the minimiser the time step asks for."""


class NewtonReport:
    """What one Newton solve did: ``iterations`` (accepted steps),
    ``energies`` (the total energy before the first and after each accepted
    step), ``step_energies`` (per accepted step the energy before and
    after it at the same barrier stiffness: after <= before),
    ``converged``, ``step_bounds`` (the CCD bound of each iteration, with
    contact), ``stiffness`` (kappa after each change of an adaptive
    contact's stiffness), ``cg_iterations`` (of each direction) and
    ``seconds``: the time per stage as the paper's Fig. 20 splits it, after
    ``compile`` (the scene's kernels compiled or loaded up front),
    ``collisions`` (ipctk's collision sets and the pairs from them, friction's
    lag included), ``ccd``, ``derivatives`` (local derivatives of every
    energy), ``assembly`` (indices and the global system), ``pcg`` and
    ``energy`` (the line search's energy evaluations)."""

    def __init__(self) -> None:
        self.iterations = 0
        self.energies: List[float] = []
        self.step_energies: List[Tuple[float, float]] = []
        self.converged = False
        self.step_bounds: List[float] = []
        #: the barrier stiffness after each change by the adaptive rule
        self.stiffness: List[float] = []
        self.cg_iterations: List[int] = []
        #: the fraction of each direction taken (after the step bounds and
        #: the line search; 0 where the line search found no decrease)
        self.step_sizes: List[float] = []
        #: the length of each direction (world space with contact) over
        #: the tolerance: how Newton converged
        self.residuals: List[float] = []
        #: directions taken from PCG's last iterate (it hit its limit)
        self.inexact_directions = 0
        #: friction lags taken (ImplicitEuler: one per step, more with
        #: friction_iterations)
        self.friction_lags = 0
        #: solves repeated with more instances projected (progressive
        #: projection), their CG iterations counted in ``cg_iterations``
        self.projection_retries = 0
        #: directions solved again to ``cg_tolerance`` because, solved to
        #: a looser forcing term, they would have ended the solve (their
        #: CG iterations counted in ``cg_iterations``)
        self.tightened_solves = 0
        #: how far (the largest entry) the prescribed entries were left
        #: short of ``fn(time)`` because CCD stopped them (ImplicitEuler's
        #: ``prescribe``; a run's: the largest of its steps')
        self.prescribed_lag = 0.0
        self.seconds: Dict[str, float] = dict.fromkeys(STAGES, 0.0)
        #: the length of the last direction (world space with contact)
        #: over the tolerance: below 1 when converged
        self.residual = 0.0
        #: a run's frames (from 1) that ended unconverged, with their
        #: ``residual``
        self.unconverged: List[Tuple[int, float]] = []
        #: tets inverted at the end of the step (signed volume <= 0) under
        #: materials that allow it (``yasps.sim.inversion``); a run's: the
        #: most after any of its steps
        self.inverted_tets = 0

    def add(self, other: "NewtonReport") -> None:
        """Accumulates another solve's counts and seconds (a run's total)."""
        self.iterations += other.iterations
        self.step_energies += other.step_energies
        self.inexact_directions += other.inexact_directions
        self.friction_lags += other.friction_lags
        self.projection_retries += other.projection_retries
        self.tightened_solves += other.tightened_solves
        self.prescribed_lag = max(self.prescribed_lag, other.prescribed_lag)
        self.cg_iterations += other.cg_iterations
        for stage, seconds in other.seconds.items():
            self.seconds[stage] = self.seconds.get(stage, 0.0) + seconds

    def __repr__(self) -> str:
        return (f"<NewtonReport {self.iterations} iterations, "
                f"converged={self.converged}>")

    def unconverged_text(self) -> str:
        """What the unconverged frames of a run were, for users: their
        count and the worst; "" when every frame converged."""
        if not self.unconverged:
            return ""
        frame, residual = max(self.unconverged, key=lambda u: u[1])
        return (f"{len(self.unconverged)} unconverged frame"
                f"{'s' * (len(self.unconverged) > 1)} (worst: frame {frame}, "
                f"last Newton direction {residual:.3g}x the tolerance)")




# The camelCase spellings before the naming rule (docs/python.md, "Naming").
add_renamed_members(NewtonReport, {
    "stepEnergies": "step_energies", "stepBounds": "step_bounds",
    "cgIterations": "cg_iterations", "stepSizes": "step_sizes",
    "inexactDirections": "inexact_directions",
    "frictionLags": "friction_lags",
    "projectionRetries": "projection_retries",
    "tightenedSolves": "tightened_solves", "prescribedLag": "prescribed_lag"})
