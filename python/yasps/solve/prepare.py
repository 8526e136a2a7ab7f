"""Compiling everything a scene's evaluation and Newton steps need, up
front, with the wait shown (``yasps.compile(scene)``).

Without it, kernels are compiled when first used: each energy's derivative
kernels at the first ``minimizeEnergy``, its value kernel at the first
``evaluateEnergy``, each as a request of its own. Here the requests that
share a scene IR and pipeline are compiled as one (one lowering, code
generation over every core), with a progress bar over kernels, and each
later request finds its kernels in memory.
"""

from __future__ import annotations

import sys
import time
from contextlib import nullcontext
from dataclasses import dataclass
from typing import Any, Optional, Sequence, Union

from ..compiler import store as kernel_store
from ..compiler.specs import KernelRequest, grouped_requests
from ..errors import ArgumentError
from ..frontend.attribute import Attribute
from ..frontend.errors import SceneError
from ..frontend.scene import Scene
from ..runtime import (Backend, GpuBackend, cpu_backend, current,
                       gpu_backend)
from ..runtime.evaluate import compute_request
from .derivatives import assembly_requests, projector_requests


@dataclass(frozen=True)
class CompileSummary:
    """What :func:`compile_scene` did."""
    scene: str
    kernels: int    #: kernels the scene's evaluation and Newton steps use
    compiled: int   #: of them, those compiled now (the rest were cached)
    seconds: float  #: wall time, cached or not

    @property
    def loaded(self) -> int:
        """Kernels found in the memory or disk cache."""
        return self.kernels - self.compiled

    def line(self) -> str:
        """One line for users: kernels, compiled and cached, seconds."""
        return (f"scene '{self.scene}': {self.kernels} kernels, "
                f"{self.compiled} compiled, {self.loaded} from the cache, "
                f"in {self.seconds:.1f} s")


def _check_also(scene: Scene, also: Sequence[Attribute]) -> None:
    for attr in also:
        if not isinstance(attr, Attribute) or attr.owner is None or \
                attr.owner.scene is not scene:
            what = attr.describe() if isinstance(attr, Attribute) else \
                type(attr).__name__
            raise SceneError(f"yasps.compile: {what} is not an attribute of "
                             f"scene '{scene.name}'")


def _backend(backend: Union[None, str, Backend],
             chips: Optional[Sequence[str]]) -> Backend:
    """The backend ``compile_scene`` compiles for."""
    if chips is not None:
        if backend != "gpu":
            raise ArgumentError("yasps.compile: chips=... compiles GPU "
                                "kernels ahead; pass backend='gpu' with it")
        if isinstance(chips, str) or not chips:
            raise ArgumentError("yasps.compile: chips must be a non-empty "
                                "list of compute capabilities such as "
                                f"['sm_90'], got {chips!r}")
        return GpuBackend(cpu_backend(), chips=list(chips))
    if backend is None:
        return current()
    if backend == "cpu":
        return cpu_backend()
    if backend == "gpu":
        return gpu_backend()
    if isinstance(backend, str):
        raise ArgumentError("yasps.compile: backend must be 'cpu', 'gpu' or "
                            f"a backend object, got {backend!r}")
    return backend


def compile_scene(scene: Scene, also: Sequence[Attribute] = (),
                  progress: bool = True,
                  backend: Union[None, str, Backend] = None,
                  contact: Any = None, store: bool = False,
                  chips: Optional[Sequence[str]] = None) -> CompileSummary:
    """Compiles (or loads from the caches) every kernel that evaluating
    ``scene``'s energy and assembling its Newton system need (progressive
    projection's per-size projections included), and those of the
    attributes ``also`` (world positions, say) and of ``contact`` (a
    :class:`yasps.contact.Contact`: its force queries), on ``backend``
    ("cpu", "gpu" or a backend object; default: the current one). After
    it, stepping the scene makes no compiler request. With ``progress``, a
    progress bar over kernels while it works and a summary line on stderr
    when anything was compiled.

    Ahead of time: with ``store``, every kernel is also written into the
    kernel store (:mod:`yasps.compiler.store`), from which an installation
    without the compiler runs the scene; ``backend="gpu", chips=[...]``
    compiles the GPU kernels for those compute capabilities ("sm_90";
    "host" for the stand-in driver of the tests) into the store, with the
    CPU kernels the GPU backend's host side needs, on a machine that needs
    no GPU. Raises IRError for an energy the compiler cannot
    differentiate."""
    start = time.perf_counter()
    _check_also(scene, also)
    backend = _backend(backend, chips)
    recording = kernel_store.storing() if store or chips is not None \
        else nullcontext()
    with recording:
        return _compile(scene, also, progress, backend, contact, start)


def _compile(scene: Scene, also: Sequence[Attribute], progress: bool,
             backend: Backend, contact: Any,
             start: float) -> CompileSummary:
    # kernel_ir keeps the scene's IR: the named attributes' requests share
    # one emission.
    values = [compute_request(a) for a in list(scene.energies) + list(also)]
    derivatives = assembly_requests(scene, backend)
    extra = list(contact.kernel_requests()) if contact is not None else []
    total = sum(_kernel_count(requests)
                for requests in (values, derivatives, extra))
    with _progress_bar(total, f"compiling {scene.name}", progress) as bar:
        compiled = backend.derivatives.compile_ahead(derivatives, bar.update)
        # Their sizes are read off the derivative kernels compiled above.
        projectors = projector_requests(scene, backend)
        total += len(projectors)
        bar.total = total
        compiled += backend.host.compile_ahead(projectors, bar.update)
        compiled += backend.compile_ahead(values, bar.update)
        compiled += backend.compile_ahead(extra, bar.update)
    summary = CompileSummary(scene.name, total, compiled,
                             time.perf_counter() - start)
    if progress and compiled:
        print(summary.line(), file=sys.stderr)
    return summary


def _kernel_count(requests: Sequence[KernelRequest]) -> int:
    """Distinct kernels of ``requests`` (per scene IR and pipeline)."""
    return sum(len({p for paths in groups for p in paths})
               for groups in grouped_requests(requests).values())


class _NoBar:
    total = 0

    def __enter__(self) -> "_NoBar":
        return self

    def __exit__(self, *exc) -> None:
        pass

    def update(self, n: int = 1) -> None:
        pass


def _progress_bar(total: int, description: str, shown: bool):
    """A tqdm bar over ``total`` kernels on stderr (cleared when done), or
    none: without ``shown``, or where tqdm is not installed (the package
    itself needs only NumPy)."""
    try:
        from tqdm import tqdm
    except ImportError:
        shown = False
    if not shown:
        return _NoBar()
    return tqdm(total=total, unit="kernel", desc=description, leave=False,
                file=sys.stderr)
