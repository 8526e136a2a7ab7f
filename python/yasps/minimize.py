"""The global Newton system: DoF layout, assembly and the PCG solve.

The DoFs are the entries of the minimisation targets, target after target
(the paper's appendix A.1), each target instance one block of r*c DoFs. Every
energy's local parameters are mapped to DoFs (-1 for UNION padding) by the
generated ``@E__dofs`` kernels (appendix A.3, ``yasps-generate-indices``),
from the same parameter groups that differentiation produced; the C++ runtime
assembles the local gradients and projected Hessians into a block-sparse
system (appendix B) and solves it with block-Jacobi PCG (section 8).

On the GPU backend (``yasps.backend() == "gpu"``) the local derivatives,
the assembly and the PCG solve run on the device (``yasps.gpu_derivatives``,
``GpuSystem``); only the placement indices (when the structure is built)
and the solution come back.
"""

from __future__ import annotations

import time
from typing import Dict, List, Optional

import numpy as np

from . import compiler, config
from .attribute import Attribute
from .backend import backend
from .errors import SceneError, YaspsError
from .evaluate import energy_derivatives
from .gpu_derivatives import DeviceDerivatives, device_derivatives
from .emit import emit_scene
from .scene import Mesh, Primitive, PrimitiveUnion
from .values import from_column_major


class SolverError(YaspsError, RuntimeError):
    """PCG did not reach the requested tolerance; ``solution`` holds the
    last iterate (one array per target) and ``info`` the solver report."""

    def __init__(self, message: str, solution: list, info: dict):
        super().__init__(message)
        self.solution = solution
        self.info = info


class DofLayout:
    """Where each target's entries sit in the global vector."""

    def __init__(self, targets: List[Attribute]):
        self.targets = targets
        self.offset: Dict[int, int] = {}
        blocks = [0]
        for t in targets:
            self.offset[id(t)] = blocks[-1]
            rc = t.rows * t.cols
            blocks += list(blocks[-1] + rc * np.arange(1, t.owner.numInstances + 1))
        self.block_offsets = np.asarray(blocks, dtype=np.int64)
        self.size = int(blocks[-1])

    def split(self, x: np.ndarray) -> List[np.ndarray]:
        """Per target, its part of ``x`` as an ``(N, rows, cols)`` array."""
        out = []
        for t in self.targets:
            start = self.offset[id(t)]
            n = t.owner.numInstances * t.rows * t.cols
            out.append(from_column_major(x[start:start + n].copy(), t.rows, t.cols))
        return out


def _static_structure_key(scene, layout: DofLayout, static_energies) -> tuple:
    """What the DoF maps of the static energies depend on: the scene's
    structure without the instance counts of dynamic primitives, the DoF
    layout, the indices of every connectivity and the member counts of every
    union (paper 10.6: only dynamic instances change between steps)."""
    connectivities, unions = [], []
    pending = list(scene._symbols.values())
    while pending:
        entity = pending.pop()
        if isinstance(entity, PrimitiveUnion):
            unions.append(tuple(m.numInstances for m in entity.members))
        if isinstance(entity, Primitive) and not entity.isDynamic:
            connectivities += [(id(c), c._version)
                               for c in entity._connectivities.values()]
        if isinstance(entity, (Mesh, Primitive, PrimitiveUnion)):
            pending += list(entity._symbols.values())
    return (emit_scene(scene, dynamic_counts=False),
            layout.block_offsets.tobytes(), tuple(sorted(connectivities)),
            tuple(unions), tuple(id(e) for e in static_energies))


def _gpu_system(scene, system):
    """The GpuSystem mirroring ``system`` (made once per static structure;
    its dynamic structure is uploaded again on every call)."""
    from .gpu_runtime import session
    cached = scene._gpu_system
    if cached is not None and cached[0] is system:
        cached[1].update_dynamic()
        return cached[1]
    gpu = compiler._module().GpuSystem(session().device, system)
    scene._gpu_system = (system, gpu)
    return gpu


