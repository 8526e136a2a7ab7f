"""Implicit time stepping with yasps: a Newton loop with a backtracking line
search and step bounds (IPC's CCD with :class:`yasps.contact.Contact`), and
implicit Euler on top of it, over one or several minimisation targets.

yasps returns Newton directions (``minimizeEnergy``); stepping, line search
and collision handling stay with the user (paper section 3). These helpers
are the usual choices for a simulation.
"""

from __future__ import annotations

import math
import time
import warnings
from pathlib import Path
from typing import (Any, Callable, Dict, List, Mapping, Optional, Sequence,
                    Tuple, Union,
                    overload)

import numpy as np
from tqdm import tqdm

from ..contact.relative import Relative, resolve
from ..frontend.attribute import Attribute
from ..deprecation import renamed_argument, warn_renamed
from ..frontend.errors import ArgumentTypeError, SceneError
from ..runtime import current as current_backend
from ..runtime.blas import one_blas_thread
from ..solve import SolverError, minimize_energy
from ..solve.minimize import checked_fixed_mask
from ..solve.prepare import compile_scene
from . import checkpoint
from .adjoint import SimulationGradients, Tape, backward, start_recording
from .newton_report import NewtonNotConverged, NewtonReport
from .newton_settings import (NewtonSettings, add_settings_attributes,
                              settings_with_keywords)
from .forcing import Forcing
from .inversion import (ElementsInverted, count_inverted,
                        guarded_step_bound, inverted_text)
from .world import WorldInertia
from .prescribed import (Prescription, add_pull, entry_mask,
                         fixed_with_prescribed, move_prescribed, prescription,
                         pull_prescribed)

Targets = Union[Attribute, Sequence[Attribute]]
#: Predictions of targets: None for a target whose inertia is in world space.
Predictions = Union[Attribute, Sequence[Optional[Attribute]]]

def compile_kernels(scene, contact, progress: bool) -> float:
    """Compiles (or loads) every kernel a Newton step of ``scene`` needs,
    the world positions and force queries of ``contact`` included; returns
    the seconds."""
    also = [contact.positions] if contact is not None else []
    return compile_scene(scene, also=also, progress=progress,
                         contact=contact).seconds


# Typed per use: a list of targets, or of predictions (None: world inertia).
@overload
def _as_list(targets: Targets) -> List[Attribute]: ...


@overload
def _as_list(targets: Predictions) -> List[Optional[Attribute]]: ...


def _as_list(targets: Predictions) -> list:
    return [targets] if isinstance(targets, Attribute) else list(targets)


def _check_targets(scene, targets: List[Attribute]) -> None:
    if [id(t) for t in targets] != [id(t) for t in scene.minimizeTargets]:
        names = ", ".join(t.describe() for t in scene.minimizeTargets)
        raise SceneError(f"newton: the targets must be the scene's "
                         f"minimisation targets in order ({names})")


_NONE = float("inf")
_FIRST_THRESHOLD = {"progressive": _NONE, "full": None}
#: The threshold's factor after a failed solve and after a direction taken
#: (SymX's ``ppn_tightening_factor`` and ``ppn_release_factor``, 0.5 and 2
#: there). A quarter, not half: on the STARK scenes (bench/benchlib/stark_scenes.py)
#: nine directions in ten needed a retry, in chains of up to eight at 0.5,
#: and frames took 2-4% less time at 0.25 with as many Newton iterations.
_TIGHTEN, _RELEASE = 0.25, 2.0
#: Below this gradient magnitude every instance is projected.
_SMALLEST_THRESHOLD = 1e-12

#: Newton and CG iterations of every newton() call in this process (what a
#: parameter sweep reports per run, whatever loop the user wrote).
_totals = {"newton": 0, "cg": 0}


def _unusable_start(energy: float, contact) -> str:
    """Why Newton cannot start from where it is: the energy there is not a
    number (a NaN or an infinity), and what to change."""
    cause = contact.touching() if contact is not None else None
    if cause is not None:
        return (f"newton: the total energy at the start is {energy}: "
                f"{cause}")
    return (f"newton: the total energy at the start is {energy}, so no step "
            f"can lower it: an element inverted or of no volume in the "
            f"starting positions, or a NaN in a value (check the targets' "
            f"starting values and the materials)")


def iteration_totals() -> Dict[str, int]:
    """Newton iterations and CG iterations done by :func:`newton` in this
    process so far."""
    return dict(_totals)


