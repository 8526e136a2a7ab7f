"""Velocities of bodies in the terms users think in, and the motion they
carry: an affine body's A and t rates from an angular and a linear
velocity, and back; kinetic energy, momentum and angular momentum of an
affine body or of a set of free vertices.

An affine body moves its vertices as x_i = A r_i + t (r_i at rest), so
their velocities are v_i = dA r_i + dt. A rigid motion with angular
velocity w (world frame) and velocity v_c of a point c is v(x) = v_c + w x
(x - c), that is dA = [w]x A and dt = v_c + w x (t - c).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence, Tuple

import numpy as np

from .bodies import AffineBody
from ..frontend.errors import ArgumentError


@dataclass
class Motion:
    """What a body's velocities carry. ``center``: its centre of mass;
    ``linear``: the velocity of that centre; ``angular``: the angular
    velocity (world frame; for an affine body the rotation part of dA
    A^-1, None for a set of free vertices); ``kinetic_energy``,
    ``momentum`` and ``angular_momentum`` (about the centre of mass) from
    the vertices' masses and velocities."""
    mass: float
    center: np.ndarray
    linear: np.ndarray
    angular: Optional[np.ndarray]
    kinetic_energy: float
    momentum: np.ndarray
    angular_momentum: np.ndarray


def _cross_matrix(w: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]],
                     [-w[1], w[0], 0.0]])


def _body_state(body: AffineBody) -> Tuple[np.ndarray, np.ndarray,
                                           np.ndarray, np.ndarray]:
    """A (3, 3), t (3,), rest (N, 3) and masses (N,) of an affine body."""
    A = np.asarray(body.A.value, dtype=float).reshape(3, 3)
    t = np.asarray(body.t.value, dtype=float).reshape(3)
    rest = np.asarray(body.vertices["rest"].value, dtype=float).reshape(-1, 3)
    masses = np.asarray(body.vertices["mass"].value,
                        dtype=float).reshape(-1)
    return A, t, rest, masses


def affine_velocity(body: AffineBody, angular: Sequence[float] = (0, 0, 0),
                    linear: Sequence[float] = (0, 0, 0),
                    about: Optional[Sequence[float]] = None
                    ) -> Tuple[np.ndarray, np.ndarray]:
    """The rates (dA (1, 3, 3), dt (1, 3, 1)) of an affine body, at its
    current A and t, that move it rigidly with angular velocity
    ``angular`` (rad/s, world frame) and its point ``about`` (default: its
    centre of mass) at velocity ``linear``: ImplicitEuler's ``velocities``
    entries for the body's A and t."""
    A, t, rest, masses = _body_state(body)
    w = np.asarray(angular, dtype=float).reshape(3)
    center = A @ (masses @ rest / masses.sum()) + t if about is None \
        else np.asarray(about, dtype=float).reshape(3)
    A_dot = _cross_matrix(w) @ A
    t_dot = np.asarray(linear, dtype=float).reshape(3) + np.cross(w, t - center)
    return A_dot.reshape(1, 3, 3), t_dot.reshape(1, 3, 1)


def vertex_motion(masses: np.ndarray, positions: np.ndarray,
                  velocities: np.ndarray) -> Motion:
    """The motion of vertices of ``masses`` (N,) at ``positions`` (N, 3)
    moving at ``velocities`` (N, 3)."""
    m = np.asarray(masses, dtype=float).reshape(-1)
    x = np.asarray(positions, dtype=float).reshape(-1, 3)
    v = np.asarray(velocities, dtype=float).reshape(-1, 3)
    if not len(m) == len(x) == len(v):
        raise ArgumentError(f"vertex_motion: {len(m)} masses, {len(x)} "
                            f"positions and {len(v)} velocities")
    total = float(m.sum())
    center = m @ x / total
    linear = m @ v / total
    momentum = m @ v
    angular_momentum = m @ np.cross(x - center, v - linear)
    return Motion(total, center, linear, None,
                  float(0.5 * np.sum(m * np.sum(v * v, axis=1))), momentum,
                  angular_momentum)


def affine_motion(body: AffineBody, A_dot: np.ndarray,
                  t_dot: np.ndarray) -> Motion:
    """The motion of an affine body at its current A and t with rates
    ``A_dot`` and ``t_dot`` (as ImplicitEuler's ``velocities`` hold them):
    its vertices' kinetic energy, momentum and angular momentum, the
    velocity of its centre of mass and its angular velocity (the
    skew-symmetric part of dA A^-1)."""
    A, t, rest, masses = _body_state(body)
    A_dot = np.asarray(A_dot, dtype=float).reshape(3, 3)
    t_dot = np.asarray(t_dot, dtype=float).reshape(3)
    motion = vertex_motion(masses, rest @ A.T + t, rest @ A_dot.T + t_dot)
    W = A_dot @ np.linalg.inv(A)
    motion.angular = 0.5 * np.array([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0],
                                     W[1, 0] - W[0, 1]])
    return motion
