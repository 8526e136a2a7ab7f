"""The energies of a contact, built on a mesh of any scene.

:class:`yasps.contact.Contact` builds them on the user's scene, joined to
the bodies' vertices; :mod:`.forces` builds the same on a scene whose only
target is the vertices' world positions, to differentiate them in world
space. One builder keeps the two alike: primitive for primitive and
constant for constant, so that the state of one copies onto the other by
name.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, Optional, Sequence

import numpy as np

from ..frontend.attribute import Attribute
from ..frontend.scene import Mesh, Primitive
from .friction import add_friction_primitives
from .halfspace import HalfSpaces
from .pairs import PAIR_TYPES, barrier_energy


@dataclass
class ContactModel:
    """The primitives and stored constants of a contact's energies."""
    #: the mesh holding them
    mesh: Mesh
    #: the barrier stiffness (1x1 stored constant on the mesh)
    stiffness: Attribute
    #: one dynamic pair primitive per pair type, by type name
    primitives: Dict[str, Primitive]
    #: the half-spaces and their pair primitive
    halfspaces: HalfSpaces
    #: one dynamic friction primitive per stencil size (none without
    #: friction)
    friction_primitives: Dict[int, Primitive] = field(default_factory=dict)
    #: friction's displacement threshold eps_v dt (with friction)
    eps_u: Optional[Attribute] = None

    @property
    def normal_energies(self):
        """The barrier energies (pairs and half-spaces)."""
        found = [p["barrier"] for p in self.primitives.values()]
        if self.halfspaces.primitive is not None:
            found.append(self.halfspaces.primitive["barrier"])
        return found

    @property
    def friction_energies(self):
        """The friction energies."""
        return [p["friction"] for p in self.friction_primitives.values()]

    def dynamic_primitives(self):
        """Every primitive whose instances change with the pairs."""
        found = list(self.primitives.values())
        if self.halfspaces.primitive is not None:
            found.append(self.halfspaces.primitive)
        return found + list(self.friction_primitives.values())


def add_contact_energies(mesh: Mesh, vertices, positions: Attribute,
                         dhat: float, planes: Sequence, friction: bool,
                         eps_v: float, projection: str) -> ContactModel:
    """The contact's primitives and energies on ``mesh``, joined to
    ``vertices`` whose world positions are ``positions``: IPC's barrier on
    each pair type and on the half-spaces ``planes``, and with
    ``friction`` the lagged friction primitives (threshold eps_v dt, set by
    the lag). The stiffness is a stored value (1 until set): changing it
    recompiles nothing."""
    stiffness = mesh.addConstant("kappa", rows=1)
    stiffness.updateValue([1.0])
    primitives: Dict[str, Primitive] = {}
    for pair in PAIR_TYPES:
        p = mesh.addPrimitive(pair.name, numInstances=0, isDynamic=True)
        link = p.addConnectivity("v", vertices, np.zeros((0, pair.arity),
                                                          np.int64),
                                 pair.arity)
        gathered = p.addAttribute("x", through=link, source=positions)
        eps = p.addConstant("eps_x", rows=1)
        weight = p.addConstant("weight", rows=1)
        energy = barrier_energy(pair, gathered, eps, weight, dhat, stiffness)
        mesh.scene.addEnergy(p.addAttribute("barrier",
                                            computed_attribute=energy),
                             dynamic_instances=True, projection=projection)
        primitives[pair.name] = p
    halfspaces = HalfSpaces(mesh, vertices, positions, planes, dhat,
                            stiffness, projection)
    model = ContactModel(mesh, stiffness, primitives, halfspaces)
    if friction:
        model.eps_u = mesh.addConstant("eps_u", rows=1)
        model.eps_u.updateValue([eps_v])
        model.friction_primitives = add_friction_primitives(
            mesh, vertices, positions, model.eps_u, projection)
    return model
