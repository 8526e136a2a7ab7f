"""Which processor evaluates kernels: the CPU or a CUDA GPU.

``yasps.config.backend`` (default: ``$YASPS_BACKEND``, else ``"auto"``)
chooses:

- ``"auto"``: the GPU when the CUDA driver loads and lists a device and
  this installation can build and run GPU kernels (the CUDA toolkit's
  ``ptxas``, and the runtime's solver kernels, built by ``nvcc``), else the
  CPU;
- ``"cpu"``: always the CPU;
- ``"gpu"``: the GPU, or ``BackendError`` saying why it cannot be used.

``yasps.backend()`` names the active one and ``yasps.gpu_status()`` says
what the driver reported; ``yasps.runtime.current()`` is the backend object
itself. On the GPU, ``Attribute.compute()`` launches the CUDA kernels of
``yasps.compiler.gpu`` on device copies of the stored values, which are
uploaded again only when they change, and ``minimizeEnergy`` differentiates,
assembles the Newton system and solves it by PCG on the device
(docs/gpu.md).
"""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass
from typing import List, Tuple

from .. import config
from ..frontend.errors import YaspsError
from .native import native

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
    #: Whether the driver is the test stand-in that runs host images of the
    #: generated kernels (``yasps/Runtime/Gpu/HostImage.h``): the GPU backend
    #: then compiles them for the host, not for the device's chip.
    host_images: bool = False


def gpu_status() -> GpuStatus:
    """Loads the CUDA driver (once per process) and reports on it."""
    usable, reason, devices, host_images = native().cuda_status()
    return GpuStatus(usable, reason, tuple(tuple(d) for d in devices),
                     host_images)


def gpu_toolchain_missing() -> str:
    """Why this installation cannot build and run GPU kernels ("" when it
    can): kernels are serialised by the CUDA toolkit's ``ptxas`` (in
    ``$CUDA_ROOT/bin``, ``/usr/local/cuda/bin`` or on ``PATH``), and the
    GPU solve needs the runtime's solver kernels, built by ``nvcc``."""
    if not native().gpu_solver_images():
        return ("this build of yasps has no GPU solver kernels (nvcc was not "
                "found when it was built)")
    roots = [os.environ.get("CUDA_ROOT"), "/usr/local/cuda"]
    path = os.pathsep.join([f"{r}/bin" for r in roots if r] +
                           [os.environ.get("PATH", "")])
    if shutil.which("ptxas", path=path) is None:
        return ("the CUDA toolkit's ptxas, which builds GPU kernels, was not "
                "found (in $CUDA_ROOT/bin, /usr/local/cuda/bin or on PATH)")
    return ""


def backend() -> str:
    """The backend that evaluates kernels now: ``"cpu"`` or ``"gpu"``.

    Raises:
        BackendError: for an unknown ``config.backend``, or ``"gpu"``
            without a usable GPU or GPU toolchain (the message says why).
    """
    choice = config.backend
    if choice not in BACKENDS:
        raise BackendError(f"unknown backend {choice!r} (yasps.config.backend "
                           f"or YASPS_BACKEND); choose one of {BACKENDS}")
    if choice == "cpu":
        return "cpu"
    status = gpu_status()
    reason = status.reason if not status.usable else gpu_toolchain_missing()
    if not reason:
        return "gpu"
    if choice == "gpu":
        raise BackendError(f"the GPU backend was requested but cannot be "
                           f"used: {reason}")
    return "cpu"


def devices() -> List[Tuple[str, str, int]]:
    """The CUDA devices the driver lists (empty without a usable driver)."""
    return list(gpu_status().devices)
