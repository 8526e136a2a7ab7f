"""The global Newton system: DoF layout and assembly.

The DoFs are the entries of the minimisation targets, target after target
(the paper's appendix A.1), each target instance one block of r*c DoFs. Every
energy's local parameters are mapped to DoFs (-1 for UNION padding) by the
generated ``@E__dofs`` kernels (appendix A.3, ``yasps-generate-indices``),
from the same parameter groups that differentiation produced; the C++ runtime
builds the block-sparse structure from them (appendix B) and the backend
assembles the local gradients and projected Hessians into it (on the GPU,
into a device mirror of the system, from derivatives computed there).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

from ..frontend.state import StateKey
from .. import config
from ..frontend import introspect
from ..frontend.attribute import Attribute, owner_of
from ..frontend.errors import SceneError
from ..frontend.scene import (Entity, Mesh, Primitive, PrimitiveUnion,
                              Scene)
from ..frontend.values import from_column_major
from ..ir import kernel_ir
from ..runtime import Backend
from ..runtime.native import native
from .derivatives import Contribution, NoDerivativesError, \
    assembly_contribution
from .projection import GradientThreshold


class DofLayout:
    """Where each target's entries sit in the global vector."""

    def __init__(self, targets: List[Attribute]):
        self.targets = targets
        self.offset: Dict[int, int] = {}
        blocks = [0]
        for t in targets:
            self.offset[id(t)] = blocks[-1]
            rc = t.rows * t.cols
            blocks += list(blocks[-1] + rc * np.arange(1, owner_of(t).numInstances + 1))
        self.block_offsets = np.asarray(blocks, dtype=np.int64)
        self.size = int(blocks[-1])

    def split(self, x: np.ndarray) -> List[np.ndarray]:
        """Per target, its part of ``x`` as an ``(N, rows, cols)`` array."""
        out = []
        for t in self.targets:
            start = self.offset[id(t)]
            n = owner_of(t).numInstances * t.rows * t.cols
            out.append(from_column_major(x[start:start + n].copy(), t.rows, t.cols))
        return out


def read_dofs(size: int, dof_maps: List[np.ndarray]) -> np.ndarray:
    """Which of ``size`` DoFs the DoF maps (-1: padding) mention."""
    read = np.zeros(size, dtype=bool)
    for dofs in dof_maps:
        indices = np.asarray(dofs).reshape(-1)
        read[indices[indices >= 0]] = True
    return read


def _static_structure_key(scene, ir: str, layout: DofLayout,
                          static_energies) -> tuple:
    """What the DoF maps of the static energies depend on: the scene's
    structure without the instance counts of dynamic primitives (``ir``,
    its kernel_ir), the DoF layout, the indices of every connectivity and
    the member counts of every union (paper 10.6: only dynamic instances
    change between steps)."""
    connectivities, unions = [], []
    pending = list(introspect.symbols(scene).values())
    while pending:
        entity = pending.pop()
        if isinstance(entity, PrimitiveUnion):
            unions.append(tuple(m.numInstances for m in entity.members))
        if isinstance(entity, Primitive) and not entity.isDynamic:
            connectivities += [
                (id(c), introspect.version(c))
                for c in introspect.connectivities(entity).values()]
        if isinstance(entity, (Mesh, Primitive, PrimitiveUnion)):
            pending += list(introspect.symbols(entity).values())
    return (ir, layout.block_offsets.tobytes(), tuple(sorted(connectivities)),
            tuple(unions), tuple(id(e) for e in static_energies))


#: The runtime system of each scene's static energies and the key of what
#: it was built from, reused while the structure is unchanged.
# f32 represents every integer below this exactly: the placement indices
# (DoF + 1) f32 kernels compute.
_F32_EXACT_INTEGERS = 2 ** 24

_STATIC_SYSTEM: StateKey[tuple] = StateKey(
    "the Newton system's static part and the key it was built for")


class _Point:
    """The local derivatives computed at a scene's point (``key``: see
    _point_key), one (energy, is_dynamic, Contribution) per energy with
    derivatives, and the gradient assembled there once read."""

    def __init__(self, key: tuple, entries: list):
        self.key, self.entries = key, entries
        self.gradient: Optional[np.ndarray] = None
        #: the host system last assembled here (None: none, or another
        #: backend's), and the last assembly there
        self.system = None
        self.assembly: Optional[Assembly] = None


#: Each scene's last point: an assembly at the same point with another
#: projection (progressive projection's retries) reuses its derivatives
#: instead of running every kernel again.
_LAST_POINT: StateKey[_Point] = StateKey(
    "the local derivatives at the last point assembled")


def _point_key(scene: Scene, ir: str, backend: Backend,
               threads: Optional[int]) -> tuple:
    """What an assembly's local derivatives depend on besides the scene's
    structure: the version of every stored value and connectivity, every
    primitive's instance count, the backend, threads and settings."""
    versions: list = []
    pending = list(introspect.symbols(scene).values())
    while pending:
        entity = pending.pop()
        if isinstance(entity, Attribute):
            versions.append((id(entity), introspect.version(entity)))
        elif isinstance(entity, Primitive):
            versions.append((id(entity), entity.numInstances))
            versions += [(id(c), introspect.version(c))
                         for c in introspect.connectivities(entity).values()]
        if isinstance(entity, Entity):
            pending += list(introspect.symbols(entity).values())
    return (ir, id(backend), threads, config.snapshot(), tuple(versions))


