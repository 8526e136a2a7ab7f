"""CUDA code generation for a scene's kernels.

The same loop kernels the CPU runs are lowered through MLIR's GPU and NVVM
dialects (one GPU thread per instance) and serialised into a cubin per
compute capability, plus PTX for newer devices. Compiling needs the CUDA
toolkit's ``ptxas`` but no GPU or driver::

    kernels = yasps.gpu.compile_scene(scene)
    cubin = kernels.binaries[("sm_90", "cubin")]

``yasps.runtime.gpu`` loads and launches them on a device (the GPU backend,
see ``yasps.runtime.backend``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

from .. import config
from .._native import has_compiler
from ..ir import kernel_ir, text_and_locations
from . import store
from .errors import native, translated
from .params import (KernelArgument, Param, attribute_param_records,
                     attribute_params, kernel_arguments)
from .pipelines import differentiation_pipeline
from .specs import scene_kernel_paths
from ..frontend.errors import NameLookupError

#: Compute capabilities compiled by default: Ampere (A100) and Hopper (H100).
DEFAULT_CHIPS: Tuple[str, ...] = ("sm_80", "sm_90")


@dataclass
class GpuKernel:
    """One generated CUDA kernel."""
    attribute: str          #: scene-relative path of the attribute it evaluates
    name: str               #: the entry point's symbol in the binaries
    threads_per_block: int  #: launch with ceil(count / this) blocks
    arguments: List[KernelArgument]  #: its buffers, as on the CPU
    #: cuLaunchKernel's parameters in order: ("index", i) is argument i of the
    #: loop kernel (0: first instance, 1: end), ("buffer", i) a memref
    #: descriptor of buffer argument i (pointer, pointer, 0, size, 1), and
    #: ("constant", v) the i64 v.
    launch_params: List[Tuple[str, int]]
    rows: int = 0  #: rows of each instance's value (column-major in memory)
    cols: int = 0  #: its columns
    #: how a projected Hessian's kernel projects ("full", "reduced",
    #: "separate"), "" for other kernels
    projection: str = ""


@dataclass
class GpuKernels:
    """Kernels of a scene and their binaries, keyed by (chip, format)."""
    kernels: List[GpuKernel]
    binaries: Dict[Tuple[str, str], bytes]
    stats: Dict[str, object] = field(default_factory=dict)
    #: the IR and pipeline they were compiled from (for params())
    source: Tuple[str, str, str] = ("", "", "")
    #: for a set gathered from several compilations: the library that holds
    #: each kernel's binaries, by attribute (empty: all are in this one)
    libraries: Dict[str, "GpuKernels"] = field(default_factory=dict)

    def library(self, attribute: str) -> "GpuKernels":
        """The compiled library whose binaries hold ``attribute``'s kernel."""
        return self.libraries.get(attribute, self)

    def kernel(self, attribute: str) -> GpuKernel:
        """The kernel evaluating ``attribute`` (a scene-relative path)."""
        for k in self.kernels:
            if k.attribute == attribute:
                return k
        raise NameLookupError(f"no GPU kernel for {attribute}")

    def params(self, attribute: str) -> List[Param]:
        """The local parameter groups of a derivative kernel (asked of the
        compiler: the binaries do not carry them)."""
        ir, pipeline, name = self.source
        return attribute_params(ir, pipeline, [attribute], name)[0]


def compile_scene(scene, attributes: Optional[Sequence[str]] = None,
                  chips: Sequence[str] = DEFAULT_CHIPS,
                  keep_ptx: bool = True) -> GpuKernels:
    """Compiles CUDA kernels for ``attributes`` (scene-relative paths such as
    ``"@m::@tets::@elastic__grad"``; default: ``scene_kernel_paths``).
    Binaries are cached on disk with the CPU objects (``config.cache_dir``).
    Raises ``IRError`` if lowering or ptxas fails."""
    paths = list(attributes) if attributes is not None \
        else scene_kernel_paths(scene)
    pipeline = differentiation_pipeline() if scene.minimizeTargets else ""
    return compile_ir(kernel_ir(scene), paths, scene.name,
                      pipeline, chips, keep_ptx)


