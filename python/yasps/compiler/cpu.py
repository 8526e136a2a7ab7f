"""CPU kernels: the C++ compiler JIT-compiles them (and caches their objects
on disk); this module keeps the compiled libraries of this process."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from .. import config
from .._native import has_compiler
from ..ir import text_and_locations
from . import store
from .errors import native, translated
from .params import KernelArgument, Param, decode_params, kernel_arguments


@dataclass(frozen=True)
class KernelInfo:
    """What a compiled kernel computes and takes, whatever its target."""
    attribute: str                 #: scene-relative path it evaluates
    arguments: List[KernelArgument]  #: its buffers, in launch order
    rows: int                      #: rows of each instance's value
    cols: int                      #: its columns (column-major in memory)
    projection: str                #: "full"/"reduced"/"separate", or ""
    out_dtype: type = float        #: numpy type of the output buffer


@dataclass
class CpuKernels:
    """Compiled CPU kernels of some attributes and how this request for them
    was served (``stats``: cache hits and compile times)."""
    #: the native library (the compiler extension's object: untyped)
    library: Any
    stats: dict

    @property
    def _info(self) -> Dict[str, KernelInfo]:
        # Kept per library, not per request: a library compiled for a whole
        # scene (yasps.compile) serves every energy's request, and reading
        # its kernel list anew for each took 5 ms of every Newton solve on
        # the README demo.
        return _infos.setdefault(id(self.library), {})

    def kernel(self, path: str) -> KernelInfo:
        """The kernel evaluating ``path``."""
        if path not in self._info:
            arguments = dict(self.library.kernels)[path]
            rows, cols = self.library.shape(path)
            out = self.library.out_type(path)
            self._info[path] = KernelInfo(
                path, kernel_arguments(arguments), rows, cols,
                self.library.projection(path),
                np.float32 if out == "f32" else np.float64)
        return self._info[path]

    def params(self, path: str) -> List[Param]:
        """The local parameter groups of a derivative kernel."""
        return decode_params(self.library.params(path))

    def entry(self, path: str) -> Tuple[int, str]:
        """The kernel of ``path``'s entry point and buffer codes, which the
        runtime launches (``launch_cpu_kernel``); valid while this library
        lives."""
        entries = _entries.setdefault(id(self.library), {})
        found = entries.get(path)
        if found is None:
            found = entries[path] = tuple(self.library.entry(path))
        return found


def kernels_compiled() -> int:
    """How many CPU kernels this process has compiled to machine code: each
    kernel once, whichever requests share it (loads from the memory and
    disk caches are not counted)."""
    return native().cpu_kernels_compiled() if has_compiler() else 0


#: Requests of this process that parsed and lowered their scene.
_lowered = 0


def requests_lowered() -> int:
    """How many CPU compile requests this process served by parsing and
    lowering the scene (the rest were found in memory, or on disk by their
    record, without parsing anything). A warm start lowers nothing."""
    return _lowered


#: Compiled libraries by (IR text, attributes, pipeline, settings; the IR
#: without its location definitions, see ir.KernelIR): a scene
#: evaluated again with the same structure skips parsing, passes and the
#: kernel cache lookup. The IR is ir.kernel_ir's, without the counts of
#: dynamic primitives, so new numbers of collision pairs find their library
#: here.
_libraries: Dict[tuple, Any] = {}

#: What each library's kernels take, by id(library) (libraries stay
#: alive in _libraries for the life of the process).
_infos: Dict[int, Dict[str, KernelInfo]] = {}

#: Each library's kernels' entry points and buffer codes, by id(library):
#: code that lives as long as the library, hence the process.
_entries: Dict[int, Dict[str, Tuple[int, str]]] = {}


#: Requests whose kernels this process has written to the kernel store.
_recorded: set = set()


def _key(ir: str, paths: Sequence[str], pipeline: str) -> tuple:
    return (ir, tuple(paths), pipeline, config.cache_dir, config.opt_level,
            config.simd_lanes, config.cpu_target)


def compile_cpu(ir: str, paths: Sequence[str], name: str,
                pipeline: str = "",
                on_kernel: Optional[Callable[[str], None]] = None
                ) -> CpuKernels:
    """The CPU kernels of ``paths`` (scene-relative attribute paths) of the
    scene in ``ir``, after ``pipeline``; compiled once per process.
    ``on_kernel(path)`` is called as each kernel's machine code is made
    (not for kernels found in a cache), from the compiler's threads."""
    key = _key(ir, paths, pipeline)
    library = _libraries.get(key)
    if library is not None:
        if store.recording() and has_compiler() and key not in _recorded:
            # Once per request: a recording run's Newton iterations ask
            # for the same kernels again and again.
            store.store_cpu(library, text_and_locations(ir)[0], pipeline,
                            paths)
            _recorded.add(key)
        return CpuKernels(library, dict(library.stats, from_memory=True,
                                        from_disk=False, lower_seconds=0.0,
                                        codegen_seconds=0.0))
    text, locations = text_and_locations(ir)
    if not has_compiler():
        # A runtime-only installation: kernels compiled ahead, or a
        # KernelNotCompiledError naming the first that was not.
        library = store.load_cpu(text, pipeline, paths, name)
    else:
        with translated("compile_cpu"):
            library = native().compile_cpu(
                text, list(paths), config.cache_dir or "", config.opt_level,
                name, pipeline, config.simd_lanes, locations, on_kernel,
                config.cpu_target or "")
        if store.recording():
            store.store_cpu(library, text, pipeline, paths)
            _recorded.add(key)
            chips = store.mirrored_chips()
            if chips:
                from .gpu import compile_ir
                compile_ir(ir, paths, name, pipeline, chips=chips,
                           keep_ptx=False)
    _libraries[key] = library
    stats = dict(library.stats)
    if not stats.get("from_source"):
        global _lowered
        _lowered += 1
    return CpuKernels(library, stats)


def compile_cpu_together(ir: str, requests: Sequence[Sequence[str]],
                         name: str, pipeline: str = "",
                         on_kernel: Optional[Callable[[str], None]] = None
                         ) -> CpuKernels:
    """Compiles the kernels of several requests on one scene as one: one
    parse, one lowering, and code generation of all of them spread over
    every core (a request per energy would lower the scene again for each,
    and leave cores idle behind its largest kernel). Each request's later
    ``compile_cpu`` is answered from the result."""
    union = list(dict.fromkeys(p for paths in requests for p in paths))
    kernels = compile_cpu(ir, union, name, pipeline, on_kernel)
    for paths in requests:
        _libraries.setdefault(_key(ir, paths, pipeline), kernels.library)
    return kernels
