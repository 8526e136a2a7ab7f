"""Kernels compiled ahead of time, found again without a compiler.

A machine without LLVM and MLIR (a GPU machine that carries only the
runtime) cannot compile a scene's kernels; it runs kernels that a machine
with the compiler wrote into a *kernel store*: a folder of

- ``kernels/<key>.json``: one record per kernel, keyed by what identifies
  it without compiling anything (the scene's kernel IR without its
  locations, the pass pipeline, the attribute's path, and for CPU kernels
  the settings that change their code), with what running it needs (its
  arguments, shape, output type, local parameters, entry point) and the
  library that holds its code;
- ``libraries/<name>.so``: CPU kernels as a shared library, linked from the
  compiler's cached objects by the system's C compiler and loaded with
  ``dlopen`` (no JIT);
- ``libraries/<name>.<chip>.<format>``: GPU binaries (cubins, PTX, the
  stand-in driver's host images).

``yasps.compile(scene, store=True)`` (and ``backend="gpu", chips=[...]``
for a GPU elsewhere) writes the records, and so does every compile
request of a process run with ``YASPS_STORE_KERNELS=1`` (with
``YASPS_STORE_CHIPS=sm_90`` each also for those GPU chips); every compile
request of a process without the compiler (or with
``YASPS_NO_COMPILER=1``) reads them, and a kernel missing from the store
raises
:class:`~yasps.errors.KernelNotCompiledError` naming it. The store is
``$YASPS_KERNEL_STORE``, else ``store`` in the kernel cache folder.
"""

from __future__ import annotations

import ctypes
import hashlib
import json
import os
import shutil
import subprocess
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import (Any, Dict, Iterable, Iterator, List, Optional, Sequence,
                    Tuple)

from .. import config
from ..errors import ArgumentError, KernelNotCompiledError

#: Bumped when a record's fields or a library's layout change: a store of
#: another format is never read.
STORE_FORMAT = "yasps-store-1"


#: How many ``storing()`` blocks are open: while any is, every kernel
#: compiled (or found in this process's caches) is also written to the
#: store.
_recording = 0


@contextmanager
def storing() -> Iterator[None]:
    """Within it, the compile requests of this process also record their
    kernels in the store."""
    global _recording
    _recording += 1
    try:
        yield
    finally:
        _recording -= 1


def recording() -> bool:
    """Whether compile requests record their kernels now: in a
    ``storing()`` block, or anywhere in a process run with
    ``YASPS_STORE_KERNELS=1`` (which also records what a script computes
    before ``yasps.compile``: a Contact's world positions when it is made,
    on the scene as it was then)."""
    return _recording > 0 or \
        os.environ.get("YASPS_STORE_KERNELS", "") not in ("", "0")


def mirrored_chips() -> List[str]:
    """The GPU chips (``YASPS_STORE_CHIPS``, e.g. "sm_90 host") for which a
    recording process also compiles every CPU kernel request, so that a run
    on the GPU backend elsewhere finds the kernels of the evaluations the
    script makes outside ``yasps.compile``."""
    return os.environ.get("YASPS_STORE_CHIPS", "").replace(",", " ").split()


def store_dir() -> Optional[Path]:
    """The kernel store's folder: ``$YASPS_KERNEL_STORE``, else ``store``
    in ``config.cache_dir``; None when neither is set."""
    named = os.environ.get("YASPS_KERNEL_STORE")
    if named:
        return Path(named)
    if config.cache_dir:
        return Path(config.cache_dir) / "store"
    return None


def _digest(parts: Iterable[str]) -> str:
    hash = hashlib.sha256()
    for part in parts:
        hash.update(part.encode())
        hash.update(b"\0")
    return hash.hexdigest()


def cpu_key(text: str, pipeline: str, path: str) -> str:
    """The record key of a CPU kernel: the IR (without locations), the
    pipeline, the attribute, and the settings its code depends on."""
    return "cpu-" + _digest([STORE_FORMAT, text, pipeline, path,
                             str(config.opt_level), str(config.simd_lanes)])


def gpu_key(text: str, pipeline: str, path: str) -> str:
    """The record key of a GPU kernel (its binaries hold every chip)."""
    return "gpu-" + _digest([STORE_FORMAT, text, pipeline, path])


