"""A step bound that keeps tets from inverting, for materials whose energy
has a barrier at J = 0 (IPC's Neo-Hookean: ``energies.neo_hookean``).

Such an energy is undefined past J = 0, so Newton's line search already
rejects a step that ends with a tet inverted; but a step may pass through
an inversion and out again, and moves that no energy checks (a warm start,
prescribed motion) may end inverted. IPC bounds every step so that no
tet's volume falls below a fraction of what it was, as its CCD does for
distances. Along a straight step x + a p, a tet's signed volume is the
cubic det(D + a P) in a (D, P its edge matrices of x and of p); the bound
is the first a where some tet's cubic falls to KEEP of its value at 0.

Materials say whether they need it: ``add_elastic_tets`` registers the
tets of such a material with :func:`guard_inversion`, and every stepper
whose targets include their positions bounds its steps by them
(:func:`guarded_step_bound`) without being told.

The other materials (stable Neo-Hookean, fixed corotated) are defined past
J = 0 and let a tet invert where a step is too large for their stiffness
(a soft body hit at speed, a heavy body on a soft one). Asked to guard them
(``add_elastic_tets(..., guard_inversion=True)``), ``add_elastic_tets``
adds :func:`yasps.energies.inversion_barrier` to their energy besides the
step bound: the bound alone cannot stop a move no energy checks (a
prescribed motion) and, where Newton's directions keep pressing a tet the
material lets collapse, cuts every step to nothing. ``add_elastic_tets``
registers every material's tets with :func:`watch_inversion`, and
``ImplicitEuler`` counts the inverted ones after each step
(:func:`count_inverted`): the report's ``inverted_tets``, and an
:class:`ElementsInverted` warning naming the primitive and what to change.
"""

from __future__ import annotations

from typing import Any, Callable, List, Optional, Sequence, Tuple, Union, cast

import numpy as np

from ..frontend.state import StateKey
from .target_bounds import target_bounds

#: The fraction of its volume a tet keeps over one step (IPC's CCD keeps a
#: tenth of a distance likewise).
KEEP = 0.1

#: Samples of the step at which the cubics are compared before bisection.
SAMPLES = 64


