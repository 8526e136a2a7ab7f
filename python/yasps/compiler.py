"""Access to the C++ compiler: verification and pass pipelines on yasps IR."""

from __future__ import annotations

from functools import lru_cache
from types import ModuleType

from . import _native
from .errors import IRError


@lru_cache(maxsize=None)
def _module() -> ModuleType:
    return _native.load()


def verify(ir: str, name: str = "<yasps>") -> None:
    """Parses and verifies yasps IR with the C++ dialect.

    Raises:
        IRError: with the compiler's diagnostics if the IR is invalid.
    """
    native = _module()
    try:
        native.verify(ir, name)
    except native.IRError as err:
        raise IRError(str(err)) from None


def run_pipeline(ir: str, pipeline: str, name: str = "<yasps>") -> str:
    """Verifies ``ir``, runs a textual pass pipeline on it and returns the result.

    ``pipeline`` is what ``yasps-opt`` takes, without dashes and comma
    separated, e.g. ``"yasps-inline-reads,canonicalize,cse"``; an empty string
    only parses, verifies and prints.

    Raises:
        IRError: if the IR is invalid or a pass fails.
        ValueError: if the pipeline does not parse.
    """
    native = _module()
    try:
        return native.run_pipeline(ir, pipeline, name)
    except native.IRError as err:
        raise IRError(str(err)) from None