def newton(scene, targets: Optional[Targets] = None,
           tolerance: Optional[float] = None,
           step_bound: Optional[Callable[[np.ndarray, np.ndarray], float]] = None,
           *, settings: Optional[NewtonSettings] = None, fixed=None,
           contact=None, compile_first: bool = True,
           **deprecated: Any) -> NewtonReport:
    """Minimises the scene's energy over its ``targets`` (one attribute, or
    the list of the scene's minimisation targets in order) by Newton's
    method: directions from ``minimizeEnergy``, the step limited by
    ``step_bound(x, p)`` (single target: the largest safe fraction of the
    step ``p``) and by ``contact.step_bound`` (CCD), then halved until the
    energy decreases. With ``contact`` its pairs are rebuilt at every
    iterate and every candidate of the line search. ``fixed`` (a boolean
    mask of a single target's instances or entries, or a list with one mask
    or None per target) excludes DoFs, which keep their values. Stops after
    a step whose whole direction (before the step bounds and the line
    search) moves no world position (with contact) or target entry by
    ``tolerance`` or more (IPC's rule). ``settings``: the solver's
    :class:`NewtonSettings` (iteration caps, projection, PCG's tolerance,
    stopping rule and forcing; the defaults if None). A direction whose PCG
    stops at ``settings.cg_max_iterations`` before its tolerance is used as
    it is (counted in ``inexact_directions``). ``compile_first``: compile
    the scene's kernels (``yasps.compile``) before the first iteration,
    timed as the report's ``compile`` stage; a caller that did so already
    passes False.

    Before NewtonSettings, its fields were keywords of newton (and the
    targets were ``x=``): those spellings still work and warn once. NumPy's
    BLAS runs on one thread meanwhile (:mod:`yasps.runtime.blas`)."""
    with one_blas_thread():
        return _newton(scene, targets, tolerance, step_bound,
                       settings=settings, fixed=fixed, contact=contact,
                       compile_first=compile_first, **deprecated)


