"""Scene-relative symbol paths (``@mesh::@primitive::@attribute``): how IR,
compiled kernels and their argument lists name a scene's objects."""

from __future__ import annotations

from typing import Any

from ..frontend import introspect
from ..frontend.attribute import Attribute, owner_of
from ..frontend.scene import Entity, Scene


def symbol_path(attr: Attribute) -> str:
    """Scene-relative symbol path of a named attribute, e.g. @m::@v::@x."""
    name = attr.name
    assert name is not None  # named attributes only, as said
    return "::".join("@" + n for n in owner_of(attr).path + [name])


def entity_path(entity: Entity) -> str:
    """Scene-relative symbol path of an entity, e.g. @m::@v."""
    return "::".join("@" + name for name in entity.path)


def resolve(scene: Scene, path: str) -> Any:
    """The object a scene-relative path such as ``@m::@v::@x`` names."""
    node: Any = scene
    for name in path.split("::"):
        node = introspect.symbols(node)[name.lstrip("@")]
    return node
