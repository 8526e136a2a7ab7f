"""Inertia in world space, for bodies of any parameterisation.

Implicit Euler's inertia ``m/2 |x - x_hat|^2`` with ``x_hat = x + dt v +
dt^2 g`` is exact for targets that are world positions, or linear maps of
them (an affine body's A and t predict linearly). For an angle, a rotation
vector or any non-linear map, a prediction in the parameters is not the
world's: the inertia must be written on the world positions ``x(q)`` the
parameterisation computes, with the prediction made from world positions
and world velocities. :func:`add_world_inertia` registers that energy (the
compiler differentiates the map, so no derivative is written by hand), and
:class:`yasps.sim.ImplicitEuler` (``world=[...]``) predicts it each step
and keeps its world velocities; the parameters themselves then need no
prediction (``predicted=None`` for them).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..frontend import energies as E
from ..frontend.attribute import Attribute, owner_of
from ..frontend.errors import SceneError
from .bodies import position_owner


@dataclass
class WorldInertia:
    """World-space inertia on computed positions (see the module
    docstring)."""
    #: the world positions, a 3x1 attribute computed from the targets
    positions: Attribute
    #: the prediction, a 3x1 constant beside them
    x_hat: Attribute
    #: the masses, a 1x1 constant beside them
    mass: Attribute
    #: the world velocities (N, 3, 1) at the start of the next step
    velocity: Optional[np.ndarray] = field(repr=False, default=None)
    _start: Optional[np.ndarray] = field(repr=False, default=None)

    def world(self) -> np.ndarray:
        """The world positions now, (N, 3, 1)."""
        return np.array(self.positions.compute().value, dtype=float)

    def set_velocity(self, velocity) -> None:
        """Sets the world velocities: an (N, 3) or (N, 3, 1) array, or None
        for rest."""
        count = owner_of(self.positions).numInstances
        if velocity is None:
            self.velocity = np.zeros((count, 3, 1))
            return
        velocity = np.asarray(velocity, dtype=float)
        if velocity.size != 3 * count or not np.isfinite(velocity).all():
            raise SceneError(f"world inertia of "
                             f"{self.positions.describe()}: give {count} "
                             f"finite 3-vectors of velocity, got shape "
                             f"{velocity.shape}")
        self.velocity = velocity.reshape(count, 3, 1).copy()

    def predict(self, dt: float, gravity: Optional[np.ndarray]) -> None:
        """At a step's start: ``x_hat = x + dt v + dt^2 g``."""
        # add_world_inertia sets it (set_velocity), and every step after.
        assert self.velocity is not None
        self._start = self.world()
        pull = 0.0 if gravity is None else \
            np.asarray(gravity, dtype=float).reshape(1, 3, 1)
        self.x_hat.updateValue(self._start + dt * self.velocity
                               + dt * dt * pull)

    def finish(self, dt: float) -> None:
        """At a step's end: ``v = (x_new - x_old) / dt``."""
        self.velocity = (self.world() - self._start) / dt


def add_world_inertia(positions: Attribute, masses,
                      projection: str = "none") -> WorldInertia:
    """Registers ``m/2 |x(q) - x_hat|^2`` on the world positions
    ``positions`` (a 3x1 attribute of a primitive, computed from the
    minimisation targets through any parameterisation) with ``masses``
    (one per instance, or one for all), for :class:`ImplicitEuler`'s
    ``world=[...]``. Adds the constants ``x_hat`` and ``mass`` to the
    positions' primitive (``mass`` is what a contact's adaptive stiffness
    reads). ``projection``: as ``addEnergy``; "none" by default, though
    through a non-linear map the Hessian ``J^T M J + sum m (x - x_hat)
    d2x/dq2`` can be indefinite far from the prediction, where "clamp"
    helps Newton."""
    owner = position_owner(positions, "add_world_inertia", ("x_hat", "mass"))
    count = owner.numInstances
    x_hat = owner.addConstant("x_hat", rows=3)
    x_hat.updateValue(np.array(positions.compute().value, dtype=float))
    mass = owner.addConstant("mass", rows=1)
    mass.updateValue(np.broadcast_to(
        np.asarray(masses, dtype=float).reshape(-1, 1), (count, 1)).copy())
    owner.scene.addEnergy(owner.addAttribute(
        "world_inertia", computed_attribute=E.inertia(positions, x_hat, mass)),
        projection=projection)
    inertia = WorldInertia(positions, x_hat, mass)
    inertia.set_velocity(None)
    return inertia
