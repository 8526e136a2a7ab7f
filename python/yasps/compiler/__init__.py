"""The compiler layer: verification and pass pipelines on yasps IR, the
differentiation pipeline, derivative kernel specs, typed kernel metadata,
and compilation (CPU JIT, CUDA binaries) with its in-memory cache; the
on-disk cache is the C++ compiler's.

Failures of the C++ compiler arrive as :class:`IRError`; one whose cause is
an attribute that does not exist after the pipeline (an energy that depends
on no minimisation target has no derivatives) as
:class:`MissingAttributeError`, which names the symbol.
"""

from __future__ import annotations

from .._native import has_compiler
from .errors import MissingAttributeError, invocations, native, translated
from ..frontend.errors import IRError


def verify(ir: str, name: str = "<yasps>") -> None:
    """Parses and verifies yasps IR with the C++ dialect.

    Without the compiler (a runtime-only installation) nothing is checked
    here: such an installation runs only scenes whose kernels were compiled
    ahead from verified IR (``yasps.compiler.store``), and any other fails
    at its first kernel with KernelNotCompiledError.

    Raises:
        IRError: with the compiler's diagnostics if the IR is invalid.
    """
    if not has_compiler():
        return
    with translated("verify"):
        native().verify(ir, name)


def run_pipeline(ir: str, pipeline: str, name: str = "<yasps>") -> str:
    """Verifies ``ir``, runs a textual pass pipeline on it and returns the result.

    ``pipeline`` is what ``yasps-opt`` takes, without dashes and comma
    separated, e.g. ``"yasps-inline-reads,canonicalize,cse"``; an empty string
    only parses, verifies and prints.

    Raises:
        IRError: if the IR is invalid or a pass fails.
        ValueError: if the pipeline does not parse.
    """
    with translated("run_pipeline"):
        return native().run_pipeline(ir, pipeline, name)


__all__ = ["IRError", "MissingAttributeError", "invocations", "native",
           "run_pipeline",
           "verify"]