def _write_atomically(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f"{path.name}.tmp.{os.getpid()}")
    temporary.write_bytes(data)
    os.replace(temporary, path)


def _read_record(key: str) -> Optional[Dict[str, Any]]:
    folder = store_dir()
    if folder is None:
        return None
    try:
        record = json.loads((folder / "kernels" / f"{key}.json").read_text())
    except (OSError, ValueError):
        return None
    return record if record.get("format") == STORE_FORMAT else None


def missing(kind: str, path: str, name: str) -> KernelNotCompiledError:
    folder = store_dir()
    where = f"the kernel store {folder}" if folder else \
        "a kernel store (none is set: YASPS_KERNEL_STORE or config.cache_dir)"
    how = ("yasps.compile(scene, backend='gpu', chips=[...])"
           if kind == "GPU" else "yasps.compile(scene, store=True)")
    what = f"the {kind} kernel" if kind else "the kernel"
    return KernelNotCompiledError(
        f"scene '{name}': {what} of {path} is not in {where}, and "
        "this installation has no compiler: compile it ahead on a machine "
        f"with the compiler ({how}) and carry the store here")


# ------------------------------------------------------------------ CPU


#: The instruction-set flags (as /proc/cpuinfo spells them) that decide
#: whether CPU kernels run on a machine.
_SIMD_FLAGS = ("sse4_2", "popcnt", "avx", "avx2", "fma", "bmi2", "f16c",
               "movbe", "avx512f", "avx512bw", "avx512dq", "avx512vl")

#: The flags of the x86-64 levels one may compile for (config.cpu_target).
_LEVELS = {"x86-64-v2": ("sse4_2", "popcnt"),
           "x86-64-v3": ("sse4_2", "popcnt", "avx", "avx2", "fma", "bmi2",
                         "f16c", "movbe")}
_LEVELS["x86-64-v4"] = _LEVELS["x86-64-v3"] + (
    "avx512f", "avx512bw", "avx512dq", "avx512vl")


def host_flags() -> Tuple[str, ...]:
    """This machine's instruction-set flags among those that matter."""
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return ()
    for line in text.splitlines():
        if line.startswith("flags"):
            present = set(line.split(":", 1)[1].split())
            return tuple(f for f in _SIMD_FLAGS if f in present)
    return ()


def _required_flags() -> Tuple[str, ...]:
    """What the CPU kernels compiled now need of a machine: the named
    level's flags, else (compiled for this host) this host's."""
    if config.cpu_target:
        return _LEVELS.get(config.cpu_target, ())
    return host_flags()


def _linker() -> str:
    for candidate in (os.environ.get("CC"), "cc", "clang-22", "gcc"):
        if candidate and shutil.which(candidate):
            return candidate
    raise ArgumentError("storing CPU kernels links them into a shared "
                        "library and needs a C compiler (cc, clang or gcc; "
                        "$CC names another)")


def store_cpu(library: Any, text: str, pipeline: str,
              paths: Sequence[str]) -> int:
    """Records the CPU kernels of ``paths`` from a compiled ``library`` (the
    compiler's ``CpuLibrary``) in the store, their code linked into one
    shared library. Returns how many records it wrote."""
    folder = store_dir()
    if folder is None:
        raise ArgumentError("no kernel store: set YASPS_KERNEL_STORE or "
                            "yasps.config.cache_dir")
    if not config.cache_dir:
        raise ArgumentError("storing CPU kernels links the compiler's cached "
                            "objects: it needs config.cache_dir")
    objects = {path: (symbol, str(Path(config.cache_dir) / f"{key}.o"))
               for path, symbol, key in library.objects}
    missing = [p for p in paths if not Path(objects[p][1]).exists()]
    if missing:
        raise ArgumentError(f"the object of {missing[0]}'s kernel is not in "
                            f"the kernel cache {config.cache_dir}")
    files = sorted({objects[p][1] for p in paths})
    name = "cpu-" + _digest(files)
    shared = folder / "libraries" / f"{name}.so"
    if not shared.exists():
        shared.parent.mkdir(parents=True, exist_ok=True)
        temporary = shared.with_name(f"{shared.name}.tmp.{os.getpid()}")
        subprocess.run([_linker(), "-shared", "-o", str(temporary), *files,
                        "-lm"], check=True, capture_output=True)
        os.replace(temporary, shared)
    for path in paths:
        rows, cols = library.shape(path)
        arguments = dict(library.kernels)[path]
        record = {"format": STORE_FORMAT, "attribute": path,
                  "library": shared.name,
                  "cpu": config.cpu_target or "host",
                  "requires": list(_required_flags()),
                  "symbol": "_mlir_" + objects[path][0],
                  "codes": library.entry(path)[1],
                  "arguments": [(kind.name, p) for kind, p in arguments],
                  "rows": rows, "cols": cols,
                  "projection": library.projection(path),
                  "out_type": library.out_type(path),
                  "params": [list(p) for p in library.params(path)]}
        _write_atomically(folder / "kernels" /
                          f"{cpu_key(text, pipeline, path)}.json",
                          json.dumps(record).encode())
    return len(paths)


