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

from ..frontend.state import StateKey
from ..compiler.params import JoinParam, Param, ReadParam, UnionParam
from ..compiler.specs import scene_params
from ..frontend import introspect
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
        self._source_of: Dict[int, Tuple[int, bool]] = {}
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
                attr = introspect.named_attributes(union)[param.attribute]
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

    def check(self, inner_size: int, num_params: int) -> None:
        """Raises AssertionError unless the slots account for the
        ``inner_size`` inner variables of the compiled inner Hessian and
        the ``num_params`` local parameters of the DoF map."""
        if (self.inner_size, self.num_params) != (inner_size, num_params):
            raise AssertionError(
                f"{self.inner_size} inner variables and {self.num_params} "
                f"parameters from the slots of an energy of "
                f"{self.owner.describe()}, but its kernels have "
                f"{inner_size} and {num_params}")

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
            union, name = attr.owner, attr.name
            assert isinstance(union, PrimitiveUnion) and name is not None
            out: List[_Leaf] = []
            for member, offset in zip(union.members, union.offsets):
                out += self._leaves(introspect.named_attributes(member)[name],
                                    start + int(offset))
            return out
        if id(attr) not in self._source_of:
            self._source_of[id(attr)] = self._source(attr)
        table, fixed = self._source_of[id(attr)]
        return [(table, start, fixed)]

    def _source(self, attr: Attribute) -> Tuple[int, bool]:
        """The table of a source attribute (-1: no parameters) and whether
        every instance reads its row 0 (the identity)."""
        entries = attr.rows * attr.cols
        if attr.kind == "data" and any(t is attr for t in
                                       self.scene.minimizeTargets):
            return self._table(("identity", entries),
                               JacobianTable(entries)), True
        path = symbol_path(attr)
        if attr.kind in ("computed", "join") and \
                self._has_jacobian.get(path + "__jac"):
            return self._table(path, JacobianTable(entries, path + "__jac",
                                                   attr)), False
        return -1, True  # constant: no parameters

    def _leaves_of_param(self, param: Param) -> List[_Leaf]:
        if isinstance(param, ReadParam):
            target = resolve(self.scene, param.target)
            return self._leaves(target, 0)
        if isinstance(param, JoinParam):
            return self._leaves(resolve(self.scene, param.base), 0)
        union = resolve(self.scene, param.union)
        return self._leaves(
            introspect.named_attributes(union)[param.attribute], 0)

    def sources(self, count: int) -> np.ndarray:
        """The (table, row) of every slot of the ``count`` current
        instances, (count, S, 2)."""
        out = np.empty((count, len(self._slots), 2), dtype=np.int64)
        if not count:
            return out
        # The slots of one JOIN share their sources: decoded once per call.
        decoders: Dict[object, tuple] = {}
        for s, param in enumerate(self._slots):
            key = param.base if isinstance(param, JoinParam) else param
            if key not in decoders:
                leaves = self._leaves_of_param(param)
                decoders[key] = (
                    np.array([leaf[1] for leaf in leaves], dtype=np.int64),
                    np.array([leaf[0] for leaf in leaves], dtype=np.int64),
                    np.array([leaf[2] for leaf in leaves]))
            starts, tables, fixed = decoders[key]
            if isinstance(param, JoinParam):
                conn = introspect.symbols(self.owner)[
                    param.connectivity.lstrip("@")]
                index = conn.indices[:count, param.slot]
            elif isinstance(param, UnionParam):
                index = np.arange(count, dtype=np.int64)
            else:
                index = np.zeros(count, dtype=np.int64)
            if len(starts) == 1:
                out[:, s, 0] = tables[0]
                out[:, s, 1] = 0 if fixed[0] else index - starts[0]
                continue
            which = np.searchsorted(starts, index, side="right") - 1
            out[:, s, 0] = tables[which]
            out[:, s, 1] = np.where(fixed[which], 0, index - starts[which])
        return out


#: Each scene's plans by (IR, pipeline, energy path): built once per scene
#: structure, as the tables and placements do not change with counts.
_SLOT_PLANS: StateKey[Dict[tuple, Optional[SlotPlan]]] = StateKey(
    "the slot plans of factored energies")


def slot_plan(scene: Scene, energy: Attribute, ir: str,
              pipeline: str) -> Optional[SlotPlan]:
    """The plan of a factored energy, or None for an energy without
    parameter slots."""
    plans = scene.state.setdefault(_SLOT_PLANS, dict)
    key = (ir, pipeline, symbol_path(energy))
    if key not in plans:
        known = scene_params(scene, ir, pipeline)
        params = known.gradients.get(key[2])
        plans[key] = SlotPlan(scene, energy.owner, params, known.jacobians) \
            if params and isinstance(energy.owner,
                                     (Primitive, PrimitiveUnion)) else None
    return plans[key]