def _newton(scene, targets: Optional[Targets],
            tolerance: Optional[float],
            step_bound: Optional[Callable[[np.ndarray, np.ndarray], float]],
            *, settings: Optional[NewtonSettings], fixed, contact,
            compile_first: bool, **deprecated: Any) -> NewtonReport:
    """newton() with NumPy's BLAS on one thread."""
    targets = renamed_argument("newton", "x", "targets", targets, deprecated)
    settings = settings_with_keywords("newton", settings, deprecated)
    if targets is None or tolerance is None:
        raise ArgumentTypeError("newton: give the targets and the tolerance")
    x = targets
    max_iterations, cg_tolerance = (settings.max_iterations,
                                    settings.cg_tolerance)
    cg_max_iterations, cg_stopping = (settings.cg_max_iterations,
                                      settings.cg_stopping)
    projection, cg_forcing = settings.projection, settings.cg_forcing
    targets = _as_list(x)
    _check_targets(scene, targets)
    # Materials that must not invert (IPC's Neo-Hookean) bound the steps
    # of their positions themselves (sim.inversion).
    step_bound = guarded_step_bound(scene, targets, step_bound)
    if fixed is not None and isinstance(x, Attribute):
        fixed = [fixed]
    report = NewtonReport()
    clock = time.perf_counter
    if compile_first:
        report.seconds["compile"] += compile_kernels(scene, contact, False)

    def energy() -> float:
        if contact is not None:
            start = clock()
            contact.update()
            report.seconds["collisions"] += clock() - start
        start = clock()
        value = scene.evaluateEnergy()
        report.seconds["energy"] += clock() - start
        return value

    def adapt() -> float:
        # IPC's adaptive barrier stiffness changes the energy itself: the
        # next comparison is made at the new stiffness.
        kappa = contact.kappa
        if contact.adapt_stiffness() != kappa:
            report.stiffness.append(contact.kappa)
            return scene.evaluateEnergy()
        return current_energy

    current_energy = energy()
    finite = math.isfinite(current_energy)
    # A vertex below a half-space leaves the energy finite (the barrier
    # sees the squared gap): the half-spaces are checked every solve, the
    # surfaces (an ipctk query) where the energy says so.
    if not finite or (contact is not None and
                      contact.touching(surfaces=False) is not None):
        raise SceneError(_unusable_start(current_energy, contact))
    if contact is not None:
        current_energy = adapt()
    report.energies.append(current_energy)
    # Progressive projection: nothing projected (inf) until a solve needs it.
    threshold = _FIRST_THRESHOLD[projection]
    forcing = Forcing(cg_tolerance) if cg_forcing else None

    def solve_direction(tolerance_of) -> Tuple[List[np.ndarray], int, bool]:
        """A Newton direction, solved to ``tolerance_of(gradient max)``
        (more projected where progressive projection needs it): the
        directions, their CG iterations and whether PCG met the
        tolerance."""
        nonlocal threshold
        cg = 0
        while True:
            failed, inexact = False, False
            try:
                # Newton judges its directions itself (the line search and
                # the stopping rule on the whole direction): a loose one
                # costs iterations, which NewtonNotConverged reports, so
                # minimizeEnergy's conditioning warning stays for users.
                directions = minimize_energy(
                    scene, current_backend(), tolerance_of, cg_max_iterations,
                    None, fixed, cg_stopping, threshold,
                    warn_conditioning=False)
            except SolverError as error:
                # A CG iterate from zero on an SPD system is a descent
                # direction: take it, inexactly, and let the line search
                # judge.
                directions, inexact = error.solution, True
                failed = error.info["stop"] == "breakdown"
            solve = scene.lastSolve
            spent = solve["seconds"]
            report.seconds["derivatives"] += spent["derivatives"]
            report.seconds["assembly"] += spent["indices"] + spent["assembly"]
            report.seconds["pcg"] += spent["solve"]
            # A redone trial of the other preconditioner was work too.
            cg += int(solve["iterations"]) + int(solve["trialIterations"])
            if threshold is None or \
                    solve["projectedInstances"] == solve["instances"]:
                break
            # With exact Hessians the system may be indefinite: where CG met
            # negative curvature or the direction does not descend, project
            # more (the threshold falls), as SymX does.
            if not failed and solve["descends"]:
                break
            threshold = _TIGHTEN * (solve["gradientMax"]
                                    if threshold == _NONE else threshold)
            if threshold < _SMALLEST_THRESHOLD:
                threshold = 0.0
            report.projection_retries += 1
        report.inexact_directions += inexact
        return directions, cg, solve["tolerance"] <= cg_tolerance

    def measure(steps: List[np.ndarray]) -> Tuple[float, float, float]:
        """The largest safe fraction of ``steps``, their length (world
        space with contact) and the contact's CCD bound (1 without)."""
        alpha = 1.0
        if step_bound is not None:
            alpha = min(alpha, step_bound(current[0], steps[0]) if
                        len(targets) == 1 else step_bound(current, steps))
        # IPC's stopping rule measures the whole direction, not the step
        # taken: a step that CCD or the line search cuts short is no sign
        # of convergence (a vertex thrown at a plane stopped that way before
        # the barrier held it).
        if contact is not None:
            start = clock()
            bound, length = contact.step_bound_and_length(steps)
            report.seconds["ccd"] += clock() - start
            return min(alpha, bound), length, bound
        return alpha, max(float(np.abs(p).max()) for p in steps), 1.0

    for _ in range(max_iterations):
        current = [t.value for t in targets]
        directions, cg, tight = solve_direction(
            forcing.tolerance if forcing is not None else cg_tolerance)
        steps = [-dx for dx in directions]
        alpha, length, bound = measure(steps)
        if length < tolerance and not tight:
            # A loosely solved direction would end the step: Newton stops
            # only on a direction solved to the caller's tolerance.
            directions, more, _ = solve_direction(lambda _: cg_tolerance)
            cg += more
            report.tightened_solves += 1
            steps = [-dx for dx in directions]
            alpha, length, bound = measure(steps)
        if threshold is not None and threshold != _NONE:
            threshold *= _RELEASE
        report.cg_iterations.append(cg)
        _totals["cg"] += cg
        if contact is not None:
            report.step_bounds.append(bound)
        report.residual = length / tolerance if tolerance > 0 else \
            float("inf")
        report.residuals.append(report.residual)
        while alpha > 1e-10:
            for t, value, p in zip(targets, current, steps):
                t.updateValue(value + alpha * p)
            candidate = energy()
            if candidate <= current_energy:
                break
            alpha *= 0.5
        else:
            for t, value in zip(targets, current):
                t.updateValue(value)
            energy()
            report.step_sizes.append(0.0)
            break
        report.step_sizes.append(alpha)
        report.step_energies.append((current_energy, candidate))
        current_energy = candidate
        report.iterations += 1
        _totals["newton"] += 1
        report.energies.append(current_energy)
        if contact is not None:
            current_energy = adapt()
        if length < tolerance:
            report.converged = True
            break
    return report


#: ImplicitEuler's default gravity: (0, 0, -9.81) for a single target;
#: with several targets whose inertia is all in world space, none of their
#: own (``world_gravity`` pulls the world positions).
DEFAULT_GRAVITY = (0.0, 0.0, -9.81)


