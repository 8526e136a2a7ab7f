"""Evaluating attributes on a CUDA GPU: the GPU backend of ``compute()``.

One session per process holds the device's context, the loaded modules
(kernels compiled for the device's compute capability by ``yasps.gpu``) and
device copies of the scene's stored values. A copy is uploaded again only
when its source changed: attributes and connectivities carry versions that
``updateValue`` and ``updateConnectivity`` bump; union and DoF offsets are a
few integers, compared by value. Results are copied back into NumPy arrays.
"""

from __future__ import annotations

from typing import Dict, List, Optional, Tuple

import numpy as np

from . import compiler
from .backend import gpu_status
from .gpu import GpuKernels, compile_ir


class GpuSession:
    """The device, its modules and the device copies of stored values."""

    def __init__(self, ordinal: int = 0):
        native = compiler._module()
        self._native = native
        self.device = native.GpuDevice(ordinal)
        self.chip = gpu_status().devices[ordinal][1]
        self._libraries: Dict[Tuple[str, str, str], GpuKernels] = {}
        self._modules: Dict[str, object] = {}
        # (kind, path) -> (what the copy was made from, device buffer, and
        # the source object, held so that its id is not reused by another
        # object while the copy is cached)
        self._copies: Dict[Tuple[str, str], Tuple[object, object, object]] = {}
        #: (kind, path) of every upload, in order (for tests and tuning).
        self.uploads: List[Tuple[str, str]] = []
        # Reused outputs (see output()), by key.
        self._outputs: Dict[object, object] = {}

    def kernels(self, ir: str, paths, name: str,
                pipeline: str = "") -> GpuKernels:
        """The kernels of ``paths`` (one path or a list, compiled into one
        module) for this device, compiled once."""
        paths = (paths,) if isinstance(paths, str) else tuple(paths)
        key = (ir, paths, pipeline)
        if key not in self._libraries:
            self._libraries[key] = compile_ir(ir, list(paths), name, pipeline,
                                              chips=(self.chip,),
                                              keep_ptx=False)
        return self._libraries[key]

    def module(self, kernels: GpuKernels):
        """The loaded module of a library (the cubin or PTX that fits)."""
        key = kernels.stats.get("key") or str(id(kernels))
        if key not in self._modules:
            chip, fmt = self._native.gpu_select_image(list(kernels.binaries),
                                                      self.chip)
            self._modules[key] = self._native.gpu_load_module(
                self.device, kernels.binaries[(chip, fmt)])
        return self._modules[key]

    def copy_of(self, kind: str, path: str, source: object,
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

    def launch(self, kernels: GpuKernels, path: str, count: int,
               buffers: List[object]) -> None:
        """Runs the kernel of ``path`` on ``count`` instances."""
        kernel = kernels.kernel(path)
        self._native.gpu_launch(self.module(kernels), kernel.name,
                                kernel.launch_params, buffers, 0, count,
                                kernel.threads_per_block)


_session: Optional[GpuSession] = None


def session() -> GpuSession:
    """The process's GPU session, opened on first use."""
    global _session
    if _session is None:
        _session = GpuSession()
    return _session
