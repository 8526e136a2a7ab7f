"""Joint-space quantities of an articulated body, from its compiled world
inertia: the mass matrix and the Jacobians of its inertia points.

Both read the derivatives of ``m/2 |x(q) - x_hat|^2`` on the inertia
points (:mod:`.inertia_points`): its gradient is ``m J^T (x - x_hat)``, so
``x_hat = x - e_a / m`` gives row ``a`` of every point's Jacobian ``J``,
and at ``x_hat = x`` its Hessian is ``sum m J^T J``, the joint-space mass
matrix, exactly for rigid links. The predictions are restored afterwards.
"""

from __future__ import annotations

from typing import Dict, List, Tuple

import numpy as np

from ..frontend.attribute import Attribute
from ..frontend.scene import Scene
from ..sim.world import WorldInertia
from .build import ArticulatedBody, Depth


Key = Tuple[str, int, int]


def _key(target: Attribute, instance: int, entry: int) -> Key:
    return (target.describe(), instance, entry)


def _coordinates(body: ArticulatedBody) -> Dict[Key, int]:
    """(a target, instance, entry) -> index of the coordinate."""
    out: Dict[Key, int] = {}
    for target in body.targets:
        count = int(np.asarray(target.value).shape[0])
        for instance in range(count):
            for entry in range(target.rows * target.cols):
                out[_key(target, instance, entry)] = len(out)
    return out


def _derivatives(scene: Scene, depth: Depth, x_hat: np.ndarray):
    inertia = depth.inertia
    assert inertia is not None and depth.points is not None
    saved = np.array(inertia.x_hat.value, dtype=float)
    try:
        inertia.x_hat.updateValue(x_hat)
        return scene.energyDerivatives(depth.points["world_inertia"])
    finally:
        inertia.x_hat.updateValue(saved)


def _columns(derivatives, coordinates, count: int) -> List[np.ndarray]:
    """Per energy instance, the coordinate of each local parameter (-1 for
    another body's parameter or padding)."""
    out = []
    for i in range(count):
        out.append(np.array([
            -1 if place is None else
            coordinates.get(_key(*place), -1)
            for place in derivatives.locations(i)]))
    return out


def _moving_depths(body: ArticulatedBody
                   ) -> List[Tuple[Depth, WorldInertia]]:
    return [(d, d.inertia) for d in body.depths if d.inertia is not None]


def point_jacobians(scene: Scene, body: ArticulatedBody) -> List[np.ndarray]:
    """Per depth with inertia points (the order of ``body.world``), their
    Jacobians ``dx/dq`` (N, 3, n) with respect to the body's coordinates
    (``body.targets`` flattened: a floating base's w and t, then the
    joints in the order of ``joint_names``)."""
    coordinates = _coordinates(body)
    out = []
    for depth, inertia in _moving_depths(body):
        x = inertia.world()
        mass = np.asarray(inertia.mass.value, float).reshape(-1)
        J = np.zeros((len(x), 3, len(coordinates)))
        columns = None
        for a in range(3):
            x_hat = x.copy()
            x_hat[:, a, 0] -= 1.0 / mass
            d = _derivatives(scene, depth, x_hat)
            if columns is None:
                columns = _columns(d, coordinates, len(x))
            for i, cols in enumerate(columns):
                # A coordinate may stand in several slots: sum them.
                np.add.at(J[i, a], cols[cols >= 0], d.gradient[i][cols >= 0])
        out.append(J)
    return out


def mass_matrix(scene: Scene, body: ArticulatedBody) -> np.ndarray:
    """The joint-space mass matrix (n, n) at the current coordinates, in the
    order of :func:`point_jacobians`' columns."""
    coordinates = _coordinates(body)
    M = np.zeros((len(coordinates), len(coordinates)))
    for depth, inertia in _moving_depths(body):
        x = inertia.world()
        d = _derivatives(scene, depth, x)
        for i, cols in enumerate(_columns(d, coordinates, len(x))):
            keep = cols >= 0
            rows, columns = np.meshgrid(cols[keep], cols[keep], indexing="ij")
            np.add.at(M, (rows, columns), d.hessian[i][np.ix_(keep, keep)])
    return M
