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


#: Passes that turn energies into their local derivatives (docs/passes.md).
DIFFERENTIATION_PIPELINE = "yasps-inline-reads,canonicalize,cse,yasps-differentiate"


class ParamSlot:
    """A group of an energy's local parameters: the entries of one target
    value, read directly (``connectivity`` None) or gathered as the
    ``slot``-th instance of a JOIN."""

    def __init__(self, target: Attribute, connectivity, slot):
        self.target = target
        self.connectivity = connectivity
        self.slot = slot

    @property
    def size(self) -> int:
        return self.target.rows * self.target.cols

    def instance(self, i: int) -> int:
        """The target instance these parameters belong to, for energy
        instance ``i``."""
        if self.connectivity is not None:
            return int(self.connectivity.indices[i, self.slot])
        owner = self.target.owner
        return i if owner.numInstances > 1 or owner.kind in ("primitive", "primitive union") else 0

    def __repr__(self) -> str:
        via = (f" via {self.connectivity.name}[{self.slot}]"
               if self.connectivity is not None else "")
        return f"<ParamSlot {self.target.describe()}{via}>"


class LocalDerivatives:
    """Per-instance value, gradient and Hessian of one energy with respect to
    its local parameters (see :meth:`Scene.energyDerivatives`)."""

    def __init__(self, energy, value, gradient, hessian, params):
        self.energy = energy
        #: Energy of every instance, shape (N,).
        self.value = value
        #: Gradient of every instance, shape (N, n).
        self.gradient = gradient
        #: Hessian of every instance, shape (N, n, n).
        self.hessian = hessian
        #: The n local parameters, as groups in order.
        self.params = params

    def locations(self, i: int):
        """(target attribute, target instance, entry) of each local parameter
        of energy instance ``i``; entries are column-major."""
        out = []
        for slot in self.params:
            instance = slot.instance(i)
            out += [(slot.target, instance, e) for e in range(slot.size)]
        return out


def _param_slots(scene: Scene, owner: Entity, fields) -> list:
    slots = []
    for field in fields:
        if field[0] == "read":
            slots.append(ParamSlot(_resolve(scene, field[1]), None, None))
        else:
            connectivity = owner._symbols[field[1].lstrip("@")]
            slots.append(ParamSlot(_resolve(scene, field[3]), connectivity,
                                   int(field[2])))
    return slots


def energy_derivatives(scene: Scene, energy: Attribute,
                       threads: int = None) -> LocalDerivatives:
    """Local gradients and Hessians of a registered energy, per instance."""
    if not any(e is energy for e in scene.energies):
        raise SceneError(f"{energy.describe()} is not an energy of scene "
                         f"'{scene.name}' (addEnergy)")
    if not scene.minimizeTargets:
        raise SceneError(f"scene '{scene.name}' has no minimisation targets "
                         "(addMinimizeTarget)")
    owner = energy.owner
    base = "::".join("@" + n for n in owner.path + [energy.name])
    paths = [base + "__grad", base + "__hess"]
    native = compiler._module()
    ir = emit_scene(scene, locations=True)
    try:
        library = native.compile_cpu(ir, paths, config.cache_dir or "",
                                     config.opt_level, scene.name,
                                     DIFFERENTIATION_PIPELINE)
    except native.IRError as err:
        if "does not name an attribute" in str(err):
            raise SceneError(f"{energy.describe()} depends on no "
                             "minimisation target") from None
        raise compiler.IRError(str(err)) from None
    params = _param_slots(scene, owner, library.params(paths[0]))
    n = sum(p.size for p in params)
    count = owner.numInstances
    results = []
    for path, shape in zip(paths, [(n, 1), (n, n)]):
        out = np.empty(count * shape[0] * shape[1], dtype=np.float64)
        arguments = dict(library.kernels)[path]
        buffers = [_buffer(scene, kind, p, out) for kind, p in arguments]
        library.launch(path, count, buffers,
                       config.num_threads if threads is None else threads)
        results.append(from_column_major(out, *shape))
    value = compute(energy, threads).value[:, 0, 0]
    return LocalDerivatives(energy, value, results[0][:, :, 0], results[1],
                            params)
