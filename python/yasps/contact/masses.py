"""The vertices' masses a contact's adaptive stiffness reads, found in the
scene itself.

IPC's adaptive barrier stiffness (ipctk's ``initial_barrier_stiffness``)
scales its smallest stiffness by the average vertex mass, which IPC takes
from its mass matrix. yasps' bodies keep their vertices' masses as a 1x1
stored attribute ``mass`` on their vertex primitive (``add_free_vertices``
and ``add_affine_body`` record it), so a contact over those primitives, or
a UNION of them, finds the average without being told."""

from __future__ import annotations

from typing import List, Optional, Union

import numpy as np

from ..frontend.attribute import STORED_KINDS
from ..frontend.errors import ValueUpdateError
from ..frontend.scene import Primitive, PrimitiveUnion

#: The stored per-vertex attribute holding each vertex's mass.
MASS = "mass"


def _leaves(vertices: Union[Primitive, PrimitiveUnion]) -> List[Primitive]:
    """The primitives under a primitive or (nested) union, in order."""
    if isinstance(vertices, PrimitiveUnion):
        return [leaf for member in vertices.members for leaf in _leaves(member)]
    return [vertices]


def average_vertex_mass(vertices: Union[Primitive, PrimitiveUnion]
                        ) -> Optional[float]:
    """The mean mass over the vertices that record one (a 1x1 stored
    ``mass`` with a value for every instance), or None where none do."""
    masses = []
    for primitive in _leaves(vertices):
        if MASS not in primitive:
            continue
        mass = primitive[MASS]
        if mass.shape != (1, 1) or mass.kind not in STORED_KINDS:
            continue
        try:
            masses.append(np.asarray(mass.value, dtype=float).reshape(-1))
        except ValueUpdateError:  # no values for the current instances
            continue
    if not masses:
        return None
    values = np.concatenate(masses)
    return float(values.mean()) if values.size else None
