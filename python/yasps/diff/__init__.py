"""Gradients of a simulation's outcome with respect to its inputs.

The static case: after a converged solve of min_x E(x; theta),
:func:`equilibrium_gradient` gives dL/dtheta for a loss L(x*) from dL/dx*,
by one linear solve with the exact Hessian and the compiler's mixed
derivatives d(grad_x E)/dtheta (yasps.solve.adjoint; docs/diff.md)::

    yasps.sim.newton(s, [x], 1e-10, fixed=[pinned])
    grads = yasps.diff.equilibrium_gradient(
        s, dloss={x: dL_dx}, parameters=[cloth["cloth_stretch"]],
        fixed=[pinned])
    grads[cloth["cloth_stretch"]]          # shaped like its value

Any stored attribute that is not a target may be a parameter: materials
(the sim helpers store them as constants), per-element rest-shape
constants, masses, predictions.
"""

from __future__ import annotations

from typing import Mapping, Optional, Sequence, Tuple

import numpy as np

from .. import runtime
from ..frontend.attribute import Attribute
from ..sim.bodies import lame
from ..frontend.scene import Scene
from ..solve.adjoint import AdjointWarning, Gradients
from ..solve.adjoint import equilibrium_gradient as _equilibrium_gradient
from .rest import cloth_rest_gradient, tet_rest_gradient

__all__ = ["AdjointWarning", "Gradients", "cloth_rest_gradient",
           "equilibrium_gradient", "tet_rest_gradient",
           "young_poisson_gradient"]


def equilibrium_gradient(scene: Scene, dloss: Mapping[Attribute, object],
                         parameters: Sequence[Attribute], fixed=None,
                         tolerance: float = 1e-6,
                         threads: Optional[int] = None,
                         hessian: str = "exact") -> Gradients:
    """dL/dtheta at the minimiser the scene holds, for each of
    ``parameters``, given ``dloss`` (dL/dx* per target, each shaped like the
    target's value; targets left out contribute nothing). ``fixed`` is
    minimizeEnergy's and newton's (one mask or None per target): those DoFs
    do not move with the parameters. The Hessian is the exact one (never
    projected), solved directly on the free DoFs; warns with
    AdjointWarning when the free gradient's largest entry exceeds
    ``tolerance`` (the adjoint holds at a minimiser only). Returns a
    :class:`Gradients`: parameter -> array shaped like its value.
    ``hessian="projected"`` solves with each instance's block
    PSD-projected instead: another, approximate gradient, for measuring
    what projection would cost."""
    return _equilibrium_gradient(scene, dloss, parameters, runtime.current(),
                                 fixed=fixed, threads=threads,
                                 tolerance=tolerance, hessian=hessian)


def young_poisson_gradient(young: float, poisson: float, d_mu, d_lam
                           ) -> Tuple[float, float]:
    """dL/dE and dL/dnu from dL/dmu and dL/dlambda (the gradients of the
    Lame constants that :func:`yasps.sim.lame` makes of Young's modulus E
    and Poisson's ratio nu; arrays of one entry, as Gradients gives them,
    or numbers), by the chain rule through ``lame``."""
    lame(young, poisson)                  # refuses what lame refuses
    d_mu, d_lam = float(np.sum(d_mu)), float(np.sum(d_lam))
    a, b = 1.0 + poisson, 1.0 - 2.0 * poisson
    d_young = d_mu / (2.0 * a) + d_lam * poisson / (a * b)
    d_poisson = (-d_mu * young / (2.0 * a * a) +
                 d_lam * young * (1.0 + 2.0 * poisson ** 2) / (a * a * b * b))
    return d_young, d_poisson
