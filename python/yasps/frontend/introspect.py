"""Read-only access to what the frontend's objects hold, for the layers
above (IR emission, inputs, assembly, checkpoints): they read it here
instead of the objects' private fields, so the frontend may change how it
keeps them.

Functions, not members: meshes and primitives are reached as
``scene.<mesh>`` and ``mesh.<primitive>``, so every member of those classes
would take a name from users (``Entity._check_new_symbol``).
"""

from __future__ import annotations

from types import MappingProxyType
from typing import (TYPE_CHECKING, Any, Dict, Mapping, Optional, Sequence,
                    Tuple)

import numpy as np

from .attribute import Attribute

if TYPE_CHECKING:
    from .scene import Connectivity, Entity, Scene

#: One energy of a scene: (its attribute, whether its instances are
#: dynamic, its projection method).
EnergyRecord = Tuple[Attribute, bool, str]


def symbols(entity: "Entity") -> Mapping[str, Any]:
    """Everything named in ``entity``'s namespace (attributes, child
    entities, connectivities), in creation order."""
    return MappingProxyType(entity._symbols)


def named_attributes(entity: "Entity") -> Mapping[str, Attribute]:
    """``entity``'s named attributes (``entity.attributes`` without the
    copy)."""
    return MappingProxyType(entity._attributes)


def connectivities(entity: "Entity") -> Mapping[str, "Connectivity"]:
    """A primitive's connectivities (none for other entities)."""
    found: Dict[str, "Connectivity"] = getattr(entity, "_connectivities", {})
    return MappingProxyType(found)


def version(item: Any) -> int:
    """The version of an attribute's values or a connectivity's indices:
    it changes with every ``updateValue`` or ``updateConnectivity``."""
    return item._version


def structure_revision(scene: "Scene") -> int:
    """Counts the changes of what the scene's IR says: caches of anything
    derived from the structure are keyed by it."""
    return scene._structure


def energy_records(scene: "Scene") -> Sequence[EnergyRecord]:
    """The scene's energies with how each was added."""
    return tuple(scene._energies)


def stored_values(attr: Attribute) -> Optional[np.ndarray]:
    """A stored attribute's values as kept, flat and column-major (no
    copy; None before ``updateValue``)."""
    return attr._values


def stored_indices(conn: "Connectivity") -> Optional[np.ndarray]:
    """A connectivity's indices as kept (no copy; None before
    ``updateConnectivity`` or after its primitive's count changed)."""
    return conn._indices


def operation(attr: Attribute) -> str:
    """The operation that computes ``attr`` ("" for a stored one)."""
    return attr._op


def operands(attr: Attribute) -> Tuple[Attribute, ...]:
    """The attributes ``attr``'s operation reads."""
    return tuple(attr._operands)


def parameters(attr: Attribute) -> Mapping[str, Any]:
    """The operation's parameters (a literal's value, a JOIN's
    connectivity, ...)."""
    return MappingProxyType(attr._params)


def user_location(attr: Attribute) -> Optional[Tuple[str, int]]:
    """Where in the user's code ``attr`` was made: (file, line), or None."""
    return attr._loc
