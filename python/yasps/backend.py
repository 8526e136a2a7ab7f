"""Which processor evaluates kernels: the CPU or a CUDA GPU.

``yasps.config.backend`` (default: ``$YASPS_BACKEND``, else ``"auto"``)
chooses:

- ``"auto"``: the GPU when the CUDA driver loads and lists a device, else
  the CPU;
- ``"cpu"``: always the CPU;
- ``"gpu"``: the GPU, or ``BackendError`` saying why it cannot be used.

``yasps.backend()`` names the active one and ``yasps.gpu_status()`` says
what the driver reported. On the GPU, ``Attribute.compute()`` launches the
CUDA kernels of ``yasps.gpu`` on device copies of the stored values, which
are uploaded again only when they change, and ``minimizeEnergy`` assembles
the Newton system and solves it by PCG on the device; energy derivatives
still run on the CPU (docs/gpu.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import List, Tuple

from . import compiler, config
from .errors import YaspsError

BACKENDS = ("auto", "cpu", "gpu")


class BackendError(YaspsError, RuntimeError):
    """A backend that cannot be used (no GPU, no driver) or is unknown."""


@dataclass(frozen=True)
class GpuStatus:
    """What the CUDA driver reported when it was loaded."""
    usable: bool
    #: Why the GPU cannot be used ("" when it can).
    reason: str
    #: (name, compute capability such as "sm_90", memory in bytes) per device.
    devices: Tuple[Tuple[str, str, int], ...]


def gpu_status() -> GpuStatus:
    """Loads the CUDA driver (once per process) and reports on it."""
    usable, reason, devices = compiler._module().cuda_status()
    return GpuStatus(usable, reason, tuple(tuple(d) for d in devices))


def backend() -> str:
    """The backend that evaluates kernels now: ``"cpu"`` or ``"gpu"``.

    Raises:
        BackendError: for an unknown ``config.backend``, or ``"gpu"``
            without a usable GPU (the message says why).
    """
    choice = config.backend
    if choice not in BACKENDS:
        raise BackendError(f"unknown backend {choice!r} (yasps.config.backend "
                           f"or YASPS_BACKEND); choose one of {BACKENDS}")
    if choice == "cpu":
        return "cpu"
    status = gpu_status()
    if status.usable:
        return "gpu"
    if choice == "gpu":
        raise BackendError(f"the GPU backend was requested but cannot be "
                           f"used: {status.reason}")
    return "cpu"


def devices() -> List[Tuple[str, str, int]]:
    """The CUDA devices the driver lists (empty without a usable driver)."""
    return list(gpu_status().devices)
