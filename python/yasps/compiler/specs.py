"""Which kernels a scene's evaluation needs: the derivative kernels of an
energy (what the differentiation pipeline makes of it) and every kernel of a
simulation."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Tuple

from .. import config
from ..frontend.attribute import Attribute
from ..frontend.errors import SceneError
from ..frontend.scene import Scene
from ..ir import kernel_ir, symbol_path
from .errors import native, translated
from .pipelines import DIFFERENTIATION_PIPELINE, differentiation_pipeline


@dataclass
class DerivativeKernels:
    """Which kernels give an energy's local derivatives (the attributes
    that ``differentiation_pipeline()`` makes of it)."""
    base: str         #: the energy's scene-relative path
    ir: str           #: the scene's IR
    pipeline: str     #: the differentiation pipeline
    separate: bool    #: projected Hessians kept as factors (__ij, inner)
    #: the kernels whose values are returned: __grad, __hess unless only
    #: assembly needs them, and the projected Hessian or its factors
    evaluated: List[str]
    #: whether assembly compresses repeated DoFs before projecting (paper
    #: 7.2), which needs the unprojected Hessian as well
    compress: bool
    paths: List[str]  #: every kernel to compile (evaluated, __hess, __dofs)

    def path(self, role: str) -> str:
        """The derivative attribute of ``role`` (grad, hess, hess_proj,
        ij, hess_inner_proj, dofs)."""
        return f"{self.base}__{role}"


#: Whether an energy's projected Hessian has factors, by (IR, pipeline,
#: energy): asked of the compiler once per scene structure.
_factored: Dict[Tuple[str, str, str], bool] = {}


def _has_inner_factors(ir: str, pipeline: str, base: str, name: str) -> bool:
    key = (ir, pipeline, base)
    if key not in _factored:
        with translated("attribute_params"):
            _factored[key] = bool(native().attribute_params(
                ir, pipeline, [base + "__hess_inner_proj"], name)[0])
    return _factored[key]


def derivative_kernels(scene: Scene, energy: Attribute,
                       assembly_only: bool) -> DerivativeKernels:
    """The kernels of ``energy``'s local derivatives; ``assembly_only``
    leaves out what assembly does not need (values, unprojected
    Hessians)."""
    if not any(e is energy for e in scene.energies):
        raise SceneError(f"{energy.describe()} is not an energy of scene "
                         f"'{scene.name}' (addEnergy)")
    if not scene.minimizeTargets:
        raise SceneError(f"scene '{scene.name}' has no minimisation targets "
                         "(addMinimizeTarget)")
    base = symbol_path(energy)
    ir = kernel_ir(scene)
    pipeline = differentiation_pipeline()
    separate = config.separate_reduced_hessians and \
        _has_inner_factors(ir, pipeline, base, scene.name)
    projected = [base + "__ij", base + "__hess_inner_proj"] if separate \
        else [base + "__hess_proj"]
    evaluated = [base + "__grad"] + \
        ([] if assembly_only else [base + "__hess"]) + projected
    compress = assembly_only and not separate and config.compress_local_hessians
    paths = evaluated + ([base + "__hess"] if compress else []) \
        + [base + "__dofs"]
    return DerivativeKernels(base, ir, pipeline, separate, evaluated,
                             compress, paths)


def scene_kernel_paths(scene: Scene) -> List[str]:
    """The attributes a scene's simulation evaluates: every energy, and for
    energies that depend on a minimisation target their gradient, Hessian,
    projected Hessian and placement indices (``__dofs``)."""
    if not scene.energies:
        raise SceneError(f"scene '{scene.name}' has no energies (addEnergy)")
    paths = []
    bases = [symbol_path(e) for e in scene.energies]
    derived = [False] * len(bases)
    if scene.minimizeTargets:
        ir = kernel_ir(scene)
        with translated("attribute_params"):
            params = native().attribute_params(
                ir, DIFFERENTIATION_PIPELINE, [b + "__grad" for b in bases],
                scene.name)
        derived = [bool(p) for p in params]
    for base, has_derivatives in zip(bases, derived):
        paths.append(base)
        if has_derivatives:
            paths += [base + "__grad", base + "__hess", base + "__hess_proj",
                      base + "__dofs"]
    return paths
