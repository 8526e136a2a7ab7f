"""Locates the compiled extension module ``_yasps_native``.

An installed package (``pip install .``) has the extension next to this file.
In a source checkout the extension lives in the CMake build tree, by default
``<repo>/build/python/yasps``; ``YASPS_BUILD_DIR`` names another build tree.
"""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path
from types import ModuleType

_MODULE = "yasps._yasps_native"


def _from_build_tree() -> ModuleType | None:
    repo = Path(__file__).resolve().parent.parent.parent
    build = Path(os.environ.get("YASPS_BUILD_DIR", repo / "build"))
    for candidate in sorted((build / "python" / "yasps").glob("_yasps_native*")):
        spec = importlib.util.spec_from_file_location(_MODULE, candidate)
        if spec is None or spec.loader is None:
            continue
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    return None


def load() -> ModuleType:
    """Returns the extension module, or raises ImportError saying how to build it."""
    try:
        from . import _yasps_native  # type: ignore[attr-defined]

        return _yasps_native
    except ImportError:
        pass
    module = _from_build_tree()
    if module is None:
        raise ImportError(
            "the yasps compiler extension (_yasps_native) was not found: "
            "build it with 'bash scripts/build.sh' (or set YASPS_BUILD_DIR to "
            "your build tree), or install the package with 'pip install .'")
    return module
