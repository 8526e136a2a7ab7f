"""Joint drives: a PD controller per joint, as a potential of the step, and
the torques (forces, for prismatic joints) it exerts.

A drive pulls its joint's coordinate ``q`` towards a target position
``q*`` with stiffness ``kp`` and its velocity ``v = (q - q_0) / dt``
towards a target velocity ``v*`` with damping ``kd`` (``q_0`` the
coordinate at the step's start). Its force ``tau = kp (q* - q) + kd (v* -
v)`` is minus the gradient of

    dt^2 kp/2 (q - q*)^2 + dt kd/2 (q - q_0 - dt v*)^2,

which implicit Euler minimises beside its inertia ``m/2 |x - x_hat|^2`` (the
potentials' dt^2 written out): the drive's force is taken at the step's
end, as every other force of the step is. Targets are stored values: changing them per
frame recompiles nothing. :meth:`JointDrives.attach` has a stepper set
``q_0`` at every step's start; :meth:`JointDrives.torques` reads the force
of each drive after a step (the joint torque that holds a load).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Dict, List, Mapping, Optional, Sequence, Union

import numpy as np

from ..frontend.attribute import Attribute
from ..frontend.errors import SceneError
from ..frontend.scene import Scene
from .build import ArticulatedBody

Values = Union[float, Sequence[float], Mapping[str, float]]


def _per_joint(names: List[str], values: Values, current: np.ndarray,
               what: str) -> np.ndarray:
    """``values`` for every joint: all (in ``names``' order), one for all,
    or some by name with ``current`` for the others."""
    out = current.copy()
    if isinstance(values, Mapping):
        for name, value in values.items():
            if name not in names:
                raise SceneError(f"{what}: no moving joint named {name!r}; "
                                 f"the joints are {names}")
            out[names.index(name)] = float(value)
        return out
    given = np.asarray(values, dtype=float).reshape(-1)
    if given.size == 1:
        return np.full(len(names), float(given[0]))
    if given.shape != out.shape:
        raise SceneError(f"{what}: give {len(names)} values (one per joint, "
                         f"in joint_names' order), one for all, or a dict by "
                         f"name; got {given.size}")
    return given.copy()


@dataclass
class _Part:
    """One depth's drives: its slice of the coordinates and constants."""
    coordinates: Attribute
    where: slice
    target: Attribute
    rate: Attribute
    start: Attribute


@dataclass
class JointDrives:
    """The PD drives of an articulated body (:func:`add_joint_drives`)."""
    body: ArticulatedBody
    dt: float
    stiffness: np.ndarray   # kp (n,)
    damping: np.ndarray     # kd (n,)
    parts: List[_Part]
    energies: List[Attribute]
    #: target positions and velocities as functions of time (s) -> (n,),
    #: evaluated at each step's end time when attached
    schedule: Optional[Callable[[float], Dict[str, Values]]] = None
    _start: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def _read(self, name: str) -> np.ndarray:
        out = np.zeros(len(self.body.joint_names))
        for part in self.parts:
            out[part.where] = np.asarray(getattr(part, name).value,
                                         float).reshape(-1)
        return out

    def _write(self, name: str, values: np.ndarray) -> None:
        for part in self.parts:
            chunk = values[part.where]
            getattr(part, name).updateValue(chunk.reshape(len(chunk), 1, 1))

    @property
    def targets(self) -> np.ndarray:
        """The target positions q* (n,)."""
        return self._read("target")

    @property
    def target_velocities(self) -> np.ndarray:
        """The target velocities v* (n,)."""
        return self._read("rate") / self.dt

    def set_targets(self, positions: Optional[Values] = None,
                    velocities: Optional[Values] = None) -> None:
        """Sets target positions and/or velocities: all joints (in
        ``joint_names``' order), one value for all, or some by name."""
        if positions is not None:
            self._write("target", _per_joint(
                self.body.joint_names, positions, self.targets,
                "JointDrives.set_targets"))
        if velocities is not None:
            self._write("rate", self.dt * _per_joint(
                self.body.joint_names, velocities, self.target_velocities,
                "JointDrives.set_targets"))

    def begin_step(self, stepper=None) -> None:
        """Takes the coordinates at the step's start (``q_0``), and the
        scheduled targets at its end time if there is a schedule."""
        self._start = self.body.joint_positions()
        self._write("start", self._start)
        if self.schedule is not None and stepper is not None:
            self.set_targets(**self.schedule(stepper.time + stepper.dt))

    def attach(self, stepper) -> None:
        """Has ``stepper`` (an ImplicitEuler of the same dt) call
        :meth:`begin_step` at every step's start."""
        if not np.isclose(stepper.dt, self.dt, rtol=1e-12):
            raise SceneError(f"JointDrives.attach: the drives were made for "
                             f"dt = {self.dt}, the stepper steps {stepper.dt}")
        if getattr(stepper, "record", False):
            raise SceneError("JointDrives.attach: gradients of runs with "
                             "drives (record=True) are not supported yet: "
                             "the drives' step-start coordinates are not on "
                             "the tape")
        stepper.before_step.append(self.begin_step)

    def torques(self) -> np.ndarray:
        """Each drive's force on its joint after the last step (n,): N m
        for revolute joints, N for prismatic ones: ``kp (q* - q) + kd (v*
        - v)``, with ``v`` the step's mean velocity."""
        q = self.body.joint_positions()
        start = self._start if self._start.size else q
        velocity = (q - start) / self.dt
        return self.stiffness * (self.targets - q) + \
            self.damping * (self.target_velocities - velocity)


def add_joint_drives(scene: Scene, body: ArticulatedBody, dt: float,
                     stiffness: Values, damping: Values = 0.0,
                     joints: Optional[Sequence[str]] = None) -> JointDrives:
    """Adds a PD drive to every joint of ``body`` (or those named in
    ``joints``; the others get stiffness and damping 0) for steps of
    ``dt``: ``stiffness`` kp (N m / rad, N / m) and ``damping`` kd
    (N m s / rad, N s / m), one value for all or one per joint (a sequence
    in ``joint_names``' order or a dict by name). The targets start at the
    current coordinates and zero velocity. Call ``drives.attach(stepper)``
    once the stepper exists."""
    if not dt > 0:
        raise SceneError(f"add_joint_drives: dt must be > 0, got {dt}")
    names = body.joint_names
    zero = np.zeros(len(names))
    kp = _per_joint(names, stiffness, zero, "add_joint_drives: stiffness")
    kd = _per_joint(names, damping, zero, "add_joint_drives: damping")
    if joints is not None:
        unknown = [j for j in joints if j not in names]
        if unknown:
            raise SceneError(f"add_joint_drives: no moving joints named "
                             f"{unknown}; the joints are {names}")
        keep = np.array([n in joints for n in names])
        kp, kd = np.where(keep, kp, 0.0), np.where(keep, kd, 0.0)
    if (kp < 0).any() or (kd < 0).any() or not np.isfinite(kp + kd).all():
        raise SceneError("add_joint_drives: stiffness and damping must be "
                         "finite and >= 0")
    q = body.joint_positions()
    parts, energies, start = [], [], 0
    for depth in body.depths[1:]:
        count = len(depth.bodies)
        where = slice(start, start + count)
        start += count
        if not (kp[where] > 0).any() and not (kd[where] > 0).any():
            continue
        frames, coordinate = depth.frames, depth.q
        assert coordinate is not None

        def stored(name: str, values: np.ndarray) -> Attribute:
            attr = frames.addConstant(name, rows=1)
            attr.updateValue(np.asarray(values, float).reshape(count, 1, 1))
            return attr

        stiff = stored("drive_kp_dt2", kp[where] * dt * dt)
        damp = stored("drive_kd_dt", kd[where] * dt)
        part = _Part(coordinate, where, stored("drive_target", q[where]),
                     stored("drive_rate", np.zeros(count)),
                     stored("drive_start", q[where]))
        held = coordinate - part.target
        moved = coordinate - part.start - part.rate
        energy = frames.addAttribute("joint_drives", computed_attribute=(
            0.5 * stiff * held * held + 0.5 * damp * moved * moved))
        scene.addEnergy(energy)
        parts.append(part)
        energies.append(energy)
    return JointDrives(body, float(dt), kp, kd, parts, energies,
                       _start=q.copy())
