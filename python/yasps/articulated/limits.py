"""Joint limits that are never crossed: IPC's log barrier on the distance
to each limit, and a step bound that keeps every step inside them.

For a joint with coordinate ``q`` and a lower limit ``l``, the distance is
``d = q - l`` (``u - q`` for an upper one) and the energy

    s b(d),   b(d) = -(d - dhat)^2 ln(d / dhat) for d < dhat, else 0,

IPC's barrier (C2, convex, infinite at d = 0), on each joint's primitive
``joints<d>``. ``s`` is the joint's stiffness in the units of implicit
Euler's incremental potential (inertia ``m/2 |x - x_hat|^2`` beside dt^2
times the potentials); by default the joint's diagonal entry of the
joint-space mass matrix, so that a joint driven into its limit by a motion
of delta per step stops about ``dhat^2 / delta`` short of it. The barrier
alone would let a long step jump over it; the step bound lets no step go
further than 90% of the way to a limit, as IPC's CCD does for contact.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Sequence, Union

import numpy as np

from ..frontend.attribute import Attribute, select
from ..frontend.errors import SceneError
from ..frontend.scene import Scene
from ..sim.target_bounds import guard_target
from .build import ArticulatedBody
from .dynamics import mass_matrix

#: A limit far beyond any coordinate, for joints without one: its
#: distance never falls below dhat, so its barrier is 0.
UNBOUNDED = 1e9
#: The share of the way to a limit that one step may go.
STEP_SHARE = 0.9


def barrier(d: Attribute, dhat: Attribute) -> Attribute:
    """IPC's barrier ``-(d - dhat)^2 ln(d / dhat)`` below ``dhat``, 0 above
    (the logarithm's argument is 1 there, so neither branch is NaN)."""
    inside = d < dhat
    ratio = select(inside, d, dhat) / dhat
    return select(inside, -(d - dhat) * (d - dhat) * ratio.log(), 0.0)


def default_dhat(joint) -> float:
    """A hundredth of a radian or a millimetre, or a twentieth of the range
    where that is shorter."""
    dhat = 1e-3 if joint.kind == "prismatic" else 1e-2
    if joint.lower is not None and joint.upper is not None:
        dhat = min(dhat, 0.05 * (joint.upper - joint.lower))
    return dhat


@dataclass
class JointLimits:
    """The limits of an articulated body (:func:`add_joint_limits`)."""
    body: ArticulatedBody
    lower: np.ndarray      # (n,), -UNBOUNDED where a joint has none
    upper: np.ndarray      # (n,), UNBOUNDED where it has none
    dhat: np.ndarray       # (n,)
    stiffness: np.ndarray  # (n,)
    energies: List[Attribute]

    def distances(self) -> np.ndarray:
        """Each joint's distance to its nearer limit now (n,)."""
        q = self.body.joint_positions()
        return np.minimum(q - self.lower, self.upper - q)


def _step_bound(lower: np.ndarray, upper: np.ndarray):
    def bound(x: np.ndarray, p: np.ndarray) -> float:
        q, step = x.reshape(-1), p.reshape(-1)
        alpha = 1.0
        down, up = step < 0, step > 0
        if down.any():
            alpha = min(alpha, float((STEP_SHARE * (q - lower)[down]
                                      / -step[down]).min()))
        if up.any():
            alpha = min(alpha, float((STEP_SHARE * (upper - q)[up]
                                      / step[up]).min()))
        return max(alpha, 0.0)
    return bound


def add_joint_limits(scene: Scene, body: ArticulatedBody,
                     dhat: Optional[Union[float, Sequence[float]]] = None,
                     stiffness: Optional[Union[float, Sequence[float]]] = None
                     ) -> JointLimits:
    """Adds the barrier of every joint limit of ``body`` (a joint's
    ``lower``/``upper``) as an energy of its depth's primitive, and a step
    bound on its coordinates that every stepper of ``scene`` applies.
    ``dhat``: the distance below which a barrier acts (radians or metres;
    default :func:`default_dhat`); ``stiffness``: its scale (default the
    joint's diagonal entry of the joint-space mass matrix, which compiles
    the body's inertia kernels). The body's targets must be minimisation
    targets of ``scene``; every joint must start strictly inside its
    limits (SceneError otherwise)."""
    joints = body.joints
    n = len(joints)
    lower = np.array([-UNBOUNDED if j.lower is None else j.lower
                      for j in joints], dtype=float)
    upper = np.array([UNBOUNDED if j.upper is None else j.upper
                      for j in joints], dtype=float)
    q = body.joint_positions()
    outside = [j.name for j, v, lo, hi in zip(joints, q, lower, upper)
               if not lo < v < hi]
    if outside:
        raise SceneError(f"add_joint_limits: joints {outside} start on or "
                         f"outside their limits; set their coordinates "
                         f"inside (set_joint_positions) first")
    gaps = np.array([default_dhat(j) for j in joints]) if dhat is None \
        else np.broadcast_to(np.asarray(dhat, float), (n,)).copy()
    if not (gaps > 0).all():
        raise SceneError(f"add_joint_limits: dhat must be > 0, got {gaps}")
    if stiffness is None:
        offset = 6 if body.base_w is not None else 0
        scale = np.diag(mass_matrix(scene, body))[offset:offset + n].copy()
    else:
        scale = np.broadcast_to(np.asarray(stiffness, float), (n,)).copy()
    if not (scale > 0).all():
        raise SceneError(f"add_joint_limits: stiffness must be > 0, got "
                         f"{scale}")
    energies, start = [], 0
    for depth in body.depths[1:]:
        count = len(depth.bodies)
        part = slice(start, start + count)
        start += count
        limited = (lower[part] > -UNBOUNDED) | (upper[part] < UNBOUNDED)
        if not limited.any():
            continue
        frames, coordinate = depth.frames, depth.q
        assert coordinate is not None

        def stored(name: str, values: np.ndarray) -> Attribute:
            attr = frames.addConstant(name, rows=1)
            attr.updateValue(values.reshape(count, 1, 1))
            return attr

        lo, hi = stored("lower", lower[part]), stored("upper", upper[part])
        gap, kappa = stored("limit_dhat", gaps[part]), \
            stored("limit_stiffness", scale[part])
        energy = frames.addAttribute("joint_limits", computed_attribute=kappa * (
            barrier(coordinate - lo, gap) + barrier(hi - coordinate, gap)))
        scene.addEnergy(energy)
        energies.append(energy)
        guard_target(coordinate, _step_bound(lower[part], upper[part]))
    return JointLimits(body, lower, upper, gaps, scale, energies)
