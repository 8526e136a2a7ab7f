"""Evaluating attributes with compiled CPU kernels (``attr.compute()``).

The scene is emitted as IR, the attribute's kernel is compiled (or found in
the in-memory or on-disk cache), and the runtime runs it over all instances of
the attribute's owner with the stored values, connectivities and union
offsets as buffers. Intermediate attributes are never stored.
"""

from __future__ import annotations

from typing import Dict, List, Tuple

import numpy as np

from . import compiler, config
from .attribute import Attribute
from .emit import emit_scene
from .errors import SceneError, ValueUpdateError
from .scene import Connectivity, Entity, PrimitiveUnion, Scene
from .values import from_column_major

#: Name under which an unnamed expression is evaluated.
_TEMPORARY = "__yasps_compute"


class ComputedValue:
    """The result of :meth:`Attribute.compute`."""

    def __init__(self, attribute: Attribute, value: np.ndarray, stats: dict):
        self.attribute = attribute
        #: The values, shape ``(N, rows, cols)``.
        self.value = value
        #: How the kernel was obtained: cache hits and compile times.
        self.stats = stats

    def __repr__(self) -> str:
        return f"<yasps.ComputedValue of {self.attribute.describe()}: {self.value.shape}>"


def _resolve(scene: Scene, path: str):
    """The object a scene-relative path such as ``@m::@v::@x`` names."""
    node = scene
    for name in path.split("::"):
        node = node._symbols[name.lstrip("@")]
    return node


def _buffer(scene: Scene, kind: str, path: str, out: np.ndarray) -> np.ndarray:
    if kind == "out":
        return out
    target = _resolve(scene, path)
    if kind == "attr":
        if target._values is None:
            raise ValueUpdateError(
                f"{target.describe()} has no values for the current "
                f"{target.owner.numInstances} instances; call updateValue")
        return target._values
    if kind == "conn":
        assert isinstance(target, Connectivity)
        if target._indices is None:
            raise SceneError(f"{target.describe()} has no indices for the "
                             f"current {target.source.numInstances} instances; "
                             "call updateConnectivity")
        return target._indices
    if kind == "offsets":
        assert isinstance(target, PrimitiveUnion)
        return np.ascontiguousarray(target.offsets, dtype=np.int64)
    raise AssertionError(f"unknown kernel argument kind {kind!r}")


def compute(attr: Attribute, threads: int = None) -> ComputedValue:
    """Evaluates ``attr`` on every instance of its owner."""
    owner = attr.owner
    if owner is None:
        raise SceneError(f"{attr.describe()} belongs to no entity; add it to "
                         "one with addAttribute(name, computed_attribute=...)")
    scene = owner.scene
    extra: Dict[Entity, List[Tuple[str, Attribute]]] = {}
    target = attr
    if not attr.isNamed:
        extra = {owner: [(_TEMPORARY, attr)]}
        path = "::".join("@" + n for n in owner.path + [_TEMPORARY])
    else:
        path = "::".join("@" + n for n in owner.path + [attr.name])
    ir = emit_scene(scene, locations=True, extra=extra)
    native = compiler._module()
    try:
        library = native.compile_cpu(ir, [path], config.cache_dir or "",
                                     config.opt_level, scene.name)
    except native.IRError as err:
        raise compiler.IRError(str(err)) from None
    arguments = dict(library.kernels)[path]
    count = owner.numInstances
    out = np.empty(count * target.rows * target.cols, dtype=np.float64)
    buffers = [_buffer(scene, kind, p, out) for kind, p in arguments]
    library.launch(path, count, buffers,
                   config.num_threads if threads is None else threads)
    return ComputedValue(attr, from_column_major(out, target.rows, target.cols),
                         dict(library.stats))
