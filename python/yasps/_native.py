"""Locates the compiled extension modules.

The bindings mirror the package's layers: the compiler module links MLIR
(parsing, passes, kernel generation, the CPU JIT and GPU code generation);
the runtime module does not (buffers, CUDA devices, the Newton system and its
solvers). An installed package (``pip install .``) has the extensions next to
this file. In a source checkout they live in the CMake build tree, by default
``<repo>/build/python/yasps``; ``YASPS_BUILD_DIR`` names another build tree.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
from functools import lru_cache
from pathlib import Path
from types import ModuleType

#: The extension of the compiler layer and of the runtime layer.
COMPILER_MODULE = "_yasps_compiler"
RUNTIME_MODULE = "_yasps_runtime"


#: The build tree named by ``YASPS_BUILD_DIR``, resolved when yasps is
#: imported: a relative path names a folder of the working directory then,
#: not of whatever folder a later call runs in (a sweep's worker runs each
#: simulation in the run's own folder).
BUILD_DIR = (Path(os.environ["YASPS_BUILD_DIR"]).resolve()
              if os.environ.get("YASPS_BUILD_DIR") else
              Path(__file__).resolve().parent.parent.parent / "build")


def _from_build_tree(name: str) -> ModuleType | None:
    build = BUILD_DIR
    for candidate in sorted((build / "python" / "yasps").glob(name + "*")):
        spec = importlib.util.spec_from_file_location("yasps." + name,
                                                      candidate)
        if spec is None or spec.loader is None:
            continue
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    return None


@lru_cache(maxsize=None)
def load(name: str) -> ModuleType:
    """The extension module ``name``, or ImportError saying how to build it."""
    try:
        return importlib.import_module("yasps." + name)
    except ImportError:
        pass
    module = _from_build_tree(name)
    if module is None:
        raise ImportError(
            f"the yasps extension module {name} was not found: build it with "
            "'bash scripts/build.sh' (or set YASPS_BUILD_DIR to your build "
            "tree), or install the package with 'pip install .'")
    return module


def compiler_module() -> ModuleType:
    """The compiler's bindings (links MLIR)."""
    if os.environ.get("YASPS_NO_COMPILER", "") not in ("", "0"):
        raise ImportError("the compiler is switched off (YASPS_NO_COMPILER)")
    return load(COMPILER_MODULE)


@lru_cache(maxsize=None)
def has_compiler() -> bool:
    """Whether this installation has the compiler's bindings, and
    ``YASPS_NO_COMPILER`` does not switch them off (to run as a
    runtime-only installation would, from the kernel store)."""
    try:
        compiler_module()
    except ImportError:
        return False
    return True


def runtime_module() -> ModuleType:
    """The runtime's bindings (no MLIR)."""
    return load(RUNTIME_MODULE)
