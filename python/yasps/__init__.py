"""yasps: differentiable simulation scenes compiled with MLIR.

Build a scene with the API of the YASPS paper (section 4, appendix F)::

    import numpy as np
    from yasps import scene

    s = scene("scene0")
    cloth = s.addMesh("cloth")
    cloth.addPrimitive("vertices", numInstances=4)
    x = cloth.vertices.addAttribute("position", rows=3, cols=1)
    x.updateValue(np.zeros((4, 3)))
    print(s.ir())

See docs/python.md for the guide and the API reference.
"""

from . import config
from .attribute import (Attribute, concat, constant, hstack, identity, select,
                        vstack, zeros)
from .backend import BackendError, backend, gpu_status
from .errors import (IRError, LineageError, SceneError, ShapeError,
                     ValueUpdateError, YaspsError)
from .minimize import SolverError
from .scene import Connectivity, Entity, Mesh, Primitive, PrimitiveUnion, Scene, scene

__all__ = [
    "Attribute", "BackendError", "backend", "Connectivity", "config", "Entity", "IRError", "LineageError", "Mesh",
    "Primitive", "PrimitiveUnion", "Scene", "SceneError", "ShapeError",
    "SolverError",
    "ValueUpdateError", "YaspsError", "concat", "constant", "gpu_status", "hstack",
    "identity", "scene", "select", "vstack", "zeros",
]

__version__ = "0.1.0"
