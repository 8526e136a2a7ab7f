"""Point masses with a rigid link's exact inertia.

A rigid body's kinetic energy depends on its mass distribution only through
the mass, the centre of mass and the second moments ``S = sum m r r^T``
about it (``S = tr(I) / 2 E - I`` for the inertia tensor ``I``). Six points
of mass ``m / 6`` at ``c +- s_k e_k``, with ``e_k`` the eigenvectors of S
and ``s_k = sqrt(3 lambda_k / m)``, have all three: their world inertia
(implicit Euler's ``m/2 |x - x_hat|^2`` on each) gives the link's
joint-space mass matrix exactly, with no inertia written in joint space.
"""

from __future__ import annotations

from typing import Tuple

import numpy as np

from ..frontend.errors import SceneError


def inertia_points(mass: float, com, inertia,
                   name: str = "link") -> Tuple[np.ndarray, np.ndarray]:
    """Six points (6, 3) in the link's frame and their masses (6,) that have
    ``mass``, the centre of mass ``com`` and the inertia tensor ``inertia``
    (3x3 about the centre of mass, in the link's frame); none for a link
    without mass. Raises SceneError for a tensor no body can have
    (not symmetric, or breaking the triangle inequality)."""
    if mass == 0:
        return np.zeros((0, 3)), np.zeros(0)
    inertia = np.asarray(inertia, dtype=float).reshape(3, 3)
    scale = max(np.abs(inertia).max(), 1e-300)
    if not np.allclose(inertia, inertia.T, atol=1e-12 * scale):
        raise SceneError(f"link {name!r}: its inertia tensor is not "
                         f"symmetric:\n{inertia}")
    second = 0.5 * np.trace(inertia) * np.eye(3) - inertia
    moments, axes = np.linalg.eigh(0.5 * (second + second.T))
    if moments.min() < -1e-9 * scale:
        raise SceneError(f"link {name!r}: its inertia tensor breaks the "
                         f"triangle inequality (principal moments "
                         f"{np.linalg.eigvalsh(inertia)}): no body has it")
    spread = np.sqrt(3.0 * np.clip(moments, 0.0, None) / mass)
    offsets = (axes * spread).T  # row k: s_k e_k
    points = np.asarray(com, dtype=float).reshape(1, 3) + \
        np.concatenate([offsets, -offsets])
    return points, np.full(6, mass / 6.0)
