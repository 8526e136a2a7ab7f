"""The GPU backend: kernels compiled for the device's chip, launched on
device copies of the stored values; the Newton system mirrored on the device
(``GpuSystem``), assembled there and solved by PCG.

One session per process holds the device's context, the loaded modules
(kernels compiled for the device's compute capability by ``yasps.gpu``) and
device copies of the scene's stored values. A copy is uploaded again only
when its source changed: attributes and connectivities carry versions that
``updateValue`` and ``updateConnectivity`` bump; union and DoF offsets are a
few integers, compared by value. Results stay on the device until read.
"""

from __future__ import annotations

import warnings
import weakref
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, cast

import numpy as np

from .. import config
from ..compiler.gpu import GpuKernels, compile_ir
from ..compiler.params import ArgumentKind
from ..compiler.specs import KernelRequest, grouped_requests
from ..frontend.errors import SceneError
from ..frontend.values import from_column_major
from .backend import gpu_status
from .base import DenseInputs, FactoredInputs, LocalInputs, Shape
from .cpu import CpuBackend, add_host_arrays
from .inputs import host_input, source_of
from .native import native


class GpuKernelCache:
    """The GPU kernels of this process for some chips, each compiled once:
    a request compiles, in one module, only the kernels no earlier request
    of the same IR and pipeline compiled, and the set it returns refers to
    the libraries that hold the others (``GpuKernels.library``)."""

    def __init__(self, chips: Sequence[str], keep_ptx: bool = False):
        self.chips = tuple(chips)
        self.keep_ptx = keep_ptx
        self._libraries: Dict[Tuple[str, Tuple[str, ...], str],
                              GpuKernels] = {}
        #: the compiled library of each kernel, by (IR, pipeline, path)
        self._library_of: Dict[Tuple[str, str, str], GpuKernels] = {}

    def kernels(self, ir: str, paths, name: str,
                pipeline: str = "") -> GpuKernels:
        """The kernels of ``paths`` (one path or a list)."""
        paths = (paths,) if isinstance(paths, str) else tuple(paths)
        key = (ir, paths, pipeline)
        if key in self._libraries:
            return self._libraries[key]
        missing = [p for p in dict.fromkeys(paths)
                   if (ir, pipeline, p) not in self._library_of]
        if missing:
            library = compile_ir(ir, missing, name, pipeline,
                                 chips=self.chips, keep_ptx=self.keep_ptx)
            for kernel in library.kernels:
                self._library_of[(ir, pipeline, kernel.attribute)] = \
                    library.library(kernel.attribute)
            stats = dict(library.stats, from_memory=False)
        else:
            stats = {"from_memory": True, "from_disk": False}
        libraries = {p: self._library_of[(ir, pipeline, p)] for p in paths}
        gathered = GpuKernels([libraries[p].kernel(p) for p in
                               dict.fromkeys(paths)], {}, stats,
                              (ir, pipeline, name), libraries)
        self._libraries[key] = gathered
        return gathered


