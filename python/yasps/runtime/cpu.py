"""The CPU backend: JIT-compiled kernels run by the runtime's thread pool on
the stored NumPy values; the Newton system is the runtime's GlobalSystem."""

from __future__ import annotations

import weakref
from typing import Callable, Optional, Sequence

import numpy as np

from .. import config
from ..compiler.cpu import CpuKernels, compile_cpu, compile_cpu_together
from ..compiler.params import ArgumentKind
from ..compiler.specs import KernelRequest, grouped_requests
from ..frontend.errors import SceneError
from ..frontend.values import from_column_major
from .base import (DenseInputs, FactoredInputs, LocalInputs, Shape,
                   SlotFactoredInputs)
from .inputs import host_input
from .native import native


def allocate_output(path: str, count: int, rows: int, cols: int,
                    dtype=np.float64) -> np.ndarray:
    """The output of ``count`` instances of ``rows x cols`` floats of
    ``dtype``; a yasps error naming the attribute and the bytes where memory
    runs out."""
    size = np.dtype(dtype).itemsize
    what = "doubles" if size == 8 else "floats"
    try:
        return np.empty(count * rows * cols, dtype=dtype)
    except MemoryError:
        raise SceneError(
            f"{path}: {count} instances of {rows}x{cols} {what} need "
            f"{size * count * rows * cols:,} bytes, more than this machine "
            "can allocate") from None


def _threads(threads: Optional[int]) -> int:
    return config.num_threads if threads is None else threads


def launch(kernels: CpuKernels, path: str, count: int, buffers: list,
           threads: int) -> None:
    """Runs the compiled kernel of ``path`` on instances [0, count) on the
    runtime's threads (``buffers`` in the kernel's argument order)."""
    entry, codes = kernels.entry(path)
    native().launch_cpu_kernel(entry, codes, count, buffers, threads)


class CpuBackend:
    """Kernels and the Newton system on the host."""

    name = "cpu"
    slot_factors = True
    chooses_preconditioner = True

    def __init__(self) -> None:
        # Outputs run with ``reuse`` keep their memory from call to call,
        # per scene: a warm Newton loop writes into pages it has touched
        # already instead of faulting in fresh ones.
        self._outputs: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()

    @property
    def host(self) -> "CpuBackend":
        return self

    @property
    def derivatives(self) -> "CpuBackend":
        return self

    def compile(self, ir: str, paths: Sequence[str], name: str,
                pipeline: str = "") -> CpuKernels:
        return compile_cpu(ir, paths, name, pipeline)

    def compile_ahead(self, requests: Sequence[KernelRequest],
                      progress: Callable[[int], None]) -> int:
        # The requests on one scene IR and pipeline compile as one: one
        # lowering, and code generation over every core.
        compiled = 0
        for (ir, pipeline, name), groups in grouped_requests(requests).items():
            made = 0

            def on_kernel(path: str) -> None:
                nonlocal made
                made += 1
                progress(1)

            kernels = compile_cpu_together(ir, groups, name, pipeline,
                                           on_kernel)
            progress(len(kernels.library.kernels) - made)
            compiled += made
        return compiled

    def run(self, kernels: CpuKernels, scene, path: str, count: int,
            threads: Optional[int] = None, reuse: object = None) -> np.ndarray:
        kernel = kernels.kernel(path)
        # The inputs are checked (values present, indices in bounds) before
        # the output is allocated.
        inputs = [None if a.kind is ArgumentKind.out else host_input(scene, a)
                  for a in kernel.arguments]
        size = count * kernel.rows * kernel.cols
        out = None
        if reuse is not None:
            kept = self._outputs.setdefault(scene, {})
            out = kept.get(reuse)
            if out is None or out.size != size or out.dtype != kernel.out_dtype:
                out = kept[reuse] = allocate_output(path, count, kernel.rows,
                                                    kernel.cols,
                                                    kernel.out_dtype)
        else:
            out = allocate_output(path, count, kernel.rows, kernel.cols,
                                  kernel.out_dtype)
        buffers = [out if a.kind is ArgumentKind.out else given
                   for a, given in zip(kernel.arguments, inputs)]
        launch(kernels, path, count, buffers, _threads(threads))
        return out

    def sum_energies(self, plan, scene, threads: Optional[int]) -> float:
        # One native call runs every energy's kernel and sums.
        energies = plan.energies
        entries = [e.kernels.entry(e.path) for e in energies]
        return float(native().sum_cpu_kernels(
            [entry for entry, _ in entries], [codes for _, codes in entries],
            [e.owner.numInstances for e in energies],
            [e.inputs(scene) for e in energies],
            [e.output for e in energies], _threads(threads)))

    def to_host(self, array: np.ndarray, shape: Shape) -> np.ndarray:
        # A view of the output buffer: no copy.
        return from_column_major(array, shape[1], shape[2], copy=False)

    def from_host(self, array: np.ndarray) -> np.ndarray:
        return array

    def dlpack_source(self, array: np.ndarray, shape: Shape) -> np.ndarray:
        return self.to_host(array, shape)

    def stats(self, kernels: CpuKernels) -> dict:
        return dict(kernels.stats)

    def system(self, scene, host_system):
        return host_system

    def add(self, system, energy_index: int, inputs: LocalInputs,
            threads: Optional[int]) -> None:
        add_host_arrays(system, energy_index, inputs, (_threads(threads),),
                        f32=True)

    def add_to_instances(self, system, energy_index: int,
                         instances: np.ndarray, hessians: np.ndarray) -> None:
        """Adds f64 local Hessians (k x n x n) to the k listed instances of
        an energy only (progressive projection's update), nothing to the
        gradient."""
        system.add_to_instances(energy_index,
                                np.ascontiguousarray(instances, np.int64),
                                _f64(hessians))

    def finish_assembly(self, system) -> None:
        """Ends an assembly. Where ``config.hessian_storage`` resolves to
        "f32" for the system's size, the solve's products read the
        Hessian's blocks rounded to f32 (f64 vectors and arithmetic)."""
        system.single_product = (
            config.resolve_hessian_storage(system.size) == "f32")
        system.finish_assembly()

    def synchronize(self, system=None) -> None:
        """CPU work is done when its call returns."""

    def solve(self, system, x: np.ndarray, tolerance: float,
              max_iterations: int, threads: Optional[int],
              fixed: Optional[np.ndarray], stopping: str = "residual",
              preconditioner: str = "block-jacobi"):
        preconditioner = preconditioner.replace("-", "_")
        return system.solve(x, tolerance, max_iterations, _threads(threads),
                            fixed, getattr(native().PcgStopping, stopping),
                            getattr(native().PcgPreconditioner,
                                    preconditioner))


