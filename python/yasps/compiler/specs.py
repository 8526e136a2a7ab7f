"""Which kernels a scene's evaluation needs: the derivative kernels of an
energy (what the differentiation pipeline makes of it) and every kernel of a
simulation."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Set, Tuple

from .. import config
from ..frontend import introspect
from ..frontend.attribute import Attribute
from ..frontend.errors import SceneError
from ..frontend.scene import Entity, Scene
from ..ir import kernel_ir, symbol_path
from .params import Param, attribute_params
from .pipelines import differentiation_pipeline


@dataclass(frozen=True)
class KernelRequest:
    """One request to the compiler: the kernels of ``paths`` (scene-relative
    attribute paths) of the scene ``ir`` (a ``kernel_ir``) after
    ``pipeline``; ``name`` labels diagnostics."""
    ir: str
    paths: Tuple[str, ...]
    name: str
    pipeline: str = ""


def grouped_requests(requests: Sequence[KernelRequest]
                     ) -> Dict[Tuple[str, str, str], List[Tuple[str, ...]]]:
    """``requests`` by what one compiler request can serve together: the
    same scene IR, pipeline and name; each group the path lists of its
    requests, in order."""
    groups: Dict[Tuple[str, str, str], List[Tuple[str, ...]]] = {}
    for request in requests:
        key = (request.ir, request.pipeline, request.name)
        groups.setdefault(key, []).append(tuple(request.paths))
    return groups


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
        ij, hess_inner_proj, dofs, ijac: the inner gradient)."""
        return f"{self.base}__{role}"


@dataclass
class SceneParams:
    """What the differentiation pipeline made of a scene's energies, asked
    of the compiler once per scene structure (one parse and one run of the
    pipeline for all energies)."""
    #: each energy's local parameter groups (of ``E__grad``), by path;
    #: empty for energies that depend on no target
    gradients: Dict[str, List[Param]]
    #: the energies whose projected Hessians are kept as factors
    factored: Set[str]
    #: whether each computed attribute has a Jacobian ``X__jac``, by the
    #: Jacobian's path
    jacobians: Dict[str, bool]


#: SceneParams by (IR, pipeline).
_scene_params: Dict[Tuple[str, str], SceneParams] = {}


def _named_attributes(scene: Scene) -> List[Attribute]:
    """Every named attribute of the scene, entity by entity."""
    out, pending = [], list(introspect.symbols(scene).values())
    while pending:
        entity = pending.pop()
        if isinstance(entity, Attribute):
            out.append(entity)
        elif isinstance(entity, Entity):
            pending += list(introspect.symbols(entity).values())
    return out


def scene_params(scene: Scene, ir: str, pipeline: str) -> SceneParams:
    """The scene's SceneParams for its ``kernel_ir`` ``ir``."""
    key = (ir, pipeline)
    if key not in _scene_params:
        bases = [symbol_path(e) for e in scene.energies]
        sources = [symbol_path(a) + "__jac" for a in _named_attributes(scene)
                   if a.kind in ("computed", "join")]
        paths = [b + "__grad" for b in bases] + \
            [b + "__hess_inner_proj" for b in bases] + sources
        params = attribute_params(ir, pipeline, paths, scene.name)
        k = len(bases)
        _scene_params[key] = SceneParams(
            dict(zip(bases, params)),
            {b for b, p in zip(bases, params[k:2 * k]) if p},
            {path: bool(p) for path, p in zip(sources, params[2 * k:])})
    return _scene_params[key]


def _has_inner_factors(scene: Scene, ir: str, pipeline: str,
                       base: str) -> bool:
    return base in scene_params(scene, ir, pipeline).factored


def derivative_kernels(scene: Scene, energy: Attribute, assembly_only: bool,
                       ir: Optional[str] = None) -> DerivativeKernels:
    """The kernels of ``energy``'s local derivatives; ``assembly_only``
    leaves out what assembly does not need (values, unprojected
    Hessians). ``ir`` is the scene's ``kernel_ir`` if the caller has it
    (one emission for all of a scene's energies)."""
    if not any(e is energy for e in scene.energies):
        raise SceneError(f"{energy.describe()} is not an energy of scene "
                         f"'{scene.name}' (addEnergy)")
    if not scene.minimizeTargets:
        raise SceneError(f"scene '{scene.name}' has no minimisation targets "
                         "(addMinimizeTarget)")
    base = symbol_path(energy)
    ir = kernel_ir(scene) if ir is None else ir
    pipeline = differentiation_pipeline()
    separate = config.separate_reduced_hessians is not False and \
        _has_inner_factors(scene, ir, pipeline, base)
    projected = [base + "__ij", base + "__hess_inner_proj"] if separate \
        else [base + "__hess_proj"]
    # Factored: the local Hessian is J^T H_inner J, formed on the host.
    hessian = [base + ("__hess_inner" if separate else "__hess")]
    evaluated = [base + "__grad"] + \
        ([] if assembly_only else hessian) + projected
    compress = assembly_only and not separate and config.compress_local_hessians
    # Assembly may take plain local Hessians exact (progressively projected
    # Newton), and compression projects them after merging DoFs.
    paths = evaluated + ([base + "__hess"] if assembly_only and not separate
                         else []) + [base + "__dofs"]
    return DerivativeKernels(base, ir, pipeline, separate, evaluated,
                             compress, paths)


def scene_kernel_paths(scene: Scene) -> List[str]:
    """The attributes a scene's simulation evaluates: every energy, and for
    energies that depend on a minimisation target what assembly reads (the
    gradient, the projected Hessian or its factors, the unprojected Hessian
    of unfactored ones (compression and progressively projected Newton read
    it), and the placement indices ``__dofs``), after
    ``differentiation_pipeline()``."""
    if not scene.energies:
        raise SceneError(f"scene '{scene.name}' has no energies (addEnergy)")
    paths = []
    bases = [symbol_path(e) for e in scene.energies]
    derived = [False] * len(bases)
    if scene.minimizeTargets:
        gradients = scene_params(scene, kernel_ir(scene),
                                 differentiation_pipeline()).gradients
        derived = [bool(gradients[b]) for b in bases]
    for energy, base, has_derivatives in zip(scene.energies, bases, derived):
        paths.append(base)
        if has_derivatives:
            paths += derivative_kernels(scene, energy, True).paths
    return paths
