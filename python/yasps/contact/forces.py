"""Contact and friction forces on each vertex, in world space.

A contact's energies are differentiated with respect to the minimisation
targets: for free vertices those are world positions, but for an affine,
caged or rotation-vector body they are the body's parameters, whose
gradient is a generalised force. The force on a vertex is minus the
gradient with respect to its world position, whatever moves it. So
:class:`ContactForces` keeps a second, small scene whose only target is
the vertices' world positions and whose contact energies are built by the
same code (:func:`.model.add_contact_energies`); at each call it copies
the contact's state onto it (world positions, stiffness, pairs and their
constants, lagged friction) and scatters the compiled local gradients of
its energies onto the vertices. Its kernels (local gradients only)
compile with the stepper's (``kernel_requests``), or else at the first
call, and are cached on disk like every scene's.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, List

import numpy as np

from ..frontend.attribute import STORED_KINDS, Attribute
from ..frontend.scene import Primitive, PrimitiveUnion, Scene
from ..compiler.specs import KernelRequest
from ..runtime import current
from ..solve.derivatives import gradient_request, local_gradients
from .model import ContactModel, add_contact_energies
from ..frontend.errors import ArgumentError

if TYPE_CHECKING:  # pragma: no cover
    from . import Contact

#: What :meth:`ContactForces.forces` can return: the barrier's (normal)
#: forces, friction's, or both summed.
FORCE_KINDS = ("all", "normal", "friction")


class ContactForces:
    """World-space forces of a :class:`~yasps.contact.Contact`'s energies
    (see the module docstring)."""

    def __init__(self, contact: "Contact"):
        self.contact = contact
        count = contact.vertices.numInstances
        # f64 whatever the simulation's precision: forces are read, not
        # solved with, and their sums (a body's weight) need the digits.
        self.scene = Scene(f"{contact.scene.name}_contact_forces",
                           precision="f64")
        points = self.scene.addMesh("world").addPrimitive(
            "vertex", numInstances=count)
        self.positions = points.addAttribute("position", rows=3)
        self.positions.updateValue(np.zeros((count, 3)))
        self.scene.addMinimizeTarget(self.positions)
        self.model: ContactModel = add_contact_energies(
            self.scene.addMesh("contact"), points, self.positions,
            contact.dhat, list(contact.planes), contact.friction > 0,
            contact.eps_v, "none")

    def _copy_state(self, V: np.ndarray) -> None:
        """The contact's positions, stiffness, pairs and lagged friction,
        onto the world-space copy."""
        source: ContactModel = self.contact.model
        self.positions.updateValue(V)
        self.model.stiffness.updateValue(source.stiffness.value)
        if source.eps_u is not None:
            # Built with the contact's friction flag: it has eps_u as well.
            assert self.model.eps_u is not None
            self.model.eps_u.updateValue(source.eps_u.value)
        for mine, theirs in zip(self.model.dynamic_primitives(),
                                source.dynamic_primitives()):
            _copy_primitive(theirs, mine)

    def kernel_requests(self) -> List[KernelRequest]:
        """The compiler requests :meth:`forces` makes, for compiling them
        ahead (``yasps.compile``)."""
        return [gradient_request(self.scene, energy)
                for energy in (self.model.normal_energies +
                               self.model.friction_energies)]

    def forces(self, kind: str = "all") -> np.ndarray:
        """The (N, 3) forces on the contact's vertices at their current
        positions (see :meth:`Contact.forces`)."""
        if kind not in FORCE_KINDS:
            raise ArgumentError(f"Contact.forces: kind must be one of "
                                f"{', '.join(FORCE_KINDS)}, got {kind!r}")
        V = self.contact.world()
        self._copy_state(V)
        energies = []
        if kind in ("all", "normal"):
            energies += self.model.normal_energies
        if kind in ("all", "friction"):
            energies += self.model.friction_energies
        gradient = np.zeros(V.size)
        for energy in energies:
            if energy.owner.numInstances:
                _scatter(self.scene, energy, gradient)
        return -gradient.reshape(V.shape)


def _copy_primitive(source: Primitive, target: Primitive) -> None:
    """A dynamic primitive's instance count, connectivities and stored
    values, onto its namesake."""
    target.updateNumInstances(source.numInstances)
    for name, link in source.connectivities.items():
        target.connectivities[name].updateConnectivity(link.indices)
    for name, attribute in source.attributes.items():
        if attribute.kind in STORED_KINDS:
            target[name].updateValue(attribute.value)


def _scatter(scene: Scene, energy: Attribute, gradient: np.ndarray) -> None:
    """Adds ``energy``'s local gradients onto the global ``gradient`` at
    their DoFs."""
    local, dofs = local_gradients(scene, energy, current())
    used = dofs >= 0
    np.add.at(gradient, dofs[used], local[used])


def member_sums(vertices, forces: np.ndarray) -> np.ndarray:
    """The forces summed over each member of a primitive union (B, 3), in
    member order; one row for a primitive."""
    if not isinstance(vertices, PrimitiveUnion):
        return forces.sum(axis=0, keepdims=True)
    offsets = vertices.offsets
    return np.stack([forces[a:b].sum(axis=0)
                     for a, b in zip(offsets[:-1], offsets[1:])])


__all__ = ["FORCE_KINDS", "ContactForces", "member_sums"]
