"""The paper's API (section 4, appendix F): scenes, meshes, primitives,
unions, connectivities, attributes and their expressions, energies, stored
values and the errors of misuse. No IR, no kernels, no runtime: what needs
them goes through :mod:`yasps.frontend.services`."""

from .attribute import (PROJECTION_METHODS, Attribute, concat, constant,
                        hstack, identity, select, vstack, zeros)
from .errors import (IRError, LineageError, SceneError, ShapeError,
                     ValueUpdateError, YaspsError)
from .scene import (Connectivity, Entity, Mesh, Primitive, PrimitiveUnion,
                    Scene, scene)

__all__ = [
    "PROJECTION_METHODS", "Attribute", "concat", "constant", "hstack",
    "identity", "select", "vstack", "zeros", "IRError", "LineageError",
    "SceneError", "ShapeError", "ValueUpdateError", "YaspsError",
    "Connectivity", "Entity", "Mesh", "Primitive", "PrimitiveUnion", "Scene",
    "scene",
]
