"""The host arrays a kernel's arguments read: stored values,
connectivities, union offsets and the targets' first DoFs, checked for
presence and bounds before any kernel trusts them."""

from __future__ import annotations

from typing import Any, Optional

import numpy as np

from ..compiler.params import ArgumentKind, KernelArgument
from ..frontend import introspect
from ..frontend.attribute import owner_of
from ..frontend.errors import SceneError, ValueUpdateError
from ..frontend.scene import Connectivity, PrimitiveUnion, Scene
from ..ir import resolve


def target_dof_offsets(scene: Scene) -> np.ndarray:
    """The first global DoF of each minimisation target, in order: targets
    one after another, instance after instance (paper appendix A.1)."""
    sizes = [owner_of(t).numInstances * t.rows * t.cols
             for t in scene.minimizeTargets]
    return np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64) \
        if sizes else np.zeros(0, dtype=np.int64)


def source_of(scene: Scene, argument: KernelArgument) -> Optional[Any]:
    """The attribute or connectivity an argument reads (whose version tells
    whether a device copy is current); None for the small arrays that are
    compared by value."""
    if argument.kind in (ArgumentKind.attr, ArgumentKind.conn):
        return resolve(scene, argument.path)
    return None


def host_input(scene: Scene, argument: KernelArgument) -> np.ndarray:
    """The host array of an input argument (not ``out``)."""
    source = None if argument.kind is ArgumentKind.dof_offsets else \
        resolve(scene, argument.path)
    return input_array(scene, argument, source)


def input_array(scene: Scene, argument: KernelArgument,
                target: Any) -> np.ndarray:
    """The host array of an input argument read from ``target``, the
    entity its path resolves to (None for the DoF offsets): a plan resolves
    paths once per scene structure (runtime.energy_plan)."""
    kind = argument.kind
    if kind is ArgumentKind.dof_offsets:
        return target_dof_offsets(scene)
    if kind is ArgumentKind.attr:
        values = introspect.stored_values(target)
        if values is None:
            raise ValueUpdateError(
                f"{target.describe()} has no values for the current "
                f"{target.owner.numInstances} instances; call updateValue")
        return values
    if kind is ArgumentKind.conn:
        assert isinstance(target, Connectivity)
        indices = introspect.stored_indices(target)
        if indices is None:
            raise SceneError(f"{target.describe()} has no indices for the "
                             f"current {target.source.numInstances} instances; "
                             "call updateConnectivity")
        # The kernel trusts these indices: a target that shrank since they
        # were set (a dynamic primitive) must not be read out of bounds.
        bound = target.target.numInstances
        if indices.size and int(indices.max()) >= bound:
            raise SceneError(f"{target.describe()} refers to instance "
                             f"{int(indices.max())} of "
                             f"{target.target.describe()}, which now has "
                             f"{bound}; call updateConnectivity")
        return indices
    if kind is ArgumentKind.offsets:
        assert isinstance(target, PrimitiveUnion)
        return np.ascontiguousarray(target.offsets, dtype=np.int64)
    raise AssertionError(f"kernel argument {argument} is not an input")
