"""The runtime layer: one backend protocol (:mod:`.base`) with a CPU and a
GPU implementation, the choice between them (:func:`current`, the one place
that picks), and attribute evaluation (``compute``)."""

from __future__ import annotations

from .backend import BackendError, GpuStatus, backend, devices, gpu_status
from .base import (Backend, DenseInputs, FactoredInputs, LocalInputs,
                   SlotFactoredInputs)
from .cpu import CpuBackend
from .evaluate import ComputedValue, compute, total_energy
from .gpu import GpuBackend

_cpu = CpuBackend()
_gpu = GpuBackend(_cpu)


def cpu_backend() -> CpuBackend:
    """The CPU backend."""
    return _cpu


def gpu_backend() -> GpuBackend:
    """The GPU backend (usable when ``backend()`` can choose it)."""
    return _gpu


def current() -> Backend:
    """The backend ``yasps.config.backend`` selects now (see
    :func:`backend`); raises BackendError as that does."""
    return _gpu if backend() == "gpu" else _cpu


__all__ = ["Backend", "BackendError", "ComputedValue", "CpuBackend",
           "DenseInputs", "FactoredInputs", "GpuBackend", "GpuStatus",
           "LocalInputs", "SlotFactoredInputs", "backend", "compute",
           "total_energy",
           "cpu_backend", "current", "devices", "gpu_backend", "gpu_status"]
