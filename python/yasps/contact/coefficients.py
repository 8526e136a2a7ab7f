"""Friction coefficients per pair of bodies, and per half-space.

IPC's scenes give each pair of materials its own coefficient (a cloth on
the ground slides, the same cloth on a box grips). A contact's bodies are
the members of its vertex UNION (one body for a single primitive); its
half-spaces are obstacles of their own. ipctk builds the tangential set
with the largest coefficient in play; each lagged pair's weight ``mu N``
is then scaled to its own bodies' coefficient, and pairs whose coefficient
is 0 are left out.
"""

from __future__ import annotations

from typing import Dict, FrozenSet, Mapping, Optional, Tuple, Union

import numpy as np

from ..frontend.errors import SceneError
from ..frontend.scene import Primitive, PrimitiveUnion
from .friction import FrictionPairs
from ..frontend.errors import ArgumentError

#: A side of a pair: a member primitive of the contact's UNION, or the
#: index of a half-space (an int, in the order given to Contact).
Side = Union[Primitive, PrimitiveUnion, int]


class FrictionCoefficients:
    """The coefficient of every pair of bodies: ``pairs`` maps a pair of
    sides (``(member_a, member_b)``, or ``(member, k)`` for half-space
    ``k``; a member with itself for its self-contact) to its coefficient,
    and every other pair takes ``default``."""

    def __init__(self, vertices, default: float,
                 pairs: Optional[Mapping[Tuple[Side, Side], float]],
                 planes: int):
        self.default = float(default)
        members = vertices.members if isinstance(vertices, PrimitiveUnion) \
            else [vertices]
        counts = [m.numInstances for m in members]
        #: the body (member index) of each vertex
        self.body_of = np.repeat(np.arange(len(members)), counts)
        self.by_pair: Dict[FrozenSet[int], float] = {}
        for (a, b), mu in (pairs or {}).items():
            if not float(mu) >= 0:
                raise ArgumentError(f"Contact: friction coefficients must be "
                                    f">= 0, got {mu} for a pair")
            key = frozenset((_side(a, members, planes),
                             _side(b, members, planes)))
            self.by_pair[key] = float(mu)

    @property
    def largest(self) -> float:
        """The largest coefficient of any pair (what ipctk builds with)."""
        return max([self.default] + list(self.by_pair.values()))

    def coefficient(self, a: int, b: int) -> float:
        """The coefficient between bodies (or half-spaces, as -1 - k) a, b."""
        return self.by_pair.get(frozenset((a, b)), self.default)

    def apply(self, pairs: Dict[int, FrictionPairs],
              planes: np.ndarray) -> None:
        """Scales each pair's ``mu N`` from the largest coefficient (built
        with) to its own, and drops pairs whose coefficient is 0. A pair's
        sides are its first and last vertex (vertex, edge or triangle
        stencils put one side first, the other last); the pairs of arity
        1 are vertex-half-space pairs, of the half-spaces ``planes``."""
        if not self.by_pair:
            return
        built = self.largest
        for arity, found in pairs.items():
            factors = []
            for k, ids in enumerate(found.vertices):
                a = int(self.body_of[ids[0]])
                b = -1 - int(planes[k]) if arity == 1 else \
                    int(self.body_of[ids[-1]])
                factors.append(self.coefficient(a, b) / built)
            keep = [k for k, f in enumerate(factors) if f > 0]
            for name in ("vertices", "coef", "basis", "lagged", "scale"):
                values = getattr(found, name)
                setattr(found, name, [values[k] for k in keep])
            found.scale = [s * factors[k] for s, k in zip(found.scale, keep)]


def _side(side: Side, members, planes: int) -> int:
    """A side's body index (a member), or -1 - k for half-space k."""
    if isinstance(side, (int, np.integer)) and not isinstance(side, bool):
        if not 0 <= side < planes:
            raise SceneError(f"Contact: friction pair names half-space "
                             f"{side}; there are {planes}")
        return -1 - int(side)
    for j, member in enumerate(members):
        if member is side:
            return j
    names = ", ".join(m.describe() for m in members)
    raise SceneError(f"Contact: a friction pair names {side!r}, which is "
                     f"not a member of the contact's vertices ({names}) "
                     f"nor a half-space index")
