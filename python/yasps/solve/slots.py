"""Factored local Hessians from shared member Jacobians (paper 7.1, 10.9,
appendix E.3.3).

Where an energy is reached through linear parameterisations, its local
Hessian is J^T P J, P the projected Hessian in the energy's inner variables
(the world-space entries of its leaves). J is block-diagonal by slot: what a
JOIN gathers at one slot depends only on the parameters of the instance
found there, an affine body's vertex or a soft vertex of a UNION. So J is
not stored per energy instance, padded to the widest member: each slot's
block is one row of a *Jacobian table*, the ``X__jac`` kernel of the source
attribute X evaluated over X's instances once per assembly and shared by
every energy that reaches X (a minimisation target read as it is has the
identity). Per instance the runtime stores only the inner gradient, P and
one (table, row) reference per slot, and forms J^T P J while it assembles
(``GlobalSystem::addSlotFactored``).

A :class:`SlotPlan` is the static part (which tables, where each slot sits
among the inner variables and the local parameters), built once per scene
structure; :meth:`SlotPlan.sources` decodes the slots of the current
instances (JOIN indices, UNION offsets) on every call.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..compiler.errors import native, translated
from ..compiler.params import JoinParam, Param, ReadParam, UnionParam, \
    decode_params
from ..frontend.attribute import Attribute
from ..frontend.scene import Primitive, PrimitiveUnion, Scene
from ..ir import resolve, symbol_path


@dataclass(frozen=True)
class JacobianTable:
    """One source of slot Jacobians: the kernel ``jacobian`` (``X__jac``)
    over the instances of ``source``, or the identity of ``entries`` rows
    (a target read as it is) when ``jacobian`` is None."""
    entries: int
    jacobian: Optional[str] = None
    source: Optional[Attribute] = None


@dataclass
class SlotInputs:
    """What assembly reads besides the inner gradients and P: the tables
    ((instances, rows, cols), row-major), each slot's placement (S, 3) of
    (inner start, inner stride, first local column) and every instance's
    (table, row) per slot (count, S, 2), table -1 for a slot without
    parameters."""
    tables: List[np.ndarray]
    slots: np.ndarray
    sources: np.ndarray

    def stored_per_instance(self, inner_size: int) -> int:
        """Doubles kept per energy instance: inner gradient and P (the
        references are two integers per slot)."""
        return inner_size + inner_size * inner_size


#: (table index, rows offset in the union numbering) of each source behind
#: an attribute; recomputed on every call, as member counts may change.
_Leaf = Tuple[int, int, bool]


class SlotPlan:
    """How one energy's local Hessians are formed from Jacobian tables."""

    def __init__(self, scene: Scene, owner, params: Sequence[Param],
                 has_jacobian: Dict[str, bool]):
        self.scene, self.owner = scene, owner
        self._has_jacobian = has_jacobian
        self.tables: List[JacobianTable] = []
        self._table_of: Dict[object, int] = {}
        #: per slot: how to find its instances (kind, parameter)
        self._slots: List[Param] = list(params)
        placements, inner, column = [], 0, 0
        k = 0
        while k < len(params):
            param = params[k]
            if isinstance(param, JoinParam):
                # A JOIN of arity a gathers a x E entries, slot s's entry e
                # at e * a + s (the join's rows flattened column-major).
                group = [p for p in params[k:] if isinstance(p, JoinParam)
                         and p.connectivity == param.connectivity
                         and p.base == param.base]
                arity = len(group)
                base = resolve(scene, param.base)
                for s, p in enumerate(group):
                    placements.append((inner + s, arity, column))
                    column += p.width
                inner += arity * base.rows * base.cols
                k += arity
                continue
            if isinstance(param, ReadParam):
                target = resolve(scene, param.target)
                entries = width = target.rows * target.cols
            else:
                union = resolve(scene, param.union)
                attr = union._attributes[param.attribute]
                entries, width = attr.rows * attr.cols, param.width
            placements.append((inner, 1, column))
            inner += entries
            column += width
            k += 1
        self.inner_size = inner
        self.num_params = column
        self.slots = np.asarray(placements, dtype=np.int64).reshape(-1, 3)
        # Register every table now: the kernels are compiled with the
        # energy's own.
        for param in self._slots:
            self._leaves_of_param(param)

    def check(self, inner_size: int) -> None:
        """Raises AssertionError unless the slots account for the
        ``inner_size`` inner variables of the compiled inner Hessian."""
        if self.inner_size != inner_size:
            raise AssertionError(
                f"{self.inner_size} inner variables from the slots of an "
                f"energy of {self.owner.describe()}, but its inner Hessian "
                f"has {inner_size}")

    @property
    def kernel_paths(self) -> List[str]:
        """The Jacobian kernels the tables need."""
        return [t.jacobian for t in self.tables if t.jacobian]

    def _table(self, key: object, table: JacobianTable) -> int:
        if key not in self._table_of:
            self._table_of[key] = len(self.tables)
            self.tables.append(table)
        return self._table_of[key]

    def _leaves(self, attr: Attribute, start: int) -> List[_Leaf]:
        """(table, first instance in the numbering that reaches ``attr``,
        whether every instance reads row 0) of each source behind it."""
        if attr.kind == "union":
            union = attr.owner
            assert isinstance(union, PrimitiveUnion)
            out: List[_Leaf] = []
            for member, offset in zip(union.members, union.offsets):
                out += self._leaves(member._attributes[attr.name],
                                    start + int(offset))
            return out
        entries = attr.rows * attr.cols
        if attr.kind == "data" and any(t is attr for t in
                                       self.scene.minimizeTargets):
            return [(self._table(("identity", entries),
                                 JacobianTable(entries)), start, True)]
        path = symbol_path(attr)
        if attr.kind in ("computed", "join") and \
                self._has_jacobian.get(path + "__jac"):
            return [(self._table(path, JacobianTable(
                entries, path + "__jac", attr)), start, False)]
        return [(-1, start, True)]  # constant: no parameters

    def _leaves_of_param(self, param: Param) -> List[_Leaf]:
        if isinstance(param, ReadParam):
            target = resolve(self.scene, param.target)
            return self._leaves(target, 0)
        if isinstance(param, JoinParam):
            return self._leaves(resolve(self.scene, param.base), 0)
        union = resolve(self.scene, param.union)
        return self._leaves(union._attributes[param.attribute], 0)

    def sources(self, count: int) -> np.ndarray:
        """The (table, row) of every slot of the ``count`` current
        instances, (count, S, 2)."""
        out = np.empty((count, len(self._slots), 2), dtype=np.int64)
        for s, param in enumerate(self._slots):
            leaves = self._leaves_of_param(param)
            if isinstance(param, JoinParam):
                conn = self.owner._symbols[param.connectivity.lstrip("@")]
                index = np.asarray(conn.indices[:count, param.slot],
                                   dtype=np.int64)
            elif isinstance(param, UnionParam):
                index = np.arange(count, dtype=np.int64)
            else:
                index = np.zeros(count, dtype=np.int64)
            if len(leaves) == 1:
                table, start, fixed = leaves[0]
                out[:, s, 0] = table
                out[:, s, 1] = 0 if fixed else index - start
                continue
            starts = np.array([leaf[1] for leaf in leaves], dtype=np.int64)
            tables = np.array([leaf[0] for leaf in leaves], dtype=np.int64)
            fixed = np.array([leaf[2] for leaf in leaves])
            which = np.searchsorted(starts, index, side="right") - 1
            out[:, s, 0] = tables[which]
            out[:, s, 1] = np.where(fixed[which], 0, index - starts[which])
        return out


