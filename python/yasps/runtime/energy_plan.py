"""The total energy as one call into the runtime (what the line search
asks at every candidate).

A plan is made once per scene structure, backend and thread count: every
energy's kernel compiled (or found in the caches), its entry point, and the
entities its arguments read, resolved. A call then only gathers the current
arrays (values and connectivities change between calls; instance counts of
dynamic primitives too) and hands every kernel to the backend at once: on
the CPU one native call runs them all and sums their outputs.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, List, Optional, Tuple

import numpy as np

from ..frontend.state import StateKey
from .. import config
from ..compiler.params import ArgumentKind, KernelArgument
from ..frontend import introspect
from ..frontend.attribute import Attribute
from ..frontend.scene import Entity, Scene
from ..ir import kernel_ir, resolve, symbol_path
from .base import Backend
from .inputs import input_array


@dataclass(frozen=True)
class PlannedEnergy:
    """One energy's kernel: its path, the entity whose instances it runs
    over, its arguments in launch order with the entities they read (None
    for the output and the DoF offsets), and the compiled kernels that hold
    it (kept alive: an entry point is valid while its library lives)."""

    path: str
    owner: Entity
    arguments: Tuple[KernelArgument, ...]
    sources: Tuple[Optional[Any], ...]
    kernels: Any

    @property
    def output(self) -> int:
        """The position of the output among the arguments."""
        return next(k for k, a in enumerate(self.arguments)
                    if a.kind is ArgumentKind.out)

    def inputs(self, scene: Scene) -> List[np.ndarray]:
        """The current host arrays of the inputs, in argument order without
        the output (checked as ``host_input`` checks them)."""
        return [input_array(scene, a, source) for a, source
                in zip(self.arguments, self.sources)
                if a.kind is not ArgumentKind.out]


@dataclass(frozen=True)
class EnergyPlan:
    """Every registered energy's kernel (``energies``), valid for ``key``."""

    key: tuple
    energies: Tuple[PlannedEnergy, ...]


_PLAN: StateKey[EnergyPlan] = StateKey("the total energy's plan")


def _key(scene: Scene, backend: Backend, threads: Optional[int]) -> tuple:
    """What a plan depends on: the scene's structure (its energies and
    every entity's arguments), the backend, the threads and the kernels'
    settings."""
    return (introspect.structure_revision(scene), id(backend), threads, config.snapshot())


def energy_plan(scene: Scene, backend: Backend,
                threads: Optional[int] = None) -> EnergyPlan:
    """The scene's plan for ``backend`` (made now if its structure, the
    backend, the threads or a setting changed since the last)."""
    key = _key(scene, backend, threads)
    plan = scene.state.get(_PLAN)
    if plan is not None and plan.key == key:
        return plan
    # Energies are evaluated in f64 whatever the scene's precision: see
    # compute_request.
    ir = kernel_ir(scene, precision="f64")
    planned = []
    for energy in scene.energies:
        path = symbol_path(energy)
        kernels = backend.compile(ir, (path,), scene.name)
        arguments = tuple(kernels.kernel(path).arguments)
        sources = tuple(resolve(scene, a.path)
                        if a.kind in (ArgumentKind.attr, ArgumentKind.conn,
                                      ArgumentKind.offsets) else None
                        for a in arguments)
        owner = energy.owner
        assert isinstance(energy, Attribute) and owner is not None
        planned.append(PlannedEnergy(path, owner, arguments, sources,
                                     kernels))
    return scene.state.set(_PLAN, EnergyPlan(key, tuple(planned)))