def _contributions(scene: Scene, backend: Backend, threads: Optional[int],
                   ir: str) -> list:
    """(energy, is_dynamic, Contribution) of every energy with derivatives,
    static energies first (the system's order)."""
    # The Jacobian tables of factored energies: one evaluation per source
    # for every energy that reaches it.
    tables: dict = {}
    entries = []
    for energy, is_dynamic, _ in introspect.energy_records(scene):
        try:
            contribution = assembly_contribution(scene, energy, backend,
                                                 threads, ir, tables)
        except NoDerivativesError:
            continue
        entries.append((energy, is_dynamic, contribution))
    return [e for e in entries if not e[1]] + [e for e in entries if e[1]]


def _assemble_inputs(backend: Backend, system, inputs: list,
                     threads: Optional[int]) -> None:
    """Zeroes ``system`` and adds every energy's inputs to it."""
    system.set_zero()
    for k, energy_inputs in enumerate(inputs):
        backend.add(system, k, energy_inputs, threads)
    backend.finish_assembly(system)
    # The local derivatives are reused by the next call: let assembly finish.
    backend.synchronize(system)


@dataclass(frozen=True)
class Assembly:
    """An assembled Newton system (``system``: the runtime's GlobalSystem on
    the CPU, its device mirror, a ``GpuSystem``, on the GPU), its DoF
    layout, and what ``minimizeEnergy`` reports and checks of it."""

    system: Any
    layout: DofLayout
    #: seconds spent on "derivatives", "indices" and "assembly"
    seconds: Dict[str, float]
    #: whether the static energies' structure was built anew
    static_structure_rebuilt: bool
    #: how many energies were differentiated off the host
    energies_on_gpu: int
    #: instances in all, and how many of them entered projected
    instances: int
    projected_instances: int
    #: per DoF, whether some energy instance reads it
    read_dofs: np.ndarray
    #: (energy, local inputs) per energy: where a NaN would come from
    contributions: List[Tuple[Attribute, Any]]

    def report(self) -> Dict[str, Any]:
        """What ``lastSolve`` says of the assembly."""
        return {"staticStructureRebuilt": self.static_structure_rebuilt,
                "energiesDifferentiatedOnGpu": self.energies_on_gpu,
                "projectedInstances": self.projected_instances,
                "instances": self.instances}


