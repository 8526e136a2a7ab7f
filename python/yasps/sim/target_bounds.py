"""Step bounds that belong to a target: registered once on the scene, and
applied by every stepper (and :func:`yasps.sim.newton`) whose targets
include it, the way a tet mesh's inversion guard is. A bound is
``bound(x, p) -> fraction``: the largest fraction of the step ``p`` from
the target's values ``x`` (both shaped like its value) that keeps what it
guards (a joint inside its limits)."""

from __future__ import annotations

from typing import Callable, List, Sequence, Tuple

import numpy as np

from ..frontend.state import StateKey

Bound = Callable[[np.ndarray, np.ndarray], float]

_BOUNDS: StateKey[List[Tuple[object, Bound]]] = StateKey(
    "step bounds registered for one target each")


def guard_target(target, bound: Bound) -> None:
    """Registers ``bound`` for steps of ``target`` (a stored attribute)."""
    scene = target.owner.scene
    scene.state.setdefault(_BOUNDS, list).append((target, bound))


def target_bounds(scene, targets: Sequence) -> List[Callable]:
    """The registered bounds of ``targets``, each as a step bound over all
    of them (``bound(x, p)`` with one array per target, or the arrays
    themselves where there is one target)."""
    out = []
    for guarded, bound in scene.state.get(_BOUNDS) or ():
        for index, target in enumerate(targets):
            if target is guarded:
                out.append(_of_target(bound, index))
    return out


def _of_target(bound: Bound, index: int) -> Callable:
    def of_all(x, p) -> float:
        if isinstance(x, (list, tuple)):
            x, p = x[index], p[index]
        return bound(np.asarray(x), np.asarray(p))
    return of_all
