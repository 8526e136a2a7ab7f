"""The compiler's bindings and how their failures reach Python."""

from __future__ import annotations

from contextlib import contextmanager
from types import ModuleType
from typing import Iterator

from .._native import compiler_module
from ..frontend.errors import IRError


def native() -> ModuleType:
    """The compiler's extension module (links MLIR)."""
    return compiler_module()


class MissingAttributeError(IRError):
    """A kernel was requested for an attribute that does not exist after the
    pass pipeline; ``symbol`` is its scene-relative path."""

    def __init__(self, message: str, symbol: str):
        super().__init__(message)
        self.symbol = symbol


@contextmanager
def translated() -> Iterator[None]:
    """Re-raises the compiler's exceptions as yasps' own."""
    module = native()
    try:
        yield
    except getattr(module, "MissingAttributeError", ()) as err:
        raise MissingAttributeError(str(err), err.symbol) from None
    except module.IRError as err:
        raise IRError(str(err)) from None