def _f64(array: np.ndarray) -> np.ndarray:
    """``array`` as C-ordered f64 (a copy only when it is not)."""
    return np.ascontiguousarray(array, dtype=np.float64)


def add_host_arrays(system, energy_index: int, inputs: LocalInputs,
                    options: tuple = (), f32: bool = False) -> None:
    """Assembles local derivatives held in host memory into ``system`` (a
    GlobalSystem, or a GpuSystem, which uploads them); ``options`` are the
    system's further arguments (the CPU's thread count). With ``f32`` (the
    CPU's GlobalSystem), f32 gradients and Hessians of an f32 scene are
    assembled as they are; the factored paths, and other systems, take f64
    (f32 ones are widened)."""
    count, n = inputs.count, inputs.n
    if isinstance(inputs, SlotFactoredInputs):
        m, slots = inputs.inner_size, inputs.slot_factors
        # P is symmetric: row- and column-major storage agree.
        system.add_slot_factored(
            energy_index, _f64(inputs.gradient).reshape(count, m),
            _f64(inputs.inner_hessian).reshape(count, m, m),
            m, slots.tables, slots.slots, slots.sources, *options)
        return
    if isinstance(inputs, FactoredInputs):
        m = inputs.inner_size
        # Hessians kept as factors: J^T P J is formed while assembling.
        maps = _f64(from_column_major(inputs.inner_map, m, n, copy=False))
        inner = _f64(inputs.inner_hessian).reshape(count, m, m)
        system.add_factored(energy_index, _f64(inputs.gradient).reshape(
            count, n), maps, inner, m, *options)
        return
    assert isinstance(inputs, DenseInputs)  # the three kinds
    gradient, hessian = inputs.gradient, inputs.hessian
    if not (f32 and gradient.dtype == hessian.dtype == np.float32):
        gradient, hessian = _f64(gradient), _f64(hessian)
    # Symmetric: row- and column-major storage agree.
    system.add(energy_index, np.ascontiguousarray(gradient).reshape(count, n),
               np.ascontiguousarray(hessian).reshape(count, n, n), *options)
