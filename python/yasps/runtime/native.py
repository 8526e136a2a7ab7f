"""The runtime's bindings (no MLIR)."""

from __future__ import annotations

from types import ModuleType

from .._native import runtime_module


def native() -> ModuleType:
    """The runtime's extension module."""
    return runtime_module()
