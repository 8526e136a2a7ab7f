"""The adjoint of implicit Euler: gradients of a run's last state with
respect to the scene's constants and the initial positions and velocities.

A recording stepper (``ImplicitEuler(..., record=True)``) keeps, per step,
the stored values that changed (the targets, the predictions, the
collision pairs and friction's lags; constants once) in a :class:`Tape`.
:func:`backward` walks the steps from the last, restoring each step's
solution, and solves once per step with the step's exact Hessian
(yasps.solve.adjoint), the collision set held at that solution and
friction's lagged quantities held fixed. With q_n the targets, v_n their
velocities and q_hat_n = q_n + dt v_n + dt^2 g the prediction, step n
solves q_{n+1} = argmin E_n(q; q_hat_n, theta) with v_{n+1} =
(q_{n+1} - q_n) / dt, so going back (docs/diff.md)::

    b          = dL/dq_{n+1} + dL/dv_{n+1} / dt
    H_ff lam_f = b_f,  lam = 0 on the step's held DoFs
    dL/dtheta -= lam^T d(grad E_n)/dtheta
    dL/dq_hat  = -lam^T d(grad E_n)/dq_hat
    dL/dq_n    = dL/dq_hat - dL/dv_{n+1} / dt   (+ b_F - (H lam)_F on fixed DoFs)
    dL/dv_n    = dt dL/dq_hat
"""

from __future__ import annotations

import bisect
import warnings
from typing import (Any, Dict, Generator, List, Mapping, Optional, Sequence,
                    Tuple)

import numpy as np

from ..frontend.attribute import Attribute, owner_of
from ..frontend.errors import ArgumentError, IndexRangeError, SceneError
from ..frontend.values import to_column_major
from ..runtime import Backend
from ..solve.adjoint import (AdjointSystem, AdjointWarning, Gradients,
                             Variables, adjoint_terms, checked_parameters)
from ..solve.minimize import fixed_dof_mask
from .checkpoint import (restore_scene_state, restore_stepper_state,
                         scene_state, stepper_state)


class Tape:
    """The states a run went through, keeping of each stored value (and
    dynamic count and connectivity) only the versions that differ from the
    previous state's: state 0 is the run's start, state n + 1 the solution
    of step n.

    With ``every`` (checkpointing, for long runs), it keeps instead the
    stepper's whole state (:func:`checkpoint.stepper_state`) at the start
    of every ``every``-th step only; the backward pass runs each stretch
    between checkpoints again, recording it densely, before going back
    over it: memory for N / every checkpoints and one stretch, at the cost
    of a second forward run."""

    def __init__(self, every: Optional[int] = None) -> None:
        self._history: Dict[str, Tuple[List[int], List[np.ndarray]]] = {}
        self.length = 0
        #: per step: the solve's held DoF mask and the fixed one (held
        #: DoFs that keep their values, not prescribed)
        self.masks: List[Tuple[np.ndarray, np.ndarray]] = []
        self.every = every
        #: with ``every``: the stepper's state at the start of step n, by n
        self.checkpoints: Dict[int, Dict[str, Any]] = {}
        #: the steps recorded
        self.steps = 0

    def record_step(self, stepper, fixed) -> None:
        """Records the step ``stepper`` just took (``fixed``: its solve's
        held entries, one mask or None per target)."""
        self.masks.append(record_masks(stepper, fixed))
        self.steps += 1
        if self.every is None:
            self.append(scene_state(stepper.scene))
        elif self.steps % self.every == 0:
            self.checkpoints[self.steps] = stepper_state(stepper)

    def append(self, state: Dict[str, np.ndarray]) -> None:
        for key, value in state.items():
            steps, values = self._history.setdefault(key, ([], []))
            last = values[-1] if values else None
            if last is None or last.shape != value.shape or \
                    not np.array_equal(last, value):
                steps.append(self.length)
                values.append(np.array(value, copy=True))
        self.length += 1

    def state(self, n: int) -> Dict[str, np.ndarray]:
        """State ``n`` (0 <= n < length)."""
        if not 0 <= n < self.length:
            raise IndexRangeError(f"the tape holds states 0..{self.length - 1}")
        out = {}
        for key, (steps, values) in self._history.items():
            k = bisect.bisect_right(steps, n) - 1
            if k >= 0:
                out[key] = values[k]
        return out

    def nbytes(self) -> int:
        """The memory the recorded values take."""
        return sum(v.nbytes for _, values in self._history.values()
                   for v in values) + \
            sum(np.asarray(v).nbytes for state in self.checkpoints.values()
                for v in state.values())

    def stretches(self, stepper) -> Generator[Tuple[int, "Tape"], None, None]:
        """(first step, a dense tape of the stretch) from the last stretch
        to the first: the whole tape at once, or, with checkpoints, each
        stretch run again from its checkpoint. Leaves the stepper in the
        state it had."""
        if self.every is None:
            yield 0, self
            return
        final = stepper_state(stepper)
        try:
            for start in reversed(range(0, self.steps, self.every)):
                stop = min(start + self.every, self.steps)
                restore_stepper_state(stepper, self.checkpoints[start])
                stretch = Tape()
                stretch.append(scene_state(stepper.scene))
                kept, stepper.tape = stepper.tape, stretch
                try:
                    for _ in range(stop - start):
                        stepper.step(warn=False)
                finally:
                    stepper.tape = kept
                yield start, stretch
        finally:
            restore_stepper_state(stepper, final)


