"""Prescribed motion: target entries that follow a function of time
(pins that move, a motor turning an affine body, a scripted obstacle)
inside an implicit-Euler step.

Before each step the prescribed entries move to their values at the step's
end, ``fn(t + dt)``, as far as the contact's CCD (and the stepper's
``step_bound``) lets them without crossing a surface: where it stops them
short (another body in the way, as IPC's kinematic boundary conditions can
be), they move 0.9 of the safe fraction and the rest is left for the next
steps, the lag reported. Newton then keeps them fixed, so the barrier and
friction push the free bodies out of their way.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, List, Optional, Sequence, TypeVar

import numpy as np

from ..frontend.attribute import Attribute, owner_of
from ..frontend.errors import SceneError
from ..solve.minimize import checked_fixed_mask

#: The fraction of CCD's safe step a cut prescribed motion takes (as IPC's
#: line search backs off its CCD bound).
CUT_FRACTION = 0.9


#: How many penalty solves a step may take to bring its prescribed
#: entries to their values, each with a hundredfold stiffer penalty.
PULL_ROUNDS = 4
#: The largest distance from their values at which pulled entries are then
#: moved the rest of the way, relative to the distance they were short.
PULL_TOLERANCE = 1e-3


@dataclass
class Pull:
    """The penalty ``sum w (q - q*)^2 / 2`` on a target's entries, off
    (``w`` = 0) except while a step pulls its prescribed entries: stored
    values ``q*`` (``target``) and ``w`` (``weight``) beside the target,
    so switching it compiles nothing."""
    target: Attribute
    weight: Attribute

    def set(self, wanted: np.ndarray, mask: np.ndarray, k: float) -> None:
        self.target.updateValue(wanted)
        self.weight.updateValue(np.where(mask, k, 0.0))

    def off(self) -> None:
        self.weight.updateValue(np.zeros(self.weight.value.shape))


def add_pull(target: Attribute, index: int) -> Pull:
    """Registers the :class:`Pull` penalty of prescription ``index`` on
    ``target``'s primitive (off until a step needs it)."""
    owner = owner_of(target)  # a target: a data attribute
    rows, cols = target.shape
    wanted = owner.addConstant(f"prescribed{index}_value", rows=rows,
                               cols=cols)
    wanted.updateValue(target.value)
    weight = owner.addConstant(f"prescribed{index}_weight", rows=rows,
                               cols=cols)
    weight.updateValue(np.zeros(target.value.shape))
    gap = target - wanted
    owner.scene.addEnergy(owner.addAttribute(
        f"prescribed{index}_pull",
        computed_attribute=0.5 * weight.cwiseProduct(gap.cwiseProduct(gap))
        .sum()))
    return Pull(wanted, weight)


@dataclass
class Prescription:
    """Entries of target ``index`` (``mask`` over its value's entries) that
    take ``fn(time)`` (their values, in the order of the masked entries),
    with the penalty that pulls them there where CCD stops them."""
    index: int
    fn: Callable[[float], np.ndarray]
    mask: np.ndarray
    pull: Optional[Pull] = None


def prescription(targets: Sequence[Attribute], target: Attribute,
                 fn: Callable[[float], np.ndarray],
                 mask=None) -> Prescription:
    """A checked :class:`Prescription` of ``target`` (one of ``targets``);
    ``mask`` as ImplicitEuler's fixed masks (instances or entries; None:
    every entry)."""
    for index, t in enumerate(targets):
        if t is target:
            break
    else:
        raise SceneError(f"prescribe: {target.describe()} is not one of the "
                         f"stepper's targets")
    if not callable(fn):
        raise SceneError(f"prescribe: fn must be a function of time, got "
                         f"{fn!r}")
    entries = np.ones(target.value.shape, dtype=bool) if mask is None \
        else entry_mask(target, mask, "prescribe")
    if not entries.any():
        raise SceneError(f"prescribe: the mask of {target.describe()} holds "
                         f"no entry")
    return Prescription(index, fn, entries)


def entry_mask(target: Attribute, mask, where: str) -> np.ndarray:
    """A fixed mask (of instances or of entries) as one over the target's
    value's entries (N, rows, cols)."""
    given = checked_fixed_mask(target, mask, where)
    if given.ndim == 1:
        given = np.broadcast_to(given[:, None, None], target.value.shape)
    return given.copy()


