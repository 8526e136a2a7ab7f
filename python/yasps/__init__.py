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

The package is layered, each layer importing only those before it:
``frontend`` (this API) -> ``ir`` -> ``compiler`` -> ``runtime`` (the
backends) -> ``solve`` -> ``sim``. See docs/python.md for the guide and
docs/architecture.md for the layers.
"""

from . import compiler, config, ir, runtime, solve
from .frontend import energies
from .frontend.attribute import (Attribute, concat, constant, hstack,
                                 identity, select, vstack, zeros)
from .frontend.errors import (ArgumentError, ArgumentTypeError,
                              CheckpointError, IndexRangeError, IRError,
                              LineageError,
                              NameLookupError, SceneError, ShapeError,
                              ValueUpdateError, YaspsError)
from .errors import ModelFileError
from .frontend.scene import (Connectivity, Entity, Mesh, Primitive,
                             PrimitiveUnion, Scene, scene)
from .frontend.services import Services, install
from .runtime import BackendError, backend, gpu_status
from .solve import CompileSummary, SolverError
from .solve import compile_scene as compile
from .deprecation import YaspsDeprecationWarning
from .solve.diagnosis import IllConditionedSolve, PrecisionWarning


# The frontend's methods that need IR, kernels or a solver run on the
# backend that runtime.current() picks at each call.
install(Services(
    emit=lambda s, locations: ir.emit_scene(s, locations=locations),
    verify=lambda s: compiler.verify(ir.emit_scene(s, locations=True),
                                     name=s.name),
    compute=lambda attr, threads: runtime.compute(attr, runtime.current(),
                                                  threads),
    total_energy=lambda s, threads: runtime.total_energy(
        s, runtime.current(), threads),
    energy_derivatives=lambda s, energy, threads: solve.energy_derivatives(
        s, energy, runtime.current(), threads),
    minimize_energy=lambda s, *args: solve.minimize_energy(
        s, runtime.current(), *args),
))

__all__ = [
    "ArgumentError", "ArgumentTypeError", "CheckpointError",
    "IndexRangeError", "NameLookupError", "Attribute", "BackendError", "backend", "CompileSummary", "compile",
    "Connectivity", "config",
    "Entity", "IRError", "IllConditionedSolve", "LineageError", "Mesh",
    "ModelFileError",
    "PrecisionWarning", "Primitive", "PrimitiveUnion", "Scene", "SceneError", "ShapeError", "SolverError",
    "ValueUpdateError", "YaspsDeprecationWarning", "YaspsError", "concat", "constant", "energies",
    "gpu_status", "hstack", "identity", "scene", "select", "vstack", "zeros",
]

__version__ = "0.1.0"
