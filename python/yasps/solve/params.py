"""Where an energy's local parameters live: for each instance, the target
attribute, target instance and entry of every parameter, found by following
the compiler's parameter groups through JOINs and UNIONs (for tests and
debugging; assembly uses the generated ``__dofs`` kernels instead)."""

from __future__ import annotations

from typing import Dict, List, Optional, Tuple

import numpy as np

from ..compiler.params import (JoinParam, Param, ReadParam,
                               attribute_params)
from ..compiler.pipelines import DIFFERENTIATION_PIPELINE
from ..frontend import introspect
from ..frontend.attribute import Attribute, owner_of
from ..frontend.scene import Entity, Scene
from ..ir import resolve, symbol_path

#: (target attribute, instance, entry) of one local parameter; None for the
#: zero padding of UNION slots.
Location = Optional[Tuple[Attribute, int, int]]


class ParamSlot:
    """A group of an energy's local parameters (one entry of
    ``yasps.params``): the entries of a target read directly, or, for one
    instance gathered by a JOIN or decoded from a UNION, the parameters of
    the attribute found there (recursively, padded to ``width``)."""

    def __init__(self, param: Param, owner: Entity,
                 resolver: "ParamResolver"):
        self.param = param
        self.owner = owner
        self._resolver = resolver

    @property
    def width(self) -> int:
        if isinstance(self.param, ReadParam):
            target = resolve(self._resolver.scene, self.param.target)
            return target.rows * target.cols
        return self.param.width

    def locations(self, i: int) -> List[Location]:
        """(target attribute, instance, entry) of each parameter of this
        group for energy instance ``i``; None for UNION padding."""
        scene = self._resolver.scene
        param = self.param
        if isinstance(param, ReadParam):
            target = resolve(scene, param.target)
            inst = i if target.owner is self.owner else 0
            return [(target, inst, e) for e in range(target.rows * target.cols)]
        if isinstance(param, JoinParam):
            conn = introspect.symbols(self.owner)[
                param.connectivity.lstrip("@")]
            j = int(conn.indices[i, param.slot])
            out = self._resolver.expand(resolve(scene, param.base), j)
        else:
            union = resolve(scene, param.union)
            offsets = union.offsets
            m = int(np.searchsorted(offsets, i, side="right") - 1)
            member = union.members[m]
            out = self._resolver.expand(
                introspect.named_attributes(member)[param.attribute],
                i - int(offsets[m]))
        return out + [None] * (self.width - len(out))

    def __repr__(self) -> str:
        return f"<ParamSlot {self.param}>"


class ParamResolver:
    """Finds the parameters of attributes met behind JOINs and UNIONs."""

    def __init__(self, scene: Scene, ir: str):
        self.scene = scene
        self.ir = ir
        self.cache: Dict[str, List[Param]] = {}

    def slots(self, attr: Attribute) -> List[ParamSlot]:
        path = symbol_path(attr)
        if path not in self.cache:
            self.cache[path] = attribute_params(
                self.ir, DIFFERENTIATION_PIPELINE, [path + "__jac"],
                self.scene.name)[0]
        return [ParamSlot(p, owner_of(attr), self) for p in self.cache[path]]

    def expand(self, attr: Attribute, instance: int) -> List[Location]:
        if attr.kind in ("data", "constant"):
            if attr.kind == "data" and any(t is attr for t in
                                           self.scene.minimizeTargets):
                return [(attr, instance, e)
                        for e in range(attr.rows * attr.cols)]
            return []
        out: List[Location] = []
        for slot in self.slots(attr):
            out += slot.locations(instance)
        return out