class SimulationGradients(Gradients):
    """dL/dtheta per parameter (keyed by the Attribute, shaped like its
    value), and ``initial_positions`` and ``initial_velocities``: dL/dq_0
    and dL/dv_0, one array per target shaped like its value."""

    initial_positions: List[np.ndarray]
    initial_velocities: List[np.ndarray]


def _flatten(variables: Variables, targets: Sequence[Attribute],
             given: Optional[Mapping[Attribute, object]], what: str) -> np.ndarray:
    out = np.zeros(variables.num_dofs)
    for attr, value in (given or {}).items():
        if not any(attr is t for t in targets):
            raise ArgumentError(f"{what} names {attr.describe()}, which is "
                                "not one of the stepper's targets")
        start = variables.offset[id(attr)]
        flat = to_column_major(value, owner_of(attr).numInstances, attr.rows,
                               attr.cols, f"{what} of {attr.describe()}")
        out[start:start + flat.size] += flat
    return out


def backward(stepper, dloss: Mapping[Attribute, object],
             parameters: Sequence[Attribute], backend: Backend,
             dloss_velocities: Optional[Mapping[Attribute, object]] = None,
             tolerance: float = 1e-6,
             threads: Optional[int] = None,
             hessian: str = "exact") -> SimulationGradients:
    """The gradients of a loss of the recorded run's last state (see
    ImplicitEuler.backward). Leaves the scene in the run's last state."""
    tape: Optional[Tape] = stepper.tape
    what = "ImplicitEuler.backward"
    if not stepper.record:
        raise SceneError(f"{what}: the stepper records nothing; make it with "
                         "record=True")
    if tape is None or tape.steps == 0:
        raise SceneError(f"{what}: no step was recorded")
    scene, dt = stepper.scene, stepper.dt
    params = checked_parameters(scene, parameters, what)
    predicted = [p for p in stepper.predicted if p is not None]
    for p in params:
        if any(p is q for q in predicted):
            raise ArgumentError(f"{what}: {p.describe()} is a prediction; "
                                "its gradient is the initial positions' and "
                                "velocities'")
    targets = list(stepper.targets)
    variables = Variables(scene, params + predicted)
    if [id(t) for t in variables.layout.targets] != [id(t) for t in targets]:
        raise SceneError(f"{what}: the scene's minimisation targets are not "
                         "the stepper's")
    nx = variables.num_dofs
    q_bar = _flatten(variables, targets, dloss, f"{what}: dloss")
    v_bar = _flatten(variables, targets, dloss_velocities,
                     f"{what}: dloss_velocities")
    theta_bar = np.zeros(variables.size - nx)
    prediction_slices = []
    for hat, target in zip(stepper.predicted, targets):
        if hat is None:
            continue
        start = variables.offset[id(hat)] - nx
        size = owner_of(hat).numInstances * hat.rows * hat.cols
        prediction_slices.append((slice(start, start + size),
                                  variables.offset[id(target)]))
    unconverged = 0
    final = scene_state(scene)
    stretches = tape.stretches(stepper)
    steps = ((stretch, n) for _, stretch in stretches
             for n in range(stretch.steps - 1, -1, -1))
    try:
        for stretch, n in steps:
            restore_scene_state(scene, stretch.state(n + 1))
            held, fixed = stretch.masks[n]
            system = AdjointSystem(variables, adjoint_terms(
                scene, variables, backend, threads), held, hessian)
            if system.free_gradient_norm() > tolerance:
                unconverged += 1
            b = q_bar + v_bar / dt
            lam = system.solve(b)
            mixed = system.mixed_vjp(lam)
            q_prev = -v_bar / dt
            hat_bar = np.zeros(nx)
            for where, offset in prediction_slices:
                part = -mixed[where]
                hat_bar[offset:offset + part.size] += part
                mixed[where] = 0.0
            theta_bar -= mixed
            q_prev = q_prev + hat_bar
            # Fixed DoFs keep their values: dL/dq_{n+1} on them, and what
            # they do to the free solution, passes to q_n. Prescribed ones
            # follow time only.
            coupled = system.hessian @ lam
            q_prev[fixed] += b[fixed] - coupled[fixed]
            q_bar, v_bar = q_prev, dt * hat_bar
    finally:
        stretches.close()          # a stepper run again is put back
        restore_scene_state(scene, final)
    if unconverged:
        warnings.warn(f"{what}: {unconverged} of {tape.steps} recorded steps end "
                      f"with a free gradient above {tolerance:g}: not at a "
                      "converged minimiser, so their adjoint is that of a "
                      "point the solve did not reach (tighten the stepper's "
                      "velocity_tolerance)", AdjointWarning, stacklevel=3)
    everything = np.concatenate([np.zeros(nx), theta_bar])
    grads = SimulationGradients({p: variables.split(everything, p)
                                 for p in params})
    grads.initial_positions = [variables.split(q_bar, t) for t in targets]
    grads.initial_velocities = [variables.split(v_bar, t) for t in targets]
    return grads


