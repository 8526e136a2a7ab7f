"""The backend protocol: what the layers below ask of a processor.

A backend compiles kernels for its processor, runs them on a scene's stored
values, keeps their outputs in its own memory (NumPy arrays on the CPU,
device buffers on the GPU), mirrors the Newton system there, assembles local
derivatives into it and solves it. ``yasps.runtime.current()`` is the one
place that picks a backend; code below this layer asks the backend it is
given and never checks which one it is.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Optional, Protocol, Sequence, Tuple

import numpy as np

#: (instances, rows, cols) of a kernel output: each instance a column-major
#: rows x cols block, instance after instance.
Shape = Tuple[int, int, int]


@dataclass
class LocalInputs:
    """One energy's contribution to the Newton system, in the memory of the
    backend that computed it: ``count`` instances of ``n`` local parameters
    and their gradients. One of three kinds (:class:`DenseInputs`,
    :class:`FactoredInputs`, :class:`SlotFactoredInputs`), which assembly
    tells apart by type."""
    backend: "Backend"
    count: int
    n: int
    gradient: Any

    def arrays(self) -> Tuple[Tuple[str, Any], ...]:
        """The arrays, by what they hold (where a NaN is looked for)."""
        return (("gradient", self.gradient),)


@dataclass
class DenseInputs(LocalInputs):
    """Local gradients (count x n) and Hessians (count x n x n, projected or
    exact as assembly chose), each instance column-major."""
    hessian: Any

    def arrays(self) -> Tuple[Tuple[str, Any], ...]:
        return super().arrays() + (("Hessian", self.hessian),)


@dataclass
class FactoredInputs(LocalInputs):
    """Local gradients (count x n) and the Hessians as their factors, J
    (``inner_map``, count x m x n) and P (``inner_hessian``, count x m x m),
    each instance column-major: J^T P J is formed while assembling."""
    inner_map: Any
    inner_hessian: Any
    inner_size: int

    def arrays(self) -> Tuple[Tuple[str, Any], ...]:
        return super().arrays() + (("inner Jacobian", self.inner_map),
                                   ("inner Hessian", self.inner_hessian))


@dataclass
class SlotFactoredInputs(LocalInputs):
    """The inner gradients (count x m, in ``gradient``) and P
    (``inner_hessian``, count x m x m), with J taken slot by slot from
    shared Jacobian tables (``slot_factors``, a
    ``yasps.solve.slots.SlotInputs``)."""
    inner_hessian: Any
    inner_size: int
    slot_factors: Any

    def arrays(self) -> Tuple[Tuple[str, Any], ...]:
        return super().arrays() + (("inner Hessian", self.inner_hessian),)


class Backend(Protocol):
    """A processor that evaluates kernels and solves the Newton system."""

    #: "cpu" or "gpu"
    name: str
    #: whether add() forms J^T P J from shared slot Jacobian tables
    slot_factors: bool
    #: whether ``config.preconditioner = "auto"`` chooses between the
    #: preconditioners here (its cost model is the CPU's); else it is
    #: block-Jacobi
    chooses_preconditioner: bool

    @property
    def host(self) -> "HostBackend":
        """The backend that runs host-side steps (the CPU)."""

    @property
    def derivatives(self) -> "Backend":
        """The backend that computes local derivatives for assembly."""

    def compile(self, ir: str, paths: Sequence[str], name: str,
                pipeline: str = "") -> Any:
        """Kernels of ``paths`` for this processor, compiled once; the
        result has ``kernel(path)`` (a KernelInfo-like record), ``params``
        and ``stats``."""

    def compile_ahead(self, requests: Sequence[Any],
                      progress: Callable[[int], None]) -> int:
        """Compiles ``requests`` (``compiler.specs.KernelRequest``) before
        they are made, so that later ``compile`` calls with them find their
        kernels; ``progress(n)`` is called as n more kernels are ready.
        Returns how many kernels were compiled (not found in a cache)."""

    def run(self, kernels: Any, scene: Any, path: str, count: int,
            threads: Optional[int] = None, reuse: object = None) -> Any:
        """Runs the kernel of ``path`` on ``count`` instances; returns its
        output in this backend's memory. With ``reuse``, the output's memory
        is kept under that key and handed out again by the next call with
        it (for outputs consumed before then)."""

    def sum_energies(self, plan: Any, scene: Any,
                     threads: Optional[int]) -> float:
        """The sum over every energy of ``plan`` (runtime.energy_plan's
        EnergyPlan) and its instances, in f64."""

    def to_host(self, array: Any, shape: Shape) -> np.ndarray:
        """An output as an (N, rows, cols) NumPy array."""

    def dlpack_source(self, array: Any, shape: Shape) -> Any:
        """An object exporting the output through DLPack, without a copy."""

    def stats(self, kernels: Any) -> dict:
        """How the kernels were obtained and the last run's transfers."""

    def system(self, scene: Any, host_system: Any) -> Any:
        """The Newton system to assemble into: ``host_system`` (a runtime
        GlobalSystem, which owns the structure) or its mirror here."""

    def add(self, system: Any, energy_index: int, inputs: LocalInputs,
            threads: Optional[int]) -> None:
        """Assembles one energy's local derivatives into ``system``."""

    def finish_assembly(self, system: Any) -> None:
        """Ends an assembly of ``system`` (after its ``add`` calls)."""

    def synchronize(self, system: Any = None) -> None:
        """Waits for this backend's queued work (on ``system`` if given)."""

    def solve(self, system: Any, x: np.ndarray, tolerance: float,
              max_iterations: int, threads: Optional[int],
              fixed: Optional[np.ndarray], stopping: str = "residual",
              preconditioner: str = "block-jacobi") -> Any:
        """PCG on the assembled system into ``x`` with ``preconditioner``
        ("block-jacobi" or "multilevel"); ``stopping`` is "residual",
        "energy_norm" or "preconditioned" (see Scene.minimizeEnergy). Returns the native
        PcgReport (iterations, relative_residual recomputed from x,
        converged, stop, energy_error, condition_estimate, diagonal_ratio,
        residual_replacements, levels)."""


class HostBackend(Backend, Protocol):
    """The backend of host-side steps (``Backend.host``), which can also add
    to some instances of an energy alone."""

    def add_to_instances(self, system: Any, energy_index: int,
                         instances: np.ndarray, hessians: np.ndarray) -> None:
        """Adds f64 local Hessians (k x n x n) to the k listed instances of
        an energy only (progressive projection's update), nothing to the
        gradient."""