def assemble(scene, threads: Optional[int] = None,
             timings: Optional[Dict[str, float]] = None,
             report: Optional[Dict[str, object]] = None,
             on_gpu: bool = False):
    """The assembled global system and its DoF layout. ``timings``, if given,
    receives the seconds spent on derivatives, indices and assembly;
    ``report`` whether the static structure was rebuilt and how many
    energies were differentiated on the GPU. With ``on_gpu``, the system
    returned is the GPU mirror of the CPU one (a ``GpuSystem``), assembled
    on the device from derivatives computed there (``config.gpu_derivatives``).

    The system keeps static energies (instances fixed from step to step) and
    dynamic ones (``dynamic_instances``, e.g. collision pairs) apart: the
    static part's DoF maps and block structure are reused for as long as
    the scene's structure and connectivities are unchanged, and only the
    dynamic part is re-indexed on every call."""
    clock = time.perf_counter
    spent = {"derivatives": 0.0, "indices": 0.0, "assembly": 0.0}
    targets = scene.minimizeTargets
    if not targets:
        raise SceneError(f"scene '{scene.name}' has no minimisation targets "
                         "(addMinimizeTarget)")
    layout = DofLayout(targets)
    static, dynamic = [], []
    for energy, is_dynamic, _ in scene._energies:
        start = clock()
        try:
            d = None
            if on_gpu and config.gpu_derivatives:
                # None where the host must compress repeated DoFs.
                d = device_derivatives(scene, energy)
            if d is None:
                d = energy_derivatives(scene, energy, threads,
                                       assembly_only=True)
        except SceneError as err:
            if "depends on no minimisation target" in str(err):
                continue
            raise
        spent["derivatives"] += clock() - start
        (dynamic if is_dynamic else static).append((energy, d))
    on_device = sum(isinstance(d, DeviceDerivatives)
                    for _, d in static + dynamic)
    if on_device:
        # Launches return at once: time the derivatives, not their launch.
        start = clock()
        from .gpu_runtime import session
        session().device.synchronize()
        spent["derivatives"] += clock() - start

    start = clock()
    native = compiler._module()
    key = _static_structure_key(scene, layout, [e for e, _ in static])
    cached = scene._static_system
    rebuilt = cached is None or cached[0] != key
    if rebuilt:
        system = native.GlobalSystem(layout.block_offsets,
                                     [d.dofs() for _, d in static])
        scene._static_system = (key, system)
    else:
        system = cached[1]
    system.set_dynamic([d.dofs() for _, d in dynamic])
    spent["indices"] += clock() - start

    start = clock()
    if on_gpu:
        system = _gpu_system(scene, system)
    system.set_zero()
    # The CPU system splits instances across threads; the GPU runs them all.
    workers = () if on_gpu else \
        (config.num_threads if threads is None else threads,)
    for k, (_, d) in enumerate(static + dynamic):
        if isinstance(d, DeviceDerivatives):
            d.add_to(system, k)
            continue
        gradient = np.ascontiguousarray(d.gradient)
        if d.innerMap is not None:
            # Hessians kept as factors: J^T P J is formed while assembling.
            system.add_factored(k, gradient, np.ascontiguousarray(d.innerMap),
                                np.ascontiguousarray(d.projectedInnerHessian),
                                d.innerMap.shape[1], *workers)
        else:
            system.add(k, gradient, np.ascontiguousarray(d.projectedHessian),
                       *workers)
    if on_gpu:
        # The device derivatives are freed on return: let assembly finish.
        system.synchronize()
    spent["assembly"] += clock() - start
    if timings is not None:
        timings.update(spent)
    if report is not None:
        report["staticStructureRebuilt"] = rebuilt
        report["energiesDifferentiatedOnGpu"] = on_device
    return system, layout


def fixed_dof_mask(layout: DofLayout, fixed) -> Optional[np.ndarray]:
    """The per-DoF uint8 mask of ``fixed``: one entry per target (in
    ``addMinimizeTarget``'s order), each None, a boolean mask of its
    instances (N,) or of its entries (N, rows, cols)."""
    if fixed is None:
        return None
    if len(fixed) != len(layout.targets):
        raise ValueError(f"minimizeEnergy: fixed has {len(fixed)} entries but "
                         f"there are {len(layout.targets)} targets")
    parts = []
    for target, mask in zip(layout.targets, fixed):
        n, r, c = target.owner.numInstances, target.rows, target.cols
        if mask is None:
            parts.append(np.zeros(n * r * c, dtype=np.uint8))
            continue
        mask = np.asarray(mask, dtype=bool)
        if mask.shape == (n,):
            mask = np.broadcast_to(mask[:, None, None], (n, r, c))
        if mask.shape != (n, r, c):
            raise ValueError(
                f"minimizeEnergy: the fixed mask of {target.describe()} has "
                f"shape {mask.shape}; expected ({n},) or ({n}, {r}, {c})")
        # DoFs are column-major within an instance.
        parts.append(np.transpose(mask, (0, 2, 1)).reshape(-1).astype(np.uint8))
    return np.ascontiguousarray(np.concatenate(parts)) if parts else None


def minimize_energy(scene, tolerance: float = 1e-6, maxIterations: int = 1000,
                    threads: Optional[int] = None,
                    fixed: Optional[list] = None) -> List[np.ndarray]:
    """Solves H dx = g for the assembled projected Hessian and gradient,
    with dx = 0 at the ``fixed`` DoFs (see fixed_dof_mask), on the active
    backend (``yasps.backend()``)."""
    if not (tolerance >= 0):
        raise ValueError(f"minimizeEnergy: tolerance must be >= 0, got {tolerance}")
    timings: Dict[str, float] = {}
    report: Dict[str, object] = {}
    where = backend()
    system, layout = assemble(scene, threads, timings, report,
                              on_gpu=where == "gpu")
    mask = fixed_dof_mask(layout, fixed)
    x = np.zeros(system.size)
    start = time.perf_counter()
    if where == "gpu":
        iterations, residual, converged = system.solve(
            x, float(tolerance), int(maxIterations), mask)
    else:
        iterations, residual, converged = system.solve(
            x, float(tolerance), int(maxIterations),
            config.num_threads if threads is None else threads, mask)
    timings["solve"] = time.perf_counter() - start
    info = {"iterations": int(iterations), "relativeResidual": float(residual),
            "converged": bool(converged), "seconds": timings,
            "backend": where, **report}
    scene.lastSolve = info
    solution = layout.split(x)
    if not converged:
        raise SolverError(
            f"minimizeEnergy: PCG stopped after {iterations} iterations at "
            f"relative residual {residual:.3g} (tolerance {tolerance:g}); "
            "the last iterate is in .solution", solution, info)
    return solution
