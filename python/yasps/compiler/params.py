"""Typed views of the metadata the compiler attaches to kernels: the
arguments a kernel takes and the local parameters of a derivative kernel.
This module is the one decoder of the bindings' records."""

from __future__ import annotations

import enum
import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, List, Optional, Sequence, Tuple, Union

from .. import config
from .._native import has_compiler
from ..ir import text_and_locations
from . import store
from .errors import native, translated
from ..frontend.errors import ArgumentError

class ArgumentKind(enum.Enum):
    """Kinds of kernel arguments: the dialect's ``KernelArgKind``, by the
    names the bindings give its values. Defined here, not taken from the
    compiler's bindings, so that kernels compiled ahead of time
    (``yasps.compiler.store``) are described without the compiler."""
    out = "out"                  #: the output
    attr = "attr"                #: a stored attribute's values
    conn = "conn"                #: a connectivity's indices
    offsets = "offsets"          #: a union's member offsets
    dof_offsets = "dof_offsets"  #: the targets' first DoFs


@dataclass(frozen=True)
class KernelArgument:
    """One buffer a kernel reads or writes, in launch order."""
    kind: ArgumentKind
    path: str  #: scene-relative symbol it comes from ("" for dof_offsets/out)


def argument_kind(kind: Any) -> ArgumentKind:
    """The ArgumentKind of a bindings' ``KernelArgKind`` value or of its
    name (as a stored kernel records it)."""
    name = kind if isinstance(kind, str) else getattr(kind, "name", None)
    try:
        return ArgumentKind(name)
    except ValueError:
        raise ArgumentError(f"unknown kernel argument kind {kind!r}") from None


def kernel_arguments(record: Sequence[Tuple[Any, str]]) -> List[KernelArgument]:
    """The typed arguments of a kernel from (kind, path) pairs, each kind a
    bindings' ``KernelArgKind`` or its name."""
    return [KernelArgument(argument_kind(kind), path) for kind, path in record]


@dataclass(frozen=True)
class ReadParam:
    """The entries of a minimisation target read directly."""
    target: str  #: the target's path


@dataclass(frozen=True)
class JoinParam:
    """The parameters of the instance a JOIN gathers at ``slot``."""
    connectivity: str  #: the connectivity's name on the energy's owner
    slot: int          #: which of its indices
    base: str          #: the path of the attribute whose parameters these are
    width: int         #: parameters per slot (the base's, padded)


@dataclass(frozen=True)
class UnionParam:
    """The parameters of the union member an instance belongs to."""
    union: str      #: the union's path
    attribute: str  #: the attribute's name on every member
    width: int      #: parameters per slot (the widest member's)


Param = Union[ReadParam, JoinParam, UnionParam]


def decode_param(fields: Sequence[str]) -> Param:
    """One parameter group from the bindings' record of ``yasps.params``."""
    kind = fields[0]
    if kind == "read":
        return ReadParam(fields[1])
    if kind == "join":
        return JoinParam(fields[1], int(fields[2]), fields[3], int(fields[4]))
    if kind == "union":
        return UnionParam(fields[1], fields[2], int(fields[3]))
    raise ArgumentError(f"unknown parameter group kind {kind!r}")


def decode_params(records: Sequence[Sequence[str]]) -> List[Param]:
    """Every parameter group of a derivative kernel, in order."""
    return [decode_param(r) for r in records]


def _record_path(ir: str, pipeline: str, paths: Sequence[str]
                 ) -> Optional[Path]:
    """Where the answer to an attribute_params request is kept on disk:
    named by the request and by this build of the compiler (a rebuilt one
    may differentiate otherwise), as the kernels' records are; None without
    a cache directory."""
    if not config.cache_dir:
        return None
    module_file = native().__file__
    assert module_file is not None  # an extension module comes from a file
    library = Path(module_file)
    built = library.stat()
    text = "\0".join([ir, pipeline, *paths, str(library), str(built.st_size),
                      str(built.st_mtime_ns)])
    key = hashlib.sha256(text.encode()).hexdigest()
    return Path(config.cache_dir) / f"{key}.params.json"


def attribute_param_records(ir: str, pipeline: str, paths: Sequence[str],
                            name: str) -> List[List[List[str]]]:
    """The bindings' records of ``attribute_params``: for a runtime-only
    installation, from the kernel store."""
    text, locations = text_and_locations(ir)
    if not has_compiler():
        found = []
        for path in paths:
            stored = store.stored_params(text, pipeline, path)
            if stored is None:
                raise store.missing("", path, name)
            found.append(stored)
        return found
    records = _native_param_records(text, locations, pipeline, paths, name)
    if store.recording():
        store.store_params(text, pipeline, paths, records)
    return records


def _native_param_records(text: str, locations: str, pipeline: str,
                          paths: Sequence[str],
                          name: str) -> List[List[List[str]]]:
    """The compiler's answer, kept on disk by the request."""
    record = _record_path(text, pipeline, paths)
    if record is not None and record.exists():
        try:
            return json.loads(record.read_text())
        except (OSError, ValueError, TypeError):
            pass  # a damaged record is made again
    with translated("attribute_params"):
        records = native().attribute_params(text, pipeline, list(paths),
                                            name, locations)
    if record is not None:
        record.parent.mkdir(parents=True, exist_ok=True)
        temporary = record.with_suffix(f".tmp.{os.getpid()}")
        temporary.write_text(json.dumps(records))
        os.replace(temporary, record)
    return records


def attribute_params(ir: str, pipeline: str, paths: Sequence[str],
                     name: str) -> List[List[Param]]:
    """The local parameter groups of each of ``paths`` in the scene ``ir``
    (a ``kernel_ir``) after ``pipeline``; an empty list for an attribute
    without them. Answers are kept on disk, so that a warm start parses
    nothing; the compiler keeps the scene after the pipeline for the kernel
    requests that follow."""
    return [[decode_param(fields) for fields in r]
            for r in attribute_param_records(ir, pipeline, paths, name)]