def wanted_values(p: Prescription, value: np.ndarray,
                  time: float) -> np.ndarray:
    """The target's value with the prescribed entries at ``fn(time)``."""
    given = np.asarray(p.fn(time), dtype=float)
    count = int(p.mask.sum())
    if given.size != count:
        raise SceneError(f"prescribe: fn({time:g}) gave {given.size} values "
                         f"for {count} prescribed entries")
    if not np.isfinite(given).all():
        raise SceneError(f"prescribe: fn({time:g}) gave a value that is not "
                         f"finite")
    out = value.copy()
    out[p.mask] = given.reshape(-1)
    return out


def move_prescribed(prescriptions: List[Prescription],
                    targets: Sequence[Attribute], time: float,
                    bound: Callable[[List[np.ndarray]], float]) -> float:
    """Moves the prescribed entries towards their values at ``time`` as far
    as ``bound(steps)`` (the safe fraction of a motion, one step per
    target) allows; returns the largest distance an entry is left short."""
    if not prescriptions:
        return 0.0
    values = [t.value for t in targets]
    steps = [np.zeros_like(v) for v in values]
    for p in prescriptions:
        wanted = wanted_values(p, values[p.index], time)
        steps[p.index][p.mask] = (wanted - values[p.index])[p.mask]
    if not any(s.any() for s in steps):
        return 0.0
    safe = bound(steps)
    fraction = 1.0 if safe >= 1.0 else CUT_FRACTION * safe
    for t, value, step in zip(targets, values, steps):
        if step.any():
            t.updateValue(value + fraction * step)
    return float(max(np.abs(s).max() for s in steps) * (1.0 - fraction))


def curvature(scene, targets: Sequence[Attribute],
              steps: List[np.ndarray]) -> float:
    """The scene energy's second derivative along the motion ``steps`` (one
    per target), per squared unit of its largest entry, by a second
    difference at a thousandth of the motion (the scale of a pull)."""
    values = [t.value for t in targets]
    h = 1e-3

    def energy(fraction: float) -> float:
        for t, value, step in zip(targets, values, steps):
            t.updateValue(value + fraction * step)
        return scene.evaluateEnergy()

    try:
        e0, e1, e2 = energy(0.0), energy(h), energy(2 * h)
    finally:
        for t, value in zip(targets, values):
            t.updateValue(value)
    size = max(float(np.abs(s).max()) for s in steps)
    return abs(e2 - 2 * e1 + e0) / (h * size) ** 2


#: What a penalty solve of :func:`pull_prescribed` returns (its report).
_Report = TypeVar("_Report")


def pull_prescribed(prescriptions: List[Prescription], targets, time: float,
                    solve: Callable[[], _Report], scene) -> List[_Report]:
    """Brings prescribed entries that CCD stopped short towards their
    values at ``time`` by the penalty solves ``solve()`` (Newton with them
    free); returns the solves' reports."""
    values = [t.value for t in targets]
    steps = [np.zeros_like(v) for v in values]
    wanted = {}
    for p in prescriptions:
        wanted[id(p)] = wanted_values(p, values[p.index], time)
        steps[p.index][p.mask] = (wanted[id(p)] - values[p.index])[p.mask]
    short = max(float(np.abs(s).max()) for s in steps)
    if short == 0.0:
        return []
    bend = curvature(scene, targets, steps)
    if not np.isfinite(bend):
        # The energy is undefined a little along the missing motion (a
        # material's barrier: a tet would invert): no pull can get there.
        return []
    k = 100.0 * max(bend, 1e-300)
    reports: List[_Report] = []
    try:
        for _ in range(PULL_ROUNDS):
            if not np.isfinite(k):
                break
            for p in prescriptions:
                assert p.pull is not None  # prescribe() gave each its pull
                p.pull.set(wanted[id(p)], p.mask, k)
            reports.append(solve())
            left = max(float(np.abs((targets[p.index].value
                                     - wanted[id(p)])[p.mask]).max())
                       for p in prescriptions)
            if left <= PULL_TOLERANCE * short:
                break
            k *= 100.0
    finally:
        for p in prescriptions:
            assert p.pull is not None  # as above
            p.pull.off()
    return reports


def fixed_with_prescribed(fixed: Sequence[Optional[np.ndarray]],
                          prescriptions: List[Prescription],
                          targets: Sequence[Attribute]
                          ) -> Optional[List[Optional[np.ndarray]]]:
    """Newton's fixed masks: the stepper's, with every prescribed entry
    added (entry masks where a target has prescriptions); None if none."""
    out: List[Optional[np.ndarray]] = list(fixed)
    for p in prescriptions:
        target = targets[p.index]
        current = out[p.index]
        base = np.zeros(target.value.shape, dtype=bool) if current is None \
            else entry_mask(target, current, "ImplicitEuler")
        out[p.index] = base | p.mask
    return None if all(m is None for m in out) else out