#: Shared libraries loaded by this process, by file: they stay loaded, as
#: JIT-compiled kernels do.
_loaded: Dict[str, ctypes.CDLL] = {}


class StoredCpuLibrary:
    """CPU kernels loaded from the store: what the compiler's
    ``CpuLibrary`` offers the runtime (kernels, shapes, entry points)."""

    def __init__(self, records: Dict[str, Dict[str, Any]]):
        self._records = records
        self.stats = {"from_memory": False, "from_disk": True,
                      "from_source": True, "from_store": True,
                      "lower_seconds": 0.0, "codegen_seconds": 0.0,
                      "key": _digest(sorted(records))}

    @property
    def kernels(self) -> List[Tuple[str, List[Tuple[str, str]]]]:
        return [(path, [tuple(a) for a in r["arguments"]])
                for path, r in self._records.items()]

    def shape(self, path: str) -> Tuple[int, int]:
        return self._records[path]["rows"], self._records[path]["cols"]

    def projection(self, path: str) -> str:
        return self._records[path]["projection"]

    def out_type(self, path: str) -> str:
        return self._records[path]["out_type"]

    def params(self, path: str) -> List[List[str]]:
        return self._records[path]["params"]

    def entry(self, path: str) -> Tuple[int, str]:
        record = self._records[path]
        folder = store_dir()
        assert folder is not None  # records were read from it
        file = str(folder / "libraries" / record["library"])
        shared = _loaded.get(file)
        if shared is None:
            shared = _loaded[file] = ctypes.CDLL(file, mode=os.RTLD_LOCAL)
        function = getattr(shared, record["symbol"])
        address = ctypes.cast(function, ctypes.c_void_p).value
        assert address is not None
        return address, record["codes"]


def load_cpu(text: str, pipeline: str, paths: Sequence[str],
             name: str) -> StoredCpuLibrary:
    """The stored CPU kernels of ``paths``; KernelNotCompiledError naming
    the first that is not stored."""
    records = {}
    flags = set(host_flags())
    for path in paths:
        record = _read_record(cpu_key(text, pipeline, path))
        if record is None:
            raise missing("CPU", path, name)
        lacking = [f for f in record["requires"] if f not in flags]
        if lacking:
            raise KernelNotCompiledError(
                f"scene '{name}': the stored CPU kernel of {path} was "
                f"compiled for {record['cpu']}, which needs "
                f"{', '.join(lacking)}, and this CPU lacks it: compile it "
                "ahead with yasps.config.cpu_target = 'x86-64-v3' (or "
                "YASPS_CPU_TARGET) for machines like this one")
        records[path] = record
    return StoredCpuLibrary(records)


# ------------------------------------------------------------------ GPU


@dataclass
class StoredGpuKernel:
    """A GPU kernel's record: the fields of ``GpuLibrary.kernels``' dicts,
    its local parameters and its library."""
    fields: Dict[str, Any]
    params: List[List[str]]
    library: str