def initial_velocities(targets: Sequence[Attribute], given,
                       single: bool) -> List[np.ndarray]:
    """ImplicitEuler's starting velocities: ``given`` (one array or None
    per target; one array for a single target) as arrays shaped as the
    targets' values, zero where None."""
    if given is None:
        given = [None] * len(targets)
    elif single and not isinstance(given, (list, tuple)):
        given = [given]
    given = list(given)
    if len(given) != len(targets):
        raise SceneError(f"ImplicitEuler: {len(given)} velocities for "
                         f"{len(targets)} targets (give one array or None "
                         f"per target)")
    out = []
    for t, v in zip(targets, given):
        value = t.value
        if v is None:
            out.append(np.zeros_like(value))
            continue
        v = np.asarray(v, dtype=float)
        if v.size != value.size:
            raise SceneError(f"ImplicitEuler: the velocity of "
                             f"{t.describe()} has shape {v.shape}; its value "
                             f"is {value.shape}")
        if not np.isfinite(v).all():
            raise SceneError(f"ImplicitEuler: the velocity of "
                             f"{t.describe()} is not finite")
        out.append(v.reshape(value.shape).copy())
    return out


class ImplicitEuler:
    """Implicit Euler time stepping of the scene's minimisation targets
    (``targets``: one attribute or the list of them, in the scene's order),
    whose inertia energies pull towards the ``predicted`` attributes (one
    constant attribute per target, or one for a single target): every step
    predicts ``x_hat = x + dt v + dt^2 g`` (``gravity``: one vector for a
    single target, or one per target, None for none) and minimises the
    energy by :func:`newton` with ``settings`` (a :class:`NewtonSettings`),
    with ``contact`` if given, until the largest displacement of a Newton
    step over ``dt`` is below ``velocity_tolerance`` (paper section 9.1;
    ``Relative(f)``: f times the contact's size per second, as IPC states
    it); then ``v = (x_new - x_old) / dt``. ``fixed`` (as for
    :func:`newton`) keeps DoFs where they are. ``stepper.settings`` may be
    replaced between steps.

    The targets and predictions were also ``x`` and ``x_hat``, and the
    settings' fields keywords of ImplicitEuler (and attributes of the
    stepper): those spellings still work and warn once.

    With friction, the normal forces, tangent bases and closest points of
    friction are lagged at the step's start, and the step is solved once
    (IPC's default). ``friction_iterations`` > 1 re-lags them at the
    solution (tangential motion still measured from the step's start) and
    solves again, up to that many lags in all or until a solve after a lag
    converges at once (IPC's lagged iterations): the friction force then
    follows the step's own normal force, which matters for stiff bodies
    that bounce in contact.

    ``settings.projection``: whether Newton starts from the exact local
    Hessians and projects only where a solve needs it ("progressive":
    SymX's and STARK's default, and ours: Newton converges quadratically
    where a cloth buckles), or projects every instance's Hessian ("full",
    projected Newton).

    ``velocities``: the targets' velocities at the start, one array (the
    target's value shape, or (N, rows) for column targets) or None (at
    rest) per target, or one array for a single target; for an affine
    body's A and t, :func:`yasps.sim.affine_velocity` gives them from an
    angular and a linear velocity. ``stepper.velocities`` holds them after
    each step (``(x_new - x_old) / dt``, one array per target shaped as its
    value) and may be set between steps.

    ``warm_start`` (on by default): Newton starts from the positions the
    last velocities carry the targets to, ``x + dt v``, cut to the fraction
    of that motion the step bounds allow (CCD with contact, ``step_bound``),
    instead of from ``x``: in smooth motion its first direction then only
    corrects the change of velocity (22% fewer Newton iterations on the
    twisting cloth, 6% on the bunny on a cloth, docs/benchmarks.md). The
    solution is the same minimiser; False starts from ``x``, as IPC does.

    ``world``: world-space inertias (:func:`yasps.sim.add_world_inertia`)
    of bodies whose parameters are not world positions or linear maps of
    them (angles, rotation vectors): each step predicts their world
    positions from world velocities and ``world_gravity``, and keeps the
    velocities (``world_velocities``: their starting values, one (N, 3)
    array or None per inertia; ``inertia.velocity`` after each step).
    Targets whose inertia is all in world space take ``predicted=None``
    (or no ``predicted`` at all) and no gravity of their own.
    ``normalize``: per target, None or a function applied to its value
    after each step, for a parameter with several values of the same
    world positions (:func:`yasps.sim.wrap_rotation_vectors`)."""

    def __init__(self, scene, targets: Optional[Targets] = None,
                 predicted: Optional[Predictions] = None,
                 dt: Optional[float] = None, *,
                 settings: Optional[NewtonSettings] = None,
                 gravity=DEFAULT_GRAVITY, velocity_tolerance: float = 1e-2,
                 step_bound: Optional[Callable[[np.ndarray, np.ndarray],
                                               float]] = None,
                 fixed=None, contact=None, friction_iterations: int = 1,
                 warm_start: bool = True, velocities=None, world=None,
                 world_velocities=None,
                 world_gravity=(0.0, 0.0, -9.81), normalize=None,
                 record: bool = False,
                 checkpoint_every: Optional[int] = None,
                 **deprecated: Any):
        x: Optional[Targets] = renamed_argument(
            "ImplicitEuler", "x", "targets", targets, deprecated)
        x_hat: Optional[Predictions] = renamed_argument(
            "ImplicitEuler", "x_hat", "predicted", predicted, deprecated)
        self.settings = settings_with_keywords("ImplicitEuler", settings,
                                               deprecated)
        if x is not None and x_hat is None and world is not None:
            x_hat = [None] * len(_as_list(x))   # all inertia in world space
        if x is None or x_hat is None or dt is None:
            raise SceneError("ImplicitEuler: give the targets, their "
                             "predictions (predicted=, None for a target "
                             "whose inertia is in world space) and dt")
        single = isinstance(x, Attribute)
        self.scene, self.dt = scene, float(dt)
        self.targets, self.predicted = _as_list(x), _as_list(x_hat)
        if len(self.targets) != len(self.predicted):
            raise SceneError(f"ImplicitEuler: {len(self.targets)} targets but "
                             f"{len(self.predicted)} predictions")
        _check_targets(scene, self.targets)
        if not single and (gravity is None or (
                all(p is None for p in self.predicted)
                and gravity is DEFAULT_GRAVITY)):
            # None for all; world inertia alone: gravity acts in the world.
            gravity = [None] * len(self.targets)
        gravities = [gravity] if single else list(gravity)
        if len(gravities) != len(self.targets):
            raise SceneError("ImplicitEuler: give one gravity (or None) per "
                             "target")
        self.gravity = [None if g is None else
                        np.asarray(g, dtype=float).reshape(1, -1, 1)
                        for g in gravities]
        for t, hat, g in zip(self.targets, self.predicted, self.gravity):
            if hat is None and g is not None:
                raise SceneError(f"ImplicitEuler: {t.describe()} has no "
                                 f"prediction, so no gravity of its own "
                                 f"(give None; world_gravity pulls world "
                                 f"inertia)")
        #: the world-space inertias (:mod:`yasps.sim.world`)
        self.world: List[WorldInertia] = [] if world is None else \
            ([world] if isinstance(world, WorldInertia) else list(world))
        self.world_gravity = None if world_gravity is None else \
            np.asarray(world_gravity, dtype=float).reshape(3)
        given = [None] * len(self.world) if world_velocities is None \
            else list(world_velocities)
        if len(given) != len(self.world):
            raise SceneError(f"ImplicitEuler: {len(given)} world velocities "
                             f"for {len(self.world)} world inertias")
        for inertia, v in zip(self.world, given):
            inertia.set_velocity(v)
        self.normalize = [None] * len(self.targets) if normalize is None \
            else list(normalize)
        if len(self.normalize) != len(self.targets):
            raise SceneError("ImplicitEuler: give one normalize function "
                             "(or None) per target")
        masks = [fixed] if single else (list(fixed) if fixed is not None
                                        else [None] * len(self.targets))
        if len(masks) != len(self.targets):
            raise SceneError("ImplicitEuler: give one fixed mask (or None) "
                             "per target")
        self.fixed = [None if m is None else
                      checked_fixed_mask(t, m, "ImplicitEuler")
                      for t, m in zip(self.targets, masks)]
        if isinstance(velocity_tolerance, Relative):
            if contact is None:
                raise SceneError("ImplicitEuler: a Relative velocity_tolerance "
                                 "is a fraction of the contact's size; give "
                                 "a contact, or a number")
            velocity_tolerance = resolve(velocity_tolerance, contact.size)
        self.velocity_tolerance = velocity_tolerance
        self.step_bound, self.contact = step_bound, contact
        if contact is not None:
            # Inertia m/2 |x - x_hat|^2 beside potentials scaled by dt^2:
            # the contact's energies are dt^2 times its potential, which
            # Contact.forces divides out to report newtons.
            contact.energy_scale = self.dt * self.dt
        if int(friction_iterations) != friction_iterations or \
                friction_iterations < 1:
            raise SceneError(f"ImplicitEuler: friction_iterations must be a "
                             f"whole number >= 1, got {friction_iterations!r}")
        self.friction_iterations = int(friction_iterations)
        self.warm_start = bool(warm_start)
        #: the entries that follow a function of time (:meth:`prescribe`)
        self.prescriptions: List[Prescription] = []
        #: the time at the end of the last step (0 at construction)
        self.time = 0.0
        self.velocities = initial_velocities(self.targets, velocities,
                                             single)
        self._warned = False
        self._warned_inverted = False
        #: with ``record``: what backward() reads, from the first step on
        self.record = bool(record)
        #: called with the stepper at the start of every step, before the
        #: predictions (a drive's damping reads the coordinates there)
        self.before_step: List[Callable[["ImplicitEuler"], None]] = []
        self.tape: Optional[Tape] = None
        if checkpoint_every is not None and (
                int(checkpoint_every) != checkpoint_every or
                checkpoint_every < 1 or not record):
            raise SceneError(f"ImplicitEuler: checkpoint_every must be a "
                             f"whole number >= 1 with record=True, got "
                             f"{checkpoint_every!r}")
        self.checkpoint_every = None if checkpoint_every is None \
            else int(checkpoint_every)

    def run(self, frames: int, on_frame: Optional[Callable[[int, NewtonReport],
                                                          None]] = None,
            progress: bool = True) -> NewtonReport:
        """Takes ``frames`` steps with a progress bar (tqdm; ``progress=False``
        for none), calling ``on_frame(frame, report)`` after each (frames
        count from 1); returns the sum of the steps' reports."""
        total = NewtonReport()
        total.converged = True
        #: the first frame that ended with tets inverted, and what inverted
        first_inverted: Tuple[int, List[Tuple[int, str, str]]] = (0, [])
        # The wait for kernels shown on its own bar before the frames'.
        compiled = compile_kernels(self.scene, self.contact, progress)
        total.seconds["compile"] += compiled
        with tqdm(range(1, frames + 1), unit="frame", disable=not progress,
                  leave=False) as bar:
            for frame in bar:
                report = self.step(warn=False)
                total.add(report)
                total.converged = total.converged and report.converged
                if not report.converged:
                    total.unconverged.append((frame, report.residual))
                if report.inverted_tets and not total.inverted_tets:
                    first_inverted = (frame, count_inverted(self.scene,
                                                            self.targets))
                total.inverted_tets = max(total.inverted_tets,
                                          report.inverted_tets)
                bar.set_postfix(newton=report.iterations,
                                **({"unconverged": len(total.unconverged)}
                                   if total.unconverged else {}))
                if on_frame is not None:
                    on_frame(frame, report)
        if total.unconverged:
            warnings.warn(
                f"ImplicitEuler.run: {total.unconverged_text()} of {frames}: "
                f"Newton stopped at its cap of "
                f"{self.settings.max_iterations} "
                "iterations (or where the line search found no decrease) "
                "before the step fell below velocity_tolerance * dt. Raise "
                "max_iterations, or see docs/contact.md on convergence",
                NewtonNotConverged, stacklevel=2)
        if total.inverted_tets:
            frame, found = first_inverted
            warnings.warn(inverted_text(
                found, f"ImplicitEuler.run, from frame {frame}"),
                ElementsInverted, stacklevel=2)
        return total

    def backward(self, dloss: Mapping[Attribute, Any],
                 parameters: Sequence[Attribute] = (),
                 dloss_velocities: Optional[Mapping[Attribute, Any]] = None,
                 tolerance: float = 1e-6,
                 threads: Optional[int] = None,
                 hessian: str = "exact") -> SimulationGradients:
        """The gradient of a loss L of the recorded run's last state (the
        stepper made with ``record=True``): ``dloss`` gives dL/dq per target
        at the last step (shaped like its value; ``dloss_velocities`` dL/dv
        likewise), ``parameters`` the stored attributes to differentiate
        with respect to (materials, rest-shape constants, masses; not the
        targets or predictions). One solve per step with the step's exact
        Hessian, the collision set held at each step's solution and
        friction's lags held fixed (docs/diff.md). Returns
        :class:`yasps.sim.adjoint.SimulationGradients`: parameter -> array
        shaped like its value, with ``initial_positions`` and
        ``initial_velocities`` (one array per target). Warns
        (AdjointWarning) when a step's free gradient exceeds
        ``tolerance``. Leaves the scene in the run's last state.
        ``hessian="projected"`` solves with each instance's block
        PSD-projected instead of the exact Hessian: another, approximate
        gradient, for measuring what projection would cost
        (docs/diff.md)."""
        return backward(self, dloss, parameters, current_backend(),
                        dloss_velocities, tolerance, threads, hessian)

    def save(self, path) -> Path:
        """Writes what the next step reads to ``path`` (``.npz`` added
        where it lacks it), atomically: the scene's stored values and
        dynamic pairs, the velocities, the contact's adaptive stiffness
        (:mod:`yasps.sim.checkpoint`). Returns the file written."""
        return checkpoint.save(self, path)

    def restore(self, path) -> None:
        """Reads a :meth:`save` (``path`` as given to it, with or without
        ``.npz``) of a stepper of the same scene structure and dt: the run
        then continues bit for bit as the saved one did (with the
        contact's default detection; ipctk's lists pairs in a
        thread-dependent order)."""
        checkpoint.restore(self, path)

    def prescribe(self, target: Attribute, fn: Callable[[float], np.ndarray],
                  mask=None) -> None:
        """Makes entries of ``target`` (one of the stepper's targets; with
        ``mask``, a boolean mask of its instances or entries, those only)
        follow ``fn(time)``, which gives their values at that time (the
        masked entries' values in order, any shape of that size):
        kinematic pins that move, a motor turning an affine body's A, a
        scripted obstacle. Each step moves them to ``fn(time + dt)`` before
        Newton, as far as CCD allows; where something is in the way, a
        penalty pulls them there with everything free (so a motor pushes
        what it meets, as IPC's kinematic conditions do), and they move
        the rest of the way; what CCD still forbids is left for later
        steps, reported as ``report.prescribed_lag``. Newton then keeps them
        fixed (:mod:`yasps.sim.prescribed`). ``stepper.time`` counts from 0
        at construction. Registers the penalty as an energy of the
        target's primitive (off until needed)."""
        found = prescription(self.targets, target, fn, mask)
        found.pull = add_pull(target, len(self.prescriptions))
        self.prescriptions.append(found)

    def _bound(self, steps: List[np.ndarray]) -> float:
        """The safe fraction of the motion ``steps`` (one per target) from
        the targets' values now: ``step_bound``'s and the contact's CCD."""
        return self._bound_and_length(steps)[0]

    def _bound_and_length(self, steps: List[np.ndarray]
                          ) -> Tuple[float, float]:
        """``_bound(steps)``, and how far the motion moves a position at
        most, as Newton measures its directions (world positions with a
        contact, else the targets' entries)."""
        alpha = 1.0
        now = [t.value for t in self.targets]
        bound = guarded_step_bound(self.scene, self.targets, self.step_bound)
        if bound is not None:
            alpha = bound(now[0], steps[0]) if len(steps) == 1 \
                else bound(now, steps)
        if self.contact is None:
            return alpha, max(float(np.abs(s).max()) for s in steps)
        contact_bound, length = self.contact.step_bound_and_length(steps)
        return min(alpha, contact_bound), length

    def _start_from_velocities(self, fixed) -> float:
        """Moves the targets' free entries (not in ``fixed``, Newton's
        masks) from their values towards ``+ dt v`` as far as the step
        bounds allow (warm_start); returns the seconds the bounds took.

        A motion that moves no position by Newton's tolerance
        (``velocity_tolerance * dt``) is not taken: Newton cannot resolve
        it, and carried from step to step it never dies out. A body resting
        on the ground kept such a creep: each guess pressed it further into
        the barrier, cut by CCD to a fraction of its distance, and Newton,
        whose steps there are as small as the distance, stopped at once,
        until rounding put a vertex below the ground (an affine box at
        dt = 0.1 s, bench/extremes.py)."""
        steps = [self.dt * v for v in self.velocities]
        for k, mask in enumerate(fixed or []):
            if mask is not None:
                steps[k] = np.where(entry_mask(self.targets[k], mask,
                                               "ImplicitEuler"), 0.0,
                                    steps[k])
        if not any(step.any() for step in steps):
            return 0.0
        clock = time.perf_counter()
        alpha, length = self._bound_and_length(steps)
        if length < self.velocity_tolerance * self.dt:
            return time.perf_counter() - clock
        for t, step in zip(self.targets, steps):
            t.updateValue(t.value + alpha * step)
        return time.perf_counter() - clock

    def _solve(self, fixed) -> "NewtonReport":
        """Newton on the step's energy with the entries ``fixed`` (one mask
        or None per target) held."""
        if fixed is not None and all(m is None for m in fixed):
            fixed = None
        return newton(self.scene, self.targets,
                      tolerance=self.velocity_tolerance * self.dt,
                      step_bound=self.step_bound,
                      settings=self.settings, fixed=fixed,
                      contact=self.contact, compile_first=False)

    @property
    def velocity(self) -> np.ndarray:
        """Deprecated: ``velocities[0]``."""
        warn_renamed("ImplicitEuler.velocity", "ImplicitEuler.velocities[0]")
        return self.velocities[0]

    def step(self, warn: bool = True) -> NewtonReport:
        """Advances one time step; returns the Newton report. A step that
        ends unconverged warns (NewtonNotConverged, once per stepper;
        ``warn=False`` for none: ``run`` warns once per run instead).
        NumPy's BLAS runs on one thread meanwhile
        (:mod:`yasps.runtime.blas`)."""
        with one_blas_thread():
            return self._step(warn)

    def _step(self, warn: bool) -> NewtonReport:
        """step() with NumPy's BLAS on one thread."""
        # Before friction's lag, which computes world positions: no stage
        # but ``compile`` includes compiling.
        compile_seconds = compile_kernels(self.scene, self.contact, False)
        if self.record and self.tape is None:
            self.tape = start_recording(self, self.checkpoint_every)
        if self.contact is not None:
            self.contact.forget_candidates()
        for hook in self.before_step:
            hook(self)
        previous = [t.value for t in self.targets]
        for inertia in self.world:
            inertia.predict(self.dt, self.world_gravity)
        for value, v, g, mask, hat in zip(previous, self.velocities,
                                          self.gravity, self.fixed,
                                          self.predicted):
            if hat is None:
                continue
            pull = np.zeros_like(value) if g is None else \
                np.broadcast_to(g, value.shape).copy()
            if mask is not None:
                pull[mask] = 0.0
            hat.updateValue(value + self.dt * v + self.dt * self.dt * pull)
        fixed = fixed_with_prescribed(self.fixed, self.prescriptions,
                                      self.targets)
        friction = self.contact is not None and self.contact.friction > 0
        start_world = (self.contact.world() if friction
                       and self.friction_iterations > 1 else None)
        report = None
        for lag in range(self.friction_iterations if friction else 1):
            lag_seconds = 0.0
            if friction:
                # Friction's normal forces, bases and closest points: those
                # of the step's start, then of the last solution (IPC's
                # lagging); tangential motion counts from the step's start.
                clock = time.perf_counter()
                self.contact.update(lag=True, dt=self.dt,
                                    step_start=start_world if lag else None)
                lag_seconds = time.perf_counter() - clock
            guess_seconds = 0.0
            pulls: List[NewtonReport] = []
            if lag == 0:
                clock = time.perf_counter()
                lagging = move_prescribed(self.prescriptions, self.targets,
                                          self.time + self.dt, self._bound)
                prescribed_seconds = time.perf_counter() - clock
                if lagging > 0.0:
                    # Stopped short by what they must push: pulled there
                    # with everything free, then the rest of the way.
                    pulls = pull_prescribed(
                        self.prescriptions, self.targets, self.time + self.dt,
                        lambda: self._solve(self.fixed), self.scene)
                    lagging = move_prescribed(
                        self.prescriptions, self.targets, self.time + self.dt,
                        self._bound)
                elif self.warm_start:
                    guess_seconds = self._start_from_velocities(fixed)
            solve = self._solve(fixed)
            for pulled in pulls:
                solve.add(pulled)
            solve.seconds["collisions"] += lag_seconds
            solve.seconds["ccd"] += guess_seconds + (prescribed_seconds
                                                     if lag == 0 else 0.0)
            solve.friction_lags = int(friction)
            if report is None:
                report = solve
            else:
                report.add(solve)
                report.energies += solve.energies
                report.step_bounds += solve.step_bounds
                report.step_sizes += solve.step_sizes
                report.residuals += solve.residuals
                report.stiffness += solve.stiffness
                report.converged = solve.converged
            # Consistent: the solution did not move after the last lag.
            if lag and solve.converged and solve.iterations <= 1:
                break
        self.velocities = [(t.value - p) / self.dt
                           for t, p in zip(self.targets, previous)]
        for inertia in self.world:
            inertia.finish(self.dt)
        for t, fn in zip(self.targets, self.normalize):
            if fn is not None:
                t.updateValue(fn(t.value))
        self.time += self.dt
        if self.tape is not None:
            self.tape.record_step(self, fixed)
        assert report is not None  # friction_iterations >= 1: one solve
        report.prescribed_lag = lagging
        report.seconds["compile"] += compile_seconds
        inverted = count_inverted(self.scene, self.targets)
        report.inverted_tets = sum(count for count, _, _ in inverted)
        if warn and inverted and not self._warned_inverted:
            self._warned_inverted = True
            warnings.warn(inverted_text(inverted, "ImplicitEuler.step"),
                          ElementsInverted, stacklevel=2)
        if warn and not report.converged and not self._warned:
            self._warned = True
            warnings.warn(
                f"ImplicitEuler.step: Newton stopped unconverged after "
                f"{report.iterations} iterations (last direction "
                f"{report.residual:.3g}x the tolerance); NewtonReport."
                "converged tells for each step (warned once per stepper)",
                NewtonNotConverged, stacklevel=2)
        return report


# The settings' fields as the stepper's attributes, spelled so before
# NewtonSettings.
add_settings_attributes(ImplicitEuler)
