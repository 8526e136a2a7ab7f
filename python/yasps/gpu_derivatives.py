"""Local derivatives on the GPU, kept on the device for assembly.

On the GPU backend, ``minimizeEnergy`` runs each energy's gradient, projected
Hessian (or its factors J and P) and placement-index kernels on the device;
their outputs stay there and ``GpuSystem`` assembles them directly, so the
local Hessians never cross the bus. Only the placement indices (``__dofs``)
are copied back, when the host builds the system's block structure from
them.

Each instance's value is a column-major matrix in the kernels' output:
gradients (n x 1) and Hessians (n x n, symmetric) read the same either
way; the factor maps J (m x n) are assembled as column-major.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np

from . import compiler
from .attribute import Attribute
from .evaluate import (derivative_compile_error, derivative_kernels,
                       run_on_gpu, _compressed_sizes)
from .scene import Scene


@dataclass
class DeviceDerivatives:
    """An energy's local derivatives for assembly, in device memory."""
    energy: Attribute
    count: int  #: instances
    gradient: object  #: GpuBuffer, count x n
    #: GpuBuffer, count x n x n projected Hessians (None when factored)
    projectedHessian: Optional[object]
    #: GpuBuffers of the factors J (count x m x n, each column-major) and P
    #: (count x m x m) of separated reduced Hessians, else None
    innerMap: Optional[object]
    projectedInnerHessian: Optional[object]
    innerSize: int  #: m (0 without factors)
    dofs: Callable[[], np.ndarray]  #: the (count, n) DoF map, -1 for padding

    def add_to(self, system, energy_index: int) -> None:
        """Assembles into ``system`` (a GpuSystem) as energy
        ``energy_index``."""
        if self.innerMap is not None:
            system.add_factored_device(energy_index, self.gradient,
                                       self.innerMap,
                                       self.projectedInnerHessian,
                                       self.innerSize, column_major=True)
        else:
            system.add_device(energy_index, self.gradient,
                              self.projectedHessian)


def device_derivatives(scene: Scene, energy: Attribute
                       ) -> Optional[DeviceDerivatives]:
    """The assembly inputs of ``energy`` computed on the GPU session's
    device, or None where they must come from the CPU: when
    ``config.compress_local_hessians`` would merge repeated DoFs of some
    instance before projecting (paper 7.2), which runs on the host."""
    from .gpu_runtime import session

    spec = derivative_kernels(scene, energy, assembly_only=True)
    gpu = session()
    try:
        kernels = gpu.kernels(spec.ir, spec.paths, scene.name, spec.pipeline)
    except compiler.IRError as err:
        raise derivative_compile_error(energy, str(err)) from None
    count = energy.owner.numInstances

    def run(path: str):
        kernel = kernels.kernel(path)
        size = count * kernel.rows * kernel.cols
        # Assembly consumes the outputs before the next Newton iteration
        # computes them again: their memory is reused.
        return run_on_gpu(gpu, kernels, scene, path, count, size,
                          gpu.output(("derivatives", path), size))

    dofs_path = spec.base + "__dofs"
    known: Optional[np.ndarray] = None

    def dofs() -> np.ndarray:
        nonlocal known
        if known is None:
            n = kernels.kernel(dofs_path).rows
            host = np.empty(count * n)
            run(dofs_path).download(host)
            # 1-based in the kernel, 0 for padding; exact integers in f64.
            known = host.reshape(count, n).astype(np.int64) - 1
        return known

    projected = spec.base + "__hess_proj"
    if spec.compress and kernels.kernel(projected).projection == "full" and \
            (_compressed_sizes(dofs()) < dofs().shape[1]).any():
        return None
    gradient = run(spec.base + "__grad")
    if spec.separate:
        inner = kernels.kernel(spec.base + "__hess_inner_proj")
        return DeviceDerivatives(
            energy, count, gradient, None, run(spec.base + "__ij"),
            run(spec.base + "__hess_inner_proj"), inner.rows, dofs)
    return DeviceDerivatives(energy, count, gradient, run(projected), None,
                             None, 0, dofs)
