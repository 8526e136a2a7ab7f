"""``config.preconditioner = "auto"``: per scene, the preconditioner whose
solves cost less, chosen by trials whose cost is bounded.

The multilevel preconditioner needs fewer CG iterations than block-Jacobi
(1.2-1.8x fewer on soft bodies, 3-4x on the stiff cloth and contact
systems of the larger scenes), but each of its iterations costs about one
and a half of block-Jacobi's and its setup (the levels' values, every
solve) about a dozen (``docs/benchmarks.md``, "Preconditioners"). Whether
it pays depends on how many iterations block-Jacobi needs, which changes
during a simulation and with the scene's size.

The choice is made from iteration counts and a fixed cost model, never from
clocks, so that a run repeats bit for bit (and resumes so from a
checkpoint: :func:`state` and :func:`restore` carry it). The cost of a solve
in units of one block-Jacobi iteration is ``SETUP[p] + ITERATION[p] * k``
for k iterations of preconditioner p. Every ``period`` solves the other
preconditioner is tried with an iteration cap that stops it as soon as it
would have cost more than MARGIN of the current one's solves (a moving
average of their costs): a trial that converges within it is the solve, and
the choice switches. One that does not is redone with the current
preconditioner, and the redo, of the same system, judges it: where the
trial's cost extrapolated from how far it came (its iterations over its
progress toward the tolerance, in orders of magnitude) is at most MARGIN of
the redo's, the choice switches after the redo (a trial's budget comes from
past solves, and the one it ran on may be far harder). Otherwise the period
doubles, up to ``MAX_PERIOD`` (at once where the trial came less than
``FAR`` of the way to its tolerance), unless the current preconditioner's
solves grow ``RISE`` times costlier than the highest cost it won a trial
at: then the verdict is stale and the next solve is a trial. A breakdown of
the trial or of the redo (an indefinite system: an exact Hessian of
progressive projection) is no verdict on either: the next solve is a trial
again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, Optional, Tuple

import numpy as np

from ..frontend.state import StateKey

BLOCK_JACOBI = "block-jacobi"
MULTILEVEL = "multilevel"

#: Cost of a solve's setup, in block-Jacobi iterations: the preconditioner's
#: construction and the residual's finiteness checks (bench/preconditioners.py
#: on this project's 2-core machine, one thread: 0.2-6.8 ms, 4-5 of its
#: iterations, for block-Jacobi; 9.5-12.5 iterations for multilevel, whose
#: coarse levels' values, damping estimates and coarse factor are computed
#: every solve).
SETUP = {BLOCK_JACOBI: 5.0, MULTILEVEL: 12.0}
#: Cost of one CG iteration, in block-Jacobi iterations (the fine level's
#: block-Jacobi added to the coarse levels' V-cycle: 1.44-1.47x on one
#: thread, from 4k to 86k DoFs).
ITERATION = {BLOCK_JACOBI: 1.0, MULTILEVEL: 1.5}
#: A trial wins only where it costs at most this share of the current
#: preconditioner's solves. Near break-even the two differ by less than a
#: switch costs elsewhere: their directions, solved to a forcing term's
#: loose tolerance, differ, and Newton's iterations with them (on the
#: STARK bench's bunny on a pinned cloth, 2,494 vertices, where their
#: solves cost the same by the model and by the clock, switching freely
#: took 4% more Newton iterations and 9% more time per frame than
#: block-Jacobi alone).
MARGIN = 0.8
#: A trial needs room for at least this many iterations to be worth running.
MIN_TRIAL_ITERATIONS = 3
#: Solves between trials: at the start, after a switch, at most.
FIRST_PERIOD, PERIOD_AFTER_SWITCH, MAX_PERIOD = 1, 4, 64
#: How much costlier than when it last won a trial the current solves may
#: grow before the other is tried again at once.
RISE = 1.25
#: The weight of the newest solve in the moving average of solve costs.
SMOOTHING = 0.5
#: A trial that came less than this share of the way to its tolerance (in
#: orders of magnitude) before its cap is far from converging.
FAR = 0.5


def other(preconditioner: str) -> str:
    """The preconditioner that is not ``preconditioner``."""
    return MULTILEVEL if preconditioner == BLOCK_JACOBI else BLOCK_JACOBI


def solve_cost(preconditioner: str, iterations: float) -> float:
    """A solve's cost in block-Jacobi iterations (the module's model)."""
    return SETUP[preconditioner] + ITERATION[preconditioner] * iterations


def trial_budget(trying: str, current_cost: float) -> int:
    """The iterations a trial of ``trying`` may take to win against solves
    of ``current_cost``: as many as cost MARGIN of it."""
    return math.floor((MARGIN * current_cost - SETUP[trying])
                      / ITERATION[trying])


@dataclass(frozen=True)
class Attempt:
    """One PCG run the choice asks for."""
    preconditioner: str
    max_iterations: int
    #: Whether it is a trial of the preconditioner not chosen.
    trial: bool


@dataclass
class PreconditionerChoice:
    """The choice of one scene, and what it was made from."""
    current: str = BLOCK_JACOBI
    #: The cost of its solves, per preconditioner (model units): the
    #: winning trial's, then a moving average.
    costs: Dict[str, float] = field(default_factory=dict)
    period: int = FIRST_PERIOD
    since_trial: int = 0
    #: The highest cost at which the current one won a trial since the
    #: last switch (None: none won yet).
    won_at: Optional[float] = None
    #: A trial that stopped without converging, awaiting its redo's
    #: verdict (preconditioner, iterations, progress, stop); it lives
    #: within one solve, so checkpoints do not carry it.
    pending: Optional[Tuple[str, int, float, str]] = field(
        default=None, compare=False)

    def next_attempt(self, max_iterations: int) -> Attempt:
        """What the next solve runs first (after a trial that did not
        converge: its redo, with the current preconditioner)."""
        if self.pending is not None:
            return Attempt(self.current, max_iterations, False)
        trying = other(self.current)
        last = self.costs.get(self.current)
        stale = self.won_at is not None and last is not None and \
            last > RISE * self.won_at
        if (self.since_trial >= self.period or stale) and last is not None:
            budget = trial_budget(trying, last)
            if budget >= MIN_TRIAL_ITERATIONS:
                return Attempt(trying, min(budget, max_iterations), True)
        return Attempt(self.current, max_iterations, False)

    def record(self, attempt: Attempt, iterations: int, stop: str,
               progress: float = 1.0) -> bool:
        """Takes what ``attempt`` did (its iterations and PcgStop name; for
        a trial stopped at its cap, ``progress``: the share of the way to
        the tolerance it came, in orders of magnitude); returns whether the
        solve must be redone with the current preconditioner (a trial that
        did not converge within its cap)."""
        cost = solve_cost(attempt.preconditioner, iterations)
        if attempt.trial:
            self.since_trial = 0
            if stop == "converged":
                self._switch(attempt.preconditioner, cost)
                return False
            self.pending = (attempt.preconditioner, iterations, progress,
                            stop)
            return True
        trial, self.pending = self.pending, None
        self.since_trial += 1
        # A breakdown (an indefinite exact Hessian) says nothing of cost.
        if stop in ("converged", "max_iterations"):
            # Averaged: within a frame a Newton iteration's system may need
            # twice the iterations of the one before, and one cheap solve of
            # the other must not win against one dear solve of this one.
            last = self.costs.get(self.current)
            self.costs[self.current] = cost if last is None else \
                (1.0 - SMOOTHING) * last + SMOOTHING * cost
        if stop == "max_iterations":
            # Stopped at the cap: the other may do what this could not.
            self.since_trial = max(self.since_trial, self.period)
        if trial is not None:
            self._judge(trial, cost, stop)
        return False

    def _switch(self, to: str, cost: float) -> None:
        self.current = to
        self.costs[to] = cost
        self.period = PERIOD_AFTER_SWITCH
        self.won_at = None
        self.since_trial = 0

    def _judge(self, trial: Tuple[str, int, float, str], redo_cost: float,
               redo_stop: str) -> None:
        """The verdict on a trial that did not converge, from its redo (of
        the same system) costing ``redo_cost``."""
        trying, iterations, progress, stop = trial
        if "breakdown" in (stop, redo_stop) or \
                redo_stop not in ("converged", "max_iterations"):
            self.since_trial = self.period
            return
        if progress > 0.0:
            estimate = solve_cost(trying, iterations / progress)
            if estimate <= MARGIN * redo_cost:
                self._switch(trying, estimate)
                return
        # Far from converging (it would have needed twice its cap and more),
        # it will not win soon: wait the longest (a rise of the current's
        # costs still calls a trial).
        self.period = MAX_PERIOD if progress < FAR else \
            min(2 * self.period, MAX_PERIOD)
        # The highest cost the current one won at: the solves may swing
        # within a frame; only a rise above it makes the verdict stale.
        self.won_at = max(self.won_at or 0.0,
                          self.costs.get(self.current, 0.0))

    def as_array(self) -> np.ndarray:
        """The state as numbers (what a checkpoint stores)."""
        nan = float("nan")
        return np.array([
            1.0 if self.current == MULTILEVEL else 0.0,
            self.costs.get(BLOCK_JACOBI, nan), self.costs.get(MULTILEVEL, nan),
            float(self.period), float(self.since_trial),
            nan if self.won_at is None else self.won_at])

    @classmethod
    def from_array(cls, values: np.ndarray) -> "PreconditionerChoice":
        """The inverse of as_array."""
        current, jacobi, multilevel, period, since, won_at = (
            float(v) for v in values)
        costs = {name: cost for name, cost in ((BLOCK_JACOBI, jacobi),
                                               (MULTILEVEL, multilevel))
                 if not math.isnan(cost)}
        return cls(MULTILEVEL if current == 1.0 else BLOCK_JACOBI, costs,
                   int(period), int(since),
                   None if math.isnan(won_at) else won_at)


_CHOICE: StateKey[PreconditionerChoice] = StateKey(
    "the preconditioner's choice")


def choice_for(scene) -> PreconditionerChoice:
    """The scene's choice (made on its first auto solve)."""
    return scene.state.setdefault(_CHOICE, PreconditionerChoice)


