"""Evaluating attributes with compiled kernels (``attr.compute()``).

The scene is emitted as IR, the attribute's kernel is compiled (or found in
the in-memory or on-disk cache) for the active backend, which runs it over
all instances of the attribute's owner with the stored values,
connectivities and union offsets as buffers. Intermediate attributes are
never stored.
"""

from __future__ import annotations

from typing import Any, Dict, List, Optional, Tuple

import numpy as np

from ..frontend.attribute import Attribute, owner_of
from ..frontend.errors import SceneError
from ..frontend.scene import Entity
from ..compiler.specs import KernelRequest
from ..ir import kernel_ir, symbol_path
from .base import Backend, Shape
from .energy_plan import energy_plan

#: Name under which an unnamed expression is evaluated.
_TEMPORARY = "__yasps_compute"


class ComputedValue:
    """The result of :meth:`Attribute.compute`: ``value``, an ``(N, rows,
    cols)`` NumPy array, and ``stats``.

    It is also a DLPack array of the same values (``torch.from_dlpack(r)``,
    ``cupy.from_dlpack(r)``, ``np.from_dlpack(r)``): on the GPU backend a
    view of the result in device memory, without a copy; on the CPU the
    NumPy array. On the GPU, ``value`` is copied back on first use only."""

    def __init__(self, attribute: Attribute, output: Any, shape: Shape,
                 stats: dict, backend: Backend):
        self.attribute = attribute
        #: The kernel's output in the backend's memory (column-major per
        #: instance) and its (N, rows, cols).
        self._output = output
        self._shape = shape
        self._backend = backend
        self._value: Optional[np.ndarray] = None
        #: How the kernel was obtained: cache hits and compile times.
        self.stats = stats

    @property
    def value(self) -> np.ndarray:
        """The values, shape ``(N, rows, cols)`` (copied from the GPU the
        first time they are read)."""
        if self._value is None:
            self._value = self._backend.to_host(self._output, self._shape)
        return self._value

    def __dlpack__(self, **kwargs):
        return self._backend.dlpack_source(self._output,
                                           self._shape).__dlpack__(**kwargs)

    def __dlpack_device__(self):
        return self._backend.dlpack_source(self._output,
                                           self._shape).__dlpack_device__()

    def __repr__(self) -> str:
        return (f"<yasps.ComputedValue of {self.attribute.describe()} on the "
                f"{self._backend.name.upper()}: {self._shape}>")


def _target(attr: Attribute) -> Tuple[Dict[Entity, List[Tuple[str, Attribute]]],
                                      str]:
    """The attributes to add to the scene's IR for ``attr`` (an unnamed
    expression is evaluated under a temporary name) and the path of its
    kernel."""
    owner = attr.owner
    if owner is None:
        raise SceneError(f"{attr.describe()} belongs to no entity; add it to "
                         "one with addAttribute(name, computed_attribute=...)")
    if not attr.isNamed:
        return ({owner: [(_TEMPORARY, attr)]},
                "::".join("@" + n for n in owner.path + [_TEMPORARY]))
    return {}, symbol_path(attr)


def compute_request(attr: Attribute) -> KernelRequest:
    """The compiler request that ``compute(attr)`` makes. Values are f64
    whatever the scene's precision: the line search compares energies whose
    decrease near convergence is below f32's round-off of them, and
    collision detection reads world positions. Only the derivatives (the
    Newton system) are computed in f32."""
    extra, path = _target(attr)
    scene = owner_of(attr).scene  # _target raised if it had none
    return KernelRequest(kernel_ir(scene, extra, precision="f64"), (path,),
                         scene.name)


def compute(attr: Attribute, backend: Backend,
            threads: Optional[int] = None) -> ComputedValue:
    """Evaluates ``attr`` on every instance of its owner on ``backend``, in
    f64 (``config.precision`` applies to derivatives only)."""
    request = compute_request(attr)
    owner = owner_of(attr)  # compute_request raised if it had none
    count = owner.numInstances
    kernels = backend.compile(request.ir, request.paths, request.name)
    output = backend.run(kernels, owner.scene, request.paths[0], count,
                         threads)
    return ComputedValue(attr, output, (count, attr.rows, attr.cols),
                         backend.stats(kernels), backend)


def total_energy(scene, backend: Backend,
                 threads: Optional[int] = None) -> float:
    """The sum of every registered energy over its instances, in f64
    (``Scene.evaluateEnergy``): one call into the backend over the scene's
    energy plan (runtime.energy_plan), made once per scene structure (the
    line search calls this at every candidate)."""
    if not scene.energies:
        return 0.0
    return backend.sum_energies(energy_plan(scene, backend, threads), scene,
                                threads)