def store_gpu(library: Any, text: str, pipeline: str,
              params: Sequence[Sequence[Sequence[str]]]) -> int:
    """Records the kernels of a compiled GPU ``library`` (the compiler's
    ``GpuLibrary``) and its binaries in the store; ``params`` are each
    kernel's local parameter records, in the library's kernel order."""
    folder = store_dir()
    if folder is None:
        raise ArgumentError("no kernel store: set YASPS_KERNEL_STORE or "
                            "yasps.config.cache_dir")
    binaries = list(library.binaries)
    name = "gpu-" + _digest([library.stats["key"]] +
                            [f"{chip}.{fmt}" for chip, fmt, _ in binaries])
    for chip, fmt, data in binaries:
        _write_atomically(folder / "libraries" / f"{name}.{chip}.{fmt}", data)
    _write_atomically(folder / "libraries" / f"{name}.json", json.dumps(
        [(chip, fmt) for chip, fmt, _ in binaries]).encode())
    kernels = library.kernels
    for kernel, kernel_params in zip(kernels, params):
        fields = dict(kernel)
        fields["arguments"] = [(kind.name, p) for kind, p in
                               kernel["arguments"]]
        fields["launch_params"] = [list(p) for p in kernel["launch_params"]]
        record = {"format": STORE_FORMAT, "kernel": fields,
                  "params": [list(p) for p in kernel_params],
                  "library": name}
        key = gpu_key(text, pipeline, kernel["attribute"])
        _write_atomically(folder / "kernels" / f"{key}.json",
                          json.dumps(record).encode())
    return len(kernels)


def load_gpu(text: str, pipeline: str, paths: Sequence[str],
             name: str) -> List[StoredGpuKernel]:
    """The stored GPU kernels of ``paths``; KernelNotCompiledError naming
    the first that is not stored."""
    found = []
    for path in paths:
        record = _read_record(gpu_key(text, pipeline, path))
        if record is None:
            raise missing("GPU", path, name)
        found.append(StoredGpuKernel(record["kernel"], record["params"],
                                     record["library"]))
    return found


def has_gpu(text: str, pipeline: str, path: str,
            chips: Sequence[str]) -> bool:
    """Whether the store holds the GPU kernel of ``path`` for every one of
    ``chips``."""
    record = _read_record(gpu_key(text, pipeline, path))
    folder = store_dir()
    if record is None or folder is None:
        return False
    try:
        formats = json.loads((folder / "libraries" /
                              f"{record['library']}.json").read_text())
    except (OSError, ValueError):
        return False
    return set(chips) <= {chip for chip, _ in formats}


def gpu_binaries(library: str) -> Dict[Tuple[str, str], bytes]:
    """The binaries of a stored GPU library, by (chip, format)."""
    folder = store_dir()
    assert folder is not None
    formats = json.loads((folder / "libraries" / f"{library}.json")
                         .read_text())
    return {(chip, fmt): (folder / "libraries" / f"{library}.{chip}.{fmt}")
            .read_bytes() for chip, fmt in formats}


def params_key(text: str, pipeline: str, path: str) -> str:
    """The record key of an attribute's local parameters (what the
    compiler's ``attribute_params`` answers)."""
    return "params-" + _digest([STORE_FORMAT, text, pipeline, path])


def store_params(text: str, pipeline: str, paths: Sequence[str],
                 records: Sequence[Sequence[Sequence[str]]]) -> None:
    """Records the compiler's ``attribute_params`` answer for ``paths``."""
    folder = store_dir()
    if folder is None:
        return
    for path, params in zip(paths, records):
        record = {"format": STORE_FORMAT, "attribute": path,
                  "params": [list(p) for p in params]}
        _write_atomically(folder / "kernels" /
                          f"{params_key(text, pipeline, path)}.json",
                          json.dumps(record).encode())


def stored_params(text: str, pipeline: str, path: str
                  ) -> Optional[List[List[str]]]:
    """The local parameter records of ``path``: recorded as such, else
    those of a stored kernel of it (CPU or GPU); None if neither is."""
    for key in (params_key(text, pipeline, path),
                cpu_key(text, pipeline, path), gpu_key(text, pipeline, path)):
        record = _read_record(key)
        if record is not None:
            return record["params"]
    return None
