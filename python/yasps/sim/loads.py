"""External forces on vertices and bodies.

A force ``f`` on a vertex at ``x`` is the potential ``-f . x``; scaled by
dt^2 beside implicit Euler's inertia, as every potential of a stepped scene
is. The forces are a stored value: changing them (a load that ramps up, a
push at one frame) recompiles nothing. A body of any parameterisation is
loaded through its vertices' world positions, so a force on an affine or
rotation-vector body needs no derivative by hand; spread over the vertices
in proportion to their masses (:meth:`Loads.set_total`) it acts at the
centre of mass and turns nothing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..frontend.attribute import Attribute, owner_of
from ..frontend.errors import SceneError
from .bodies import material_constant, position_owner


@dataclass
class Loads:
    """The forces on the instances of a 3x1 world-position attribute (see
    :func:`add_loads`)."""
    #: the world positions the forces act at
    positions: Attribute
    #: the forces, a 3x1 stored constant beside them
    forces: Attribute

    @property
    def count(self) -> int:
        return owner_of(self.positions).numInstances

    def _mask(self, mask) -> np.ndarray:
        if mask is None:
            return np.ones(self.count, dtype=bool)
        mask = np.asarray(mask)
        if mask.dtype != bool or mask.shape != (self.count,):
            raise SceneError(f"Loads: the mask must be a boolean array of "
                             f"{self.count} instances, got {mask.dtype} "
                             f"{mask.shape}")
        return mask

    def set(self, forces, mask=None) -> None:
        """Sets the force on each instance (where ``mask``, a boolean array
        of the instances, is set; 0 elsewhere): ``forces`` one 3-vector for
        all of them, or one per selected instance (K, 3)."""
        where = self._mask(mask)
        forces = np.asarray(forces, dtype=float)
        values = np.zeros((self.count, 3))
        try:
            values[where] = forces.reshape(-1, 3) if forces.size != 3 \
                else forces.reshape(3)
        except ValueError:
            raise SceneError(f"Loads.set: give one 3-vector or "
                             f"{int(where.sum())} of them, got shape "
                             f"{forces.shape}") from None
        if not np.isfinite(values).all():
            raise SceneError("Loads.set: forces must be finite")
        self.forces.updateValue(values[:, :, None])

    def set_total(self, force, weights=None, mask=None) -> None:
        """Spreads the 3-vector ``force`` over the selected instances in
        proportion to ``weights`` (their masses: the force then acts at
        their centre of mass; default equal shares)."""
        where = self._mask(mask)
        w = np.ones(self.count) if weights is None else \
            np.broadcast_to(np.asarray(weights, dtype=float).reshape(-1),
                            (self.count,)).copy()
        w = np.where(where, w, 0.0)
        if not w.sum() > 0:
            raise SceneError("Loads.set_total: the selected weights sum to 0")
        self.set(np.outer(w / w.sum(), np.asarray(force, float).reshape(3)))

    @property
    def total(self) -> np.ndarray:
        """The sum of the forces (3,)."""
        return self.forces.value[:, :, 0].sum(axis=0)


def add_loads(positions: Attribute, scale: float = 1.0,
              name: str = "load") -> Loads:
    """External forces on the instances of ``positions`` (a 3x1 world
    position attribute of a primitive: free vertices' targets, or an affine,
    caged or rotation-vector body's computed positions), initially 0: adds
    a 3x1 constant ``name`` and the energy ``-scale * f . x`` (``scale``:
    dt^2 in an ImplicitEuler scene, as the materials take). Set them with
    :meth:`Loads.set` or :meth:`Loads.set_total`."""
    owner = position_owner(positions, "add_loads", (name,))
    forces = owner.addConstant(name, rows=3)
    forces.updateValue(np.zeros((owner.numInstances, 3, 1)))
    weight = material_constant(owner.parent, f"{owner.name}_{name}_scale",
                               scale)
    owner.scene.addEnergy(owner.addAttribute(
        f"{name}_energy",
        computed_attribute=-(weight * forces.dot(positions))))
    return Loads(positions, forces)