def _cubics(x: np.ndarray, p: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Per tet the coefficients (c0, c1, c2, c3) of det(D + a P)."""
    def edges(v: np.ndarray):
        corners = v[tets]
        return [corners[:, k] - corners[:, 0] for k in (1, 2, 3)]

    a, b, c = edges(x)
    q, r, s = edges(p)

    def det(u, v, w):
        return np.einsum("ij,ij->i", u, np.cross(v, w))

    return np.stack([det(a, b, c),
                     det(q, b, c) + det(a, r, c) + det(a, b, s),
                     det(a, r, s) + det(q, b, s) + det(q, r, c),
                     det(q, r, s)], axis=1)


def _value(cubics: np.ndarray, alpha) -> np.ndarray:
    c0, c1, c2, c3 = cubics.T
    return c0 + alpha * (c1 + alpha * (c2 + alpha * c3))


def inversion_free_fraction(x: np.ndarray, p: np.ndarray,
                            tets: np.ndarray, keep: float = KEEP) -> float:
    """The largest fraction a <= 1 of the step ``p`` from positions ``x``
    (both (N, 3)) along which every tet keeps ``keep`` of its signed volume
    at x (tets with a volume <= 0 at x are left out)."""
    cubics = _cubics(np.asarray(x, float).reshape(-1, 3),
                     np.asarray(p, float).reshape(-1, 3), tets)
    start = cubics[:, 0]
    cubics = cubics[start > 0]
    if not len(cubics):
        return 1.0
    floor = keep * cubics[:, 0]
    grid = np.linspace(0.0, 1.0, SAMPLES + 1)
    c0, c1, c2, c3 = (c[:, None] for c in cubics.T)
    below = c0 + grid * (c1 + grid * (c2 + grid * c3)) <= floor[:, None]
    hit = below.any(axis=1)
    if not hit.any():
        return 1.0
    # The first sample at or below the floor, then bisection between it and
    # the sample before (which is above).
    first = below[hit].argmax(axis=1)
    lo, hi = grid[first - 1], grid[first]
    cubics, floor = cubics[hit], floor[hit]
    for _ in range(40):
        middle = 0.5 * (lo + hi)
        fell = _value(cubics, middle) <= floor
        hi = np.where(fell, middle, hi)
        lo = np.where(fell, lo, middle)
    return float(lo.min())


def inversion_bound(tets: np.ndarray, target: int = 0,
                    keep: float = KEEP) -> Callable:
    """A ``step_bound`` for :class:`yasps.sim.ImplicitEuler` and
    :func:`yasps.sim.newton` whose target ``target`` (free vertices, (N, 3)
    values) carries ``tets``: the fraction of a step along which no tet
    falls below ``keep`` of its volume, as IPC bounds its steps for its
    Neo-Hookean. Sampled at 64 points and bisected: a cubic that dips
    below and back between two samples is missed, which the energy's own
    barrier (NaN past J = 0) then catches in the line search."""
    tets = np.asarray(tets, dtype=np.int64).reshape(-1, 4)

    def bound(x: Union[np.ndarray, Sequence[np.ndarray]],
              p: Union[np.ndarray, Sequence[np.ndarray]]) -> float:
        if isinstance(x, (list, tuple)):
            x, p = x[target], p[target]
        # One target's values now (a list or tuple holds one per target).
        return inversion_free_fraction(cast(np.ndarray, x), cast(np.ndarray, p),
                                       tets, keep)

    return bound


def combined_bound(*bounds: Callable) -> Callable:
    """The least of several step bounds."""
    def bound(x, p) -> float:
        return min(b(x, p) for b in bounds)
    return bound


#: Per scene, the (positions, tets) whose steps must not invert a tet.
_GUARDS: StateKey[List[Tuple[object, np.ndarray]]] = StateKey(
    "the tets whose steps must not invert, and their positions")


def guard_inversion(positions, tets: np.ndarray) -> None:
    """Registers ``tets`` over the vertices whose world positions are
    ``positions`` (an attribute of a primitive): steppers of the scene
    whose targets include ``positions`` bound every step by
    :func:`inversion_bound` of them."""
    scene = positions.owner.scene
    scene.state.setdefault(_GUARDS, list).append(
        (positions, np.asarray(tets, dtype=np.int64).reshape(-1, 4)))


class ElementsInverted(UserWarning):
    """A step ended with tets inverted (signed volume at most 0) under a
    material that allows it: the body passed through itself there."""


#: Per scene, every tet set added by add_elastic_tets: (positions, tets,
#: the primitive's description, the material).
_WATCHED: StateKey[List[Tuple[object, np.ndarray, str, str]]] = StateKey(
    "the tets whose inversion steppers report")


def watch_inversion(positions, tets: np.ndarray, primitive: str,
                    material: str) -> None:
    """Registers ``tets`` over the vertices whose world positions are
    ``positions`` (of ``material``, on the primitive described by
    ``primitive``): steppers whose targets include ``positions`` count
    the inverted ones after each step."""
    scene = positions.owner.scene
    scene.state.setdefault(_WATCHED, list).append(
        (positions, np.asarray(tets, dtype=np.int64).reshape(-1, 4),
         primitive, material))


def signed_volumes(x: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Six times each tet's signed volume at positions ``x`` (N, 3)."""
    corners = x[tets]
    a, b, c = (corners[:, k] - corners[:, 0] for k in (1, 2, 3))
    return np.einsum("ij,ij->i", np.cross(a, b), c)


def count_inverted(scene, targets: Sequence) -> List[Tuple[int, str, str]]:
    """Per watched tet set whose positions are one of ``targets``: the
    number of tets inverted now, the primitive and the material (sets with
    none left out)."""
    found = []
    for positions, tets, primitive, material in \
            scene.state.get(_WATCHED) or ():
        if any(target is positions for target in targets):
            x = np.asarray(cast(Any, positions).value).reshape(-1, 3)
            count = int((signed_volumes(x, tets) <= 0.0).sum())
            if count:
                found.append((count, primitive, material))
    return found


def inverted_text(found: Sequence[Tuple[int, str, str]], where: str) -> str:
    """The ElementsInverted warning's text for ``count_inverted``'s
    result."""
    parts = ", ".join(f"{count} tets of {primitive} ({material})"
                      for count, primitive, material in found)
    return (f"{where}: {parts} inverted (signed volume <= 0): the step was "
            f"too large for the material's stiffness (a fast impact, a heavy "
            f"body on a soft one). Lower dt or raise the stiffness; or use "
            f"material='neo_hookean' (IPC's, whose energy and step bound "
            f"keep every tet from inverting) or guard_inversion=True. "
            f"NewtonReport.inverted_tets counts them per step (warned once)")


def guarded_step_bound(scene, targets: Sequence,
                       step_bound: Optional[Callable] = None
                       ) -> Optional[Callable]:
    """``step_bound`` (None for none) combined with the inversion bounds
    that :func:`guard_inversion` registered on ``scene`` for any of
    ``targets`` and the targets' own bounds
    (:func:`yasps.sim.target_bounds.guard_target`); None when there is
    none."""
    bounds = [] if step_bound is None else [step_bound]
    for positions, tets in scene.state.get(_GUARDS) or ():
        for index, target in enumerate(targets):
            if target is positions:
                bounds.append(inversion_bound(tets, target=index))
    bounds += target_bounds(scene, targets)
    if not bounds:
        return None
    return bounds[0] if len(bounds) == 1 else combined_bound(*bounds)