def compile_ir(ir: str, paths: Sequence[str], name: str, pipeline: str = "",
               chips: Sequence[str] = DEFAULT_CHIPS,
               keep_ptx: bool = True) -> GpuKernels:
    """``compile_scene`` for IR that is already emitted (``name`` labels
    diagnostics)."""
    text, locations = text_and_locations(ir)
    if not has_compiler():
        return _stored(ir, text, paths, name, pipeline)
    if store.recording():
        # A store holds each kernel once: those an earlier request of the
        # recording stored for these chips are read back, not compiled.
        unique = list(dict.fromkeys(paths))
        done = [p for p in unique if store.has_gpu(text, pipeline, p, chips)]
        if done:
            todo = [p for p in unique if p not in done]
            parts = [_stored(ir, text, done, name, pipeline)]
            if todo:
                parts.append(compile_ir(ir, todo, name, pipeline, chips,
                                        keep_ptx))
            return _merged(parts, (ir, pipeline, name))
    with translated("compile_gpu"):
        library = native().compile_gpu(text, list(paths), list(chips),
                                       keep_ptx, config.cache_dir or "",
                                       name, pipeline, locations)
    if store.recording():
        params = [native_params(ir, pipeline, k["attribute"], name)
                  for k in library.kernels]
        store.store_gpu(library, text, pipeline, params)
    kernels = [_kernel(k) for k in library.kernels]
    binaries = {(chip, fmt): data for chip, fmt, data in library.binaries}
    return GpuKernels(kernels, binaries, dict(library.stats),
                      (ir, pipeline, name))


def _kernel(fields: dict) -> GpuKernel:
    """A GpuKernel from the bindings' dict of a kernel (or a stored one)."""
    return GpuKernel(fields["attribute"], fields["name"],
                     fields["threads_per_block"],
                     kernel_arguments(fields["arguments"]),
                     [tuple(p) for p in fields["launch_params"]],
                     fields["rows"], fields["cols"], fields["projection"])


def native_params(ir: str, pipeline: str, path: str, name: str
                  ) -> List[List[str]]:
    """The parameter records of a kernel as the compiler gives them (for
    the store): empty where the pipeline gives the attribute none."""
    return attribute_param_records(ir, pipeline, [path], name)[0]


def _merged(parts: Sequence[GpuKernels],
            source: Tuple[str, str, str]) -> GpuKernels:
    """One set of the kernels of several sets (each kernel's binaries stay
    in the library that holds them)."""
    libraries = {k.attribute: part.library(k.attribute)
                 for part in parts for k in part.kernels}
    return GpuKernels([k for part in parts for k in part.kernels], {},
                      {"from_disk": all(p.stats.get("from_disk")
                                        for p in parts)}, source, libraries)


def _stored(ir: str, text: str, paths: Sequence[str], name: str,
            pipeline: str) -> GpuKernels:
    """The kernels of ``paths`` from the kernel store (no compiler here):
    one set over the stored libraries that hold them."""
    found = store.load_gpu(text, pipeline, list(dict.fromkeys(paths)), name)
    by_library: Dict[str, GpuKernels] = {}
    for record in found:
        library = by_library.get(record.library)
        if library is None:
            library = by_library[record.library] = GpuKernels(
                [], store.gpu_binaries(record.library),
                {"from_disk": True, "from_store": True,
                 "key": record.library}, (ir, pipeline, name))
        library.kernels.append(_kernel(record.fields))
    if len(by_library) == 1:
        return next(iter(by_library.values()))
    return GpuKernels([k for lib in by_library.values() for k in lib.kernels],
                      {}, {"from_disk": True, "from_store": True},
                      (ir, pipeline, name),
                      {k.attribute: lib for lib in by_library.values()
                       for k in lib.kernels})