def assemble(scene: Scene, backend: Backend, threads: Optional[int] = None,
             projection: Optional[GradientThreshold] = None) -> Assembly:
    """The system assembled on ``backend`` (:class:`Assembly`).

    The system keeps static energies (instances fixed from step to step) and
    dynamic ones (``dynamic_instances``, e.g. collision pairs) apart: the
    static part's DoF maps and block structure are reused for as long as
    the scene's structure and connectivities are unchanged, and only the
    dynamic part is re-indexed on every call.

    ``projection`` chooses the instances whose local Hessians are
    PSD-projected (None: all): at a new point the system is first
    assembled with the energies' exact Hessians where :class:`Contribution`
    allows; where the threshold then picks some DoFs by the assembled
    gradient, the chosen instances' projected minus exact Hessians are
    added (on a GPU system, it is assembled again). At the scene's last
    point the gradient is known: a retry there with a lower threshold
    (progressive projection's) adds only the newly chosen instances'
    projected minus exact Hessians to the host system assembled there, with
    no re-indexing or re-assembly; otherwise one assembly does."""
    clock = time.perf_counter
    spent = {"derivatives": 0.0, "indices": 0.0, "assembly": 0.0}
    targets = scene.minimizeTargets
    if not targets:
        raise SceneError(f"scene '{scene.name}' has no minimisation targets "
                         "(addMinimizeTarget)")
    layout = DofLayout(targets)
    if (config.resolve_precision(scene.precision) == "f32"
            and layout.size >= _F32_EXACT_INTEGERS):
        raise SceneError(
            f"scene '{scene.name}' has {layout.size:,} DoFs: f32 kernels "
            f"compute placement indices exactly only below 2^24 "
            f"({_F32_EXACT_INTEGERS:,}); compute this scene in f64")
    # One emission of the scene for every energy's kernels; it does not
    # change with the counts of dynamic primitives.
    ir = kernel_ir(scene)
    point = _point_key(scene, ir, backend, threads)
    last = scene.state.get(_LAST_POINT)
    if last is not None and last.key != point:
        last = None  # another point's derivatives: not reused
    # None: every instance projected; a DoF mask: those of the instances
    # reading it (at first none, the exact Hessians where allowed, unless
    # the gradient here is known already).
    chosen: Optional[np.ndarray] = None
    if projection is not None and not projection.projects_all():
        chosen = np.zeros(layout.size, dtype=bool)
        if last is not None and last.gradient is not None \
                and not projection.projects_none():
            chosen = projection.projected_dofs(last.gradient)
    if last is not None and last.assembly is not None and \
            chosen is not None and chosen.any() and \
            _updatable(scene, backend, last, chosen):
        # A retry of progressive projection at the point just assembled:
        # only the instances newly chosen are projected and their change
        # added (SymX's update), with no re-indexing or re-assembly.
        _add_projections(backend, last, chosen, spent)
        last.assembly = replace(
            last.assembly, seconds=spent, static_structure_rebuilt=False,
            projected_instances=sum(c.projected_count
                                    for _, _, c in last.entries))
        return last.assembly
    start = clock()
    if last is not None:
        entries = last.entries
    else:
        entries = _contributions(scene, backend, threads, ir)
        last = scene.state.set(_LAST_POINT, _Point(point, entries))
    inputs = [c.inputs(chosen) for _, _, c in entries]
    spent["derivatives"] += clock() - start
    # Launches may return at once: time the derivatives, not their launch.
    start = clock()
    backend.synchronize()
    spent["derivatives"] += clock() - start
    static = [(e, c) for e, is_dynamic, c in entries if not is_dynamic]
    dynamic = [(e, c) for e, is_dynamic, c in entries if is_dynamic]
    contributions: List[Contribution] = [c for _, _, c in entries]

    start = clock()
    key = _static_structure_key(scene, ir, layout, [e for e, _ in static])
    cached = scene.state.get(_STATIC_SYSTEM)
    rebuilt = cached is None or cached[0] != key
    if rebuilt:
        static_dofs = [c.dofs() for _, c in static]
        host_system = native().GlobalSystem(layout.block_offsets, static_dofs)
        static_read = read_dofs(layout.size, static_dofs)
        scene.state.set(_STATIC_SYSTEM, (key, host_system, static_read))
    else:
        assert cached is not None  # not rebuilt: there is one
        host_system, static_read = cached[1], cached[2]
    dynamic_dofs = [c.dofs() for _, c in dynamic]
    host_system.set_dynamic(dynamic_dofs)
    spent["indices"] += clock() - start

    system = backend.system(scene, host_system)
    start = clock()
    _assemble_inputs(backend, system, inputs, threads)
    spent["assembly"] += clock() - start
    last.system = system if backend is backend.host else None
    # chosen is only set with a projection.
    selective = chosen is not None and projection is not None and \
        not projection.projects_none() and \
        any(c.selective for c in contributions)
    if projection is not None and last.gradient is None:
        # The gradient does not depend on the projection: read it once
        # (retries at this point choose by it).
        last.gradient = np.empty(layout.size)
        system.gradient(last.gradient)
        if selective:
            chosen = projection.projected_dofs(last.gradient)
            if chosen.any() and backend is backend.host:
                # Assembly adds: only the chosen instances' projected minus
                # exact Hessians are added to what is there (SymX's
                # update), to those instances alone.
                _add_projections(backend, last, chosen, spent)
            elif chosen.any():
                start = clock()
                inputs = [c.inputs(chosen) for c in contributions]
                spent["derivatives"] += clock() - start
                start = clock()
                _assemble_inputs(backend, system, inputs, threads)
                spent["assembly"] += clock() - start
    last.assembly = Assembly(
        system, layout, spent, rebuilt,
        energies_on_gpu=sum(x.backend is not backend.host for x in inputs),
        instances=sum(c.count for c in contributions),
        projected_instances=sum(c.projected_count for c in contributions),
        read_dofs=static_read | read_dofs(layout.size, dynamic_dofs),
        contributions=[(energy, x)
                       for (energy, _, _), x in zip(entries, inputs)])
    return last.assembly


def _updatable(scene: Scene, backend: Backend, last: _Point,
               chosen: np.ndarray) -> bool:
    """Whether the host system last assembled at ``last`` is still the
    scene's and becomes the assembly projecting ``chosen`` (a DoF mask)
    by adding projections alone (every instance projected there reads a
    chosen DoF)."""
    cached = scene.state.get(_STATIC_SYSTEM)
    return (backend is backend.host and last.system is not None
            and cached is not None and cached[1] is last.system
            and all(c.updatable_to(chosen) for _, _, c in last.entries))


def _add_projections(backend: Backend, last: _Point, chosen: np.ndarray,
                     spent: Dict[str, float]) -> None:
    """Adds to the host system the projected minus exact Hessians of the
    instances that read a ``chosen`` DoF and are not projected there yet
    (the contributions track which are)."""
    host = backend.host  # backend itself, as the host backend
    start = time.perf_counter()
    updates = [(k, c.projection_update(chosen))
               for k, (_, _, c) in enumerate(last.entries)]
    spent["derivatives"] += time.perf_counter() - start
    start = time.perf_counter()
    for k, update in updates:
        if update is not None:
            host.add_to_instances(last.system, k, update.instances,
                                  update.hessians)
    backend.finish_assembly(last.system)
    spent["assembly"] += time.perf_counter() - start
