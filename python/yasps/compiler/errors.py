"""The compiler's bindings and how their failures reach Python."""

from __future__ import annotations

from collections import Counter
from contextlib import contextmanager
from types import ModuleType
from typing import Dict, Iterator

from .._native import compiler_module
from ..frontend.errors import IRError


def native() -> ModuleType:
    """The compiler's extension module (links MLIR)."""
    return compiler_module()


_invocations: Counter = Counter()


def invocations() -> Dict[str, int]:
    """How often this process asked the C++ compiler for something, by
    request (compile_cpu, compile_gpu, attribute_params, run_pipeline,
    verify). A compile request found by its disk record parses nothing, and
    the requests on a scene the compiler has differentiated already start
    from that (``compiler.cpu.requests_lowered`` counts the CPU requests
    that parsed and lowered their scene)."""
    return dict(_invocations)


class MissingAttributeError(IRError):
    """A kernel was requested for an attribute that does not exist after the
    pass pipeline; ``symbol`` is its scene-relative path."""

    def __init__(self, message: str, symbol: str):
        super().__init__(message)
        self.symbol = symbol


@contextmanager
def translated(request: str) -> Iterator[None]:
    """Counts one ``request`` to the compiler and re-raises its exceptions
    as yasps' own."""
    module = native()
    _invocations[request] += 1
    try:
        yield
    except getattr(module, "MissingAttributeError", ()) as err:
        raise MissingAttributeError(str(err), err.symbol) from None
    except module.IRError as err:
        raise IRError(str(err)) from None
