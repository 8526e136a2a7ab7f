"""Lengths relative to a scene's size, as IPC's scene files give them.

IPC states ``dhat``, the friction threshold ``eps_v`` and Newton's
tolerance as fractions of the bounding box's diagonal, so that one scene
file works at any scale. ``Relative(fraction)`` says so where yasps takes
a length (Contact's ``dhat`` and ``eps_v``, ImplicitEuler's
``velocity_tolerance``): the fraction of the diagonal of the contact's
vertices' bounding box at construction.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Union

import numpy as np
from ..frontend.errors import ArgumentError


@dataclass(frozen=True)
class Relative:
    """A fraction of the scene's size (its bounding box's diagonal)."""
    fraction: float

    def __post_init__(self):
        if not float(self.fraction) > 0:
            raise ArgumentError(f"Relative: the fraction must be > 0, got "
                                f"{self.fraction}")


#: A length in the scene's units, or relative to its size.
Length = Union[float, Relative]


def diagonal(V: np.ndarray) -> float:
    """The diagonal of the bounding box of positions V (N, 3)."""
    V = np.asarray(V, dtype=float).reshape(-1, 3)
    return float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) \
        if len(V) else 0.0


def resolve(value: Length, size: float) -> float:
    """``value`` as a number: a fraction of ``size`` if Relative."""
    if isinstance(value, Relative):
        return float(value.fraction) * size
    return float(value)