class GpuSession(GpuKernelCache):
    """The device, its modules and the device copies of stored values."""

    def __init__(self, ordinal: int = 0):
        self._native = native()
        self.device = self._native.GpuDevice(ordinal)
        status = gpu_status()
        self.chip = status.devices[ordinal][1]
        #: what kernels are compiled for: the device's chip, or "host" for
        #: the test stand-in driver, which runs host images of the kernels
        #: (yasps/Runtime/Gpu/HostImage.h)
        self.target = "host" if status.host_images else self.chip
        super().__init__((self.target,))
        # Loaded modules, by their library's stats' "key" (else its id).
        self._modules: Dict[object, Any] = {}
        # (kind, path) -> (what the copy was made from, device buffer, and
        # the source object, held so that its id is not reused by another
        # object while the copy is cached)
        self._copies: Dict[Tuple[str, str], Tuple[object, Any, object]] = {}
        #: (kind, path) of every upload, in order (for tests and tuning).
        self.uploads: List[Tuple[str, str]] = []
        # Reused outputs (see output()), by key.
        self._outputs: Dict[object, Any] = {}
        #: what the driver raises (an allocation that fails, a bad launch)
        self.driver_error = self._native.CudaError

    def module(self, kernels: GpuKernels):
        """The loaded module of a library (the cubin or PTX that fits)."""
        key = kernels.stats.get("key") or str(id(kernels))
        if key not in self._modules:
            chip, fmt = self._native.gpu_select_image(list(kernels.binaries),
                                                      self.target)
            self._modules[key] = self._native.gpu_load_module(
                self.device, kernels.binaries[(chip, fmt)])
        return self._modules[key]

    def copy_of(self, kind: Any, path: str, source: object,
                host: np.ndarray):
        """A device copy of ``host``, the value of ``source`` (an attribute,
        a connectivity, or None for small arrays compared by value)."""
        token: object = (id(source), getattr(source, "_version", None)) \
            if source is not None else host.tobytes()
        cached = self._copies.get((kind, path))
        if cached is not None and cached[0] == token:
            return cached[1]
        host = np.ascontiguousarray(host)
        if cached is not None and cached[1].bytes >= host.nbytes:
            # New values of the same size (a simulation step): the copy's
            # memory is reused.
            buffer = cached[1]
            buffer.upload(host)
        else:
            buffer = self._native.gpu_upload(self.device, host)
        self._copies[(kind, path)] = (token, buffer, source)
        self.uploads.append((kind, path))
        return buffer

    def output(self, key: object, size: int):
        """A device buffer of at least ``size`` doubles kept under ``key``
        and handed out again by later calls: for outputs that are consumed
        before the next call with the same key (the local derivatives that
        assembly reads), so that a Newton loop does not allocate."""
        buffer = self._outputs.get(key)
        if buffer is None or buffer.bytes < 8 * size:
            buffer = self._native.gpu_allocate(self.device,
                                               max(size + size // 2, 1))
            self._outputs[key] = buffer
        return buffer

    def allocate(self, size: int):
        """A fresh device buffer of ``size`` doubles (a result handed to the
        user, which nothing else may overwrite)."""
        return self._native.gpu_allocate(self.device, size)

    def launch(self, kernels: GpuKernels, path: str, count: int,
               buffers: List[object]) -> None:
        """Runs the kernel of ``path`` on ``count`` instances."""
        kernel = kernels.kernel(path)
        self._native.gpu_launch(self.module(kernels.library(path)),
                                kernel.name,
                                kernel.launch_params, buffers, 0, count,
                                kernel.threads_per_block)


_session: Optional[GpuSession] = None


def session() -> GpuSession:
    """The process's GPU session, opened on first use."""
    global _session
    if _session is None:
        _session = GpuSession()
    return _session


class GpuBackend:
    """Kernels and the Newton system on the GPU session's device."""

    name = "gpu"
    #: The device system assembles per-instance factors J and P; shared
    #: slot Jacobian tables are a CPU path so far.
    slot_factors = False
    #: A multilevel solve on the device took 10x a block-Jacobi one, its
    #: setup dominating (docs/gpu.md): "auto" is block-Jacobi here until
    #: that setup moves to the device and the choice has a device model.
    chooses_preconditioner = False

    def __init__(self, host: CpuBackend,
                 chips: Optional[Sequence[str]] = None):
        self._host = host
        #: kernels compiled ahead for these chips, on a machine that need
        #: not have a GPU (``yasps.compile(scene, backend="gpu",
        #: chips=...)``): such a backend compiles and runs nothing else
        self._ahead = GpuKernelCache(chips) \
            if chips is not None else None
        # The GpuSystem mirroring each scene's host system, made once per
        # static structure: scene -> (host system, GpuSystem).
        self._systems: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()
        #: (kind, path) of the uploads of the last run()
        self.last_uploads: List[Tuple[Any, str]] = []
        self._warned_storage = False

    @property
    def host(self) -> CpuBackend:
        return self._host

    @property
    def derivatives(self):
        """The device, or the host when ``config.gpu_derivatives`` is off
        (derivatives computed there and uploaded for assembly)."""
        return self if config.gpu_derivatives else self._host

    def compile(self, ir: str, paths: Sequence[str], name: str,
                pipeline: str = "") -> GpuKernels:
        cache = self._ahead if self._ahead is not None else session()
        return cache.kernels(ir, paths, name, pipeline)

    def compile_ahead(self, requests: Sequence[KernelRequest],
                      progress: Callable[[int], None]) -> int:
        # The session compiles each kernel once per process: a request of
        # every path of a group compiles them in one module, and each
        # request finds them there later.
        compiled = 0
        for (ir, pipeline, name), groups in grouped_requests(requests).items():
            union = list(dict.fromkeys(p for paths in groups for p in paths))
            kernels = self.compile(ir, union, name, pipeline)
            if not (kernels.stats.get("from_memory") or
                    kernels.stats.get("from_disk")):
                compiled += len(union)
            progress(len(union))
        return compiled

    def run(self, kernels: GpuKernels, scene, path: str, count: int,
            threads: Optional[int] = None, reuse: object = None):
        gpu = session()
        kernel = kernels.kernel(path)
        size = count * kernel.rows * kernel.cols
        # Inputs first: a primitive without values is reported as such, not
        # as the output it would have filled.
        inputs = [None if a.kind is ArgumentKind.out else host_input(scene, a)
                  for a in kernel.arguments]
        try:
            out = gpu.output(reuse, size) if reuse is not None else \
                gpu.allocate(size)
        except gpu.driver_error as err:
            raise SceneError(
                f"{path}: {count} instances of {kernel.rows}x{kernel.cols} "
                f"doubles need {8 * size:,} bytes on the GPU: {err}") from None
        before = len(gpu.uploads)
        # host_input gave every argument but the output its array.
        buffers = [out if a.kind is ArgumentKind.out else
                   gpu.copy_of(a.kind, a.path, source_of(scene, a),
                               cast(np.ndarray, host))
                   for a, host in zip(kernel.arguments, inputs)]
        gpu.launch(kernels, path, count, buffers)
        self.last_uploads = gpu.uploads[before:]
        return out

    def sum_energies(self, plan, scene, threads: Optional[int]) -> float:
        # Each energy's kernel on the device, its outputs summed here.
        total = 0.0
        for e in plan.energies:
            count = e.owner.numInstances
            output = self.run(e.kernels, scene, e.path, count, threads)
            total += float(self.to_host(output, (count, 1, 1)).sum())
        return total

    def to_host(self, array, shape: Shape) -> np.ndarray:
        count, rows, cols = shape
        host = np.empty(count * rows * cols, dtype=np.float64)
        array.download(host)
        return from_column_major(host, rows, cols, copy=False)

    def dlpack_source(self, array, shape: Shape):
        count, rows, cols = shape
        # Entry (i, r, c) lies at i * rows * cols + c * rows + r.
        return array.dlpack_view([count, rows, cols], [rows * cols, 1, rows])

    def stats(self, kernels: GpuKernels) -> dict:
        return dict(kernels.stats, backend="gpu", device=session().chip,
                    # (kind name, path): what a user reads.
                    uploaded=[(kind.name, path)
                              for kind, path in self.last_uploads])

    def system(self, scene, host_system):
        cached = self._systems.get(scene)
        if cached is not None and cached[0] is host_system:
            # Same static structure: only the dynamic part is uploaded again.
            cached[1].update_dynamic()
            return cached[1]
        mirror = native().GpuSystem(session().device, host_system)
        self._systems[scene] = (host_system, mirror)
        return mirror

    def finish_assembly(self, system) -> None:
        """Ends an assembly. The device keeps f64 blocks: with
        ``config.hessian_storage`` "f32" (not "auto") it warns, once."""
        if (config.resolve_hessian_storage() == "f32"
                and not self._warned_storage):
            self._warned_storage = True
            warnings.warn("hessian_storage='f32' applies to the CPU solve; "
                          "the GPU solve keeps f64 blocks", stacklevel=3)

    def add(self, system, energy_index: int, inputs: LocalInputs,
            threads: Optional[int]) -> None:
        if inputs.backend is not self:
            # Computed on the host (compressed, or gpu_derivatives off).
            add_host_arrays(system, energy_index, inputs)
        elif isinstance(inputs, FactoredInputs):
            system.add_factored_device(energy_index, inputs.gradient,
                                       inputs.inner_map, inputs.inner_hessian,
                                       inputs.inner_size, column_major=True)
        else:
            # The device computes no slot factors (Backend.slot_factors).
            assert isinstance(inputs, DenseInputs)
            system.add_device(energy_index, inputs.gradient, inputs.hessian)

    def synchronize(self, system=None) -> None:
        (system if system is not None else session().device).synchronize()

    def solve(self, system, x: np.ndarray, tolerance: float,
              max_iterations: int, threads: Optional[int],
              fixed: Optional[np.ndarray], stopping: str = "residual",
              preconditioner: str = "block-jacobi"):
        preconditioner = preconditioner.replace("-", "_")
        return system.solve(x, tolerance, max_iterations, fixed,
                            preconditioner=getattr(
                                native().PcgPreconditioner, preconditioner),
                            stopping=getattr(native().PcgStopping, stopping))