def record_masks(stepper, fixed) -> Tuple[np.ndarray, np.ndarray]:
    """The step's DoF masks: held in the solve (fixed and prescribed) and
    fixed (keeping their values)."""
    from ..solve.assembly import DofLayout

    layout = DofLayout(list(stepper.targets))
    empty = np.zeros(layout.size, dtype=bool)
    held = fixed_dof_mask(layout, fixed) if fixed is not None else None
    kept = fixed_dof_mask(layout, stepper.fixed) \
        if any(m is not None for m in stepper.fixed) else None
    return (empty if held is None else held.astype(bool),
            empty if kept is None else kept.astype(bool))


def start_recording(stepper, every: Optional[int] = None) -> Tape:
    """A tape holding the stepper's state now (checkpoints every ``every``
    steps, or every state), refusing what the adjoint does not cover."""
    if stepper.world:
        raise SceneError("ImplicitEuler(record=True): world-space inertias "
                         "are not differentiated yet")
    if any(fn is not None for fn in stepper.normalize):
        raise SceneError("ImplicitEuler(record=True): normalize is not "
                         "differentiated")
    if stepper.friction_iterations > 1:
        raise SceneError("ImplicitEuler(record=True): friction_iterations "
                         "> 1 is not differentiated (lags are held fixed)")
    tape = Tape(every)
    if every is None:
        tape.append(scene_state(stepper.scene))
    else:
        tape.checkpoints[0] = stepper_state(stepper)
    return tape