def state(scene) -> Optional[np.ndarray]:
    """The scene's choice as numbers, None before its first auto solve."""
    choice = scene.state.get(_CHOICE)
    return None if choice is None else choice.as_array()


def restore(scene, values: Optional[np.ndarray]) -> None:
    """Sets the scene's choice from :func:`state` (None: not made yet)."""
    if values is None:
        scene.state.pop(_CHOICE)
    else:
        scene.state.set(_CHOICE, PreconditionerChoice.from_array(values))


#: ``config.preconditioner``'s value that asks for this choice.
AUTO = "auto"


def progress(report, tolerance: float, stopping: str) -> float:
    """How far a stopped solve came toward ``tolerance`` under its stopping
    rule, in orders of magnitude: log(reached) / log(tolerance), in [0, 1]
    (0 where nothing says: no iteration, a NaN, a tolerance of 1 or more)."""
    reached = {"residual": report.relative_residual,
               "preconditioned": report.preconditioned_residual,
               "energy_norm": report.energy_error}[stopping]
    if not (0.0 < tolerance < 1.0) or not (0.0 < reached):
        return 0.0
    return min(max(math.log(reached) / math.log(tolerance), 0.0), 1.0)


def solve(scene, requested: str, max_iterations: int,
          run: Callable[[str, int], Any], tolerance: float = 0.0,
          stopping: str = "residual") -> Tuple[Any, str, int]:
    """Runs a scene's PCG solve, ``run(preconditioner, max_iterations)``
    (returning the native PcgReport), with the preconditioner ``requested``
    or, for AUTO, the scene's choice; ``tolerance`` and ``stopping`` are
    the solve's (they say how far a trial came). Returns the report of the
    solve kept, its preconditioner and the iterations of a trial that was
    redone."""
    if requested != AUTO:
        return run(requested, max_iterations), requested, 0
    choice = choice_for(scene)
    attempt = choice.next_attempt(max_iterations)
    report = run(attempt.preconditioner, attempt.max_iterations)
    if not choice.record(attempt, int(report.iterations), report.stop.name,
                         progress(report, tolerance, stopping)):
        return report, attempt.preconditioner, 0
    spent = int(report.iterations)
    again = choice.next_attempt(max_iterations)
    report = run(again.preconditioner, again.max_iterations)
    choice.record(again, int(report.iterations), report.stop.name)
    return report, again.preconditioner, spent
