"""Rigid bodies parameterised by a rotation vector and a translation.

The world position of a vertex at rest offset ``X`` from the body's centre
of mass ``c`` is ``x = R(w) X + c + t``, with ``R(w)`` the rotation by
``|w|`` about ``w`` (Rodrigues' formula, written as yasps attributes so
that the compiler differentiates it; its Taylor series near ``w = 0``,
where the closed form is 0/0). Six parameters per body, the minimal
rigid parameterisation, against an affine body's twelve and its stiff
orthogonality energy. The map is non-linear, so the inertia lives in world
space (:mod:`.world`); rotation vectors past pi are wrapped back after each
step (:func:`wrap_rotation_vectors`: the same rotation, away from the
map's singularity at 2 pi).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..frontend.attribute import Attribute, select
from ..frontend.errors import SceneError
from ..frontend.scene import Mesh, Primitive
from .world import WorldInertia, add_world_inertia

#: Below this squared angle Rodrigues' coefficients come from their Taylor
#: series (to the s^2 terms: error below s^3 / 5040, under 1e-16 here).
SMALL_ANGLE2 = 1e-4


def rotate(w: Attribute, v: Attribute) -> Attribute:
    """``R(w) v`` for a rotation vector ``w`` and a vector ``v`` (3x1
    attributes): ``v + a w x v + b w x (w x v)`` with ``a = sin|w| / |w|``
    and ``b = (1 - cos|w|) / |w|^2``."""
    s = w.squaredNorm()
    small = s < SMALL_ANGLE2
    # The closed form sees 1 where the series is used, so that neither it
    # nor its derivatives divide by zero at w = 0.
    safe = select(small, 1.0, s)
    angle = safe.sqrt()
    a = select(small, 1.0 - s / 6.0 + s * s / 120.0, angle.sin() / angle)
    b = select(small, 0.5 - s / 24.0 + s * s / 720.0,
               (1.0 - angle.cos()) / safe)
    wv = w.cross(v)
    return v + a * wv + b * w.cross(wv)


def rotation_matrices(w: np.ndarray) -> np.ndarray:
    """``R(w)`` (K, 3, 3) of rotation vectors (K, 3), in NumPy (for tests
    and pictures)."""
    w = np.asarray(w, dtype=float).reshape(-1, 3)
    angle = np.linalg.norm(w, axis=1)
    k = w / np.where(angle > 0, angle, 1.0)[:, None]
    K = np.zeros((len(w), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -k[:, 2], k[:, 1], -k[:, 0]
    K -= K.transpose(0, 2, 1)
    sin, cos = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return np.eye(3) + sin * K + (1 - cos) * K @ K


def wrap_rotation_vectors(values: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3, 1) longer than pi replaced by the same
    rotation the other way round, ``w (1 - 2 pi / |w|)``: for
    ImplicitEuler's ``normalize``."""
    values = np.asarray(values, dtype=float)
    angle = np.linalg.norm(values, axis=-2, keepdims=True)
    factor = np.where(angle > np.pi,
                      1.0 - 2.0 * np.pi / np.where(angle > 0, angle, 1.0),
                      1.0)
    return values * factor


@dataclass
class RotationBody:
    """A rigid body of :func:`add_rotation_vector_body`."""
    #: the body's primitive (one instance) with the targets
    body: Primitive
    #: its vertices, with ``position`` (world, computed) and ``rest``
    vertices: Primitive
    #: the rotation vector and translation (3x1 each), the targets
    w: Attribute
    t: Attribute
    #: the world positions of the vertices
    positions: Attribute
    #: the world-space inertia, for ImplicitEuler's ``world=[...]``
    inertia: WorldInertia
    #: the centre of mass at rest (3,)
    centre: np.ndarray

    @property
    def targets(self):
        """``[w, t]``, in the order the scene's targets take them."""
        return [self.w, self.t]

    def world_velocity(self, angular=(0.0, 0.0, 0.0),
                       linear=(0.0, 0.0, 0.0)) -> np.ndarray:
        """The vertices' world velocities (N, 3) of a rigid motion with
        angular velocity ``angular`` (rad/s, world axes) about the centre
        of mass and velocity ``linear`` of the centre: for ImplicitEuler's
        ``world_velocities``."""
        x = self.positions.compute().value[:, :, 0]
        centre = self.centre + self.t.value[0, :, 0]
        return np.cross(np.asarray(angular, float), x - centre) + \
            np.asarray(linear, float)


def add_rotation_vector_body(mesh: Mesh, rest: np.ndarray, masses,
                             name: str = "v") -> RotationBody:
    """A rigid body of the vertices ``rest`` (N, 3) with ``masses`` (one
    per vertex, or one for all) on ``mesh``: a primitive ``body`` holding
    the rotation vector ``w`` and the translation ``t`` (both 0 at rest),
    and a primitive ``name`` of vertices whose ``position`` is ``R(w) (X -
    c) + c + t``, with its world inertia registered. Add
    ``body.targets`` to the scene's minimisation targets."""
    rest = np.asarray(rest, dtype=float).reshape(-1, 3)
    m = np.broadcast_to(np.asarray(masses, dtype=float).reshape(-1),
                        (len(rest),))
    if not (m > 0).all():
        raise SceneError("add_rotation_vector_body: masses must be > 0")
    centre = (m[:, None] * rest).sum(axis=0) / m.sum()
    body = mesh.addPrimitive("body", numInstances=1)
    w = body.addAttribute("w", rows=3)
    w.updateValue(np.zeros((1, 3, 1)))
    t = body.addAttribute("t", rows=3)
    t.updateValue(np.zeros((1, 3, 1)))
    vertices = mesh.addPrimitive(name, numInstances=len(rest))
    offset = vertices.addConstant("rest", rows=3)
    offset.updateValue((rest - centre)[:, :, None])
    link = vertices.addConnectivity("body", body,
                                    np.zeros((len(rest), 1), np.int64), 1)
    # Gathered through a one-vertex link: 1x3 rows, turned into columns.
    w_here = vertices.addAttribute("w", through=link, source=w).T
    t_here = vertices.addAttribute("t", through=link, source=t).T
    positions = vertices.addAttribute(
        "position",
        computed_attribute=rotate(w_here, offset) + centre.reshape(3, 1)
        + t_here)
    inertia = add_world_inertia(positions, m)
    return RotationBody(body, vertices, w, t, positions, inertia, centre)