def _named_attributes(scene: Scene) -> List[Attribute]:
    """Every named attribute of the scene, entity by entity."""
    out, pending = [], list(scene._symbols.values())
    while pending:
        entity = pending.pop()
        if isinstance(entity, Attribute):
            out.append(entity)
        elif hasattr(entity, "_symbols"):
            pending += list(entity._symbols.values())
    return out


#: Per (IR, pipeline): each energy's gradient parameters and which source
#: attributes have a ``__jac``, asked of the compiler in one request.
_structure: Dict[Tuple[str, str], Tuple[Dict[str, List[Param]],
                                        Dict[str, bool]]] = {}


def slot_plan(scene: Scene, energy: Attribute, ir: str,
              pipeline: str) -> Optional[SlotPlan]:
    """The plan of a factored energy, or None for an energy without
    parameter slots."""
    key = (ir, pipeline)
    if key not in _structure:
        energies = [symbol_path(e) + "__grad" for e in scene.energies]
        sources = [symbol_path(a) + "__jac" for a in _named_attributes(scene)
                   if a.kind in ("computed", "join")]
        with translated("attribute_params"):
            params = native().attribute_params(ir, pipeline,
                                               energies + sources, scene.name)
        _structure[key] = (
            {p: decode_params(r) for p, r in zip(energies, params)},
            {p: bool(r) for p, r in zip(sources, params[len(energies):])})
    grads, has_jacobian = _structure[key]
    params = grads.get(symbol_path(energy) + "__grad")
    if not params or not isinstance(energy.owner, (Primitive,
                                                   PrimitiveUnion)):
        return None
    return SlotPlan(scene, energy.owner, params, has_jacobian)
