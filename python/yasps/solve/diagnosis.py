"""What minimizeEnergy tells a user about a solve beyond "converged": a
target no energy reads, the energy and instance behind a NaN, a residual
too weak to vouch for the step in an ill-conditioned system, and targets
too far from the origin for f32 kernels."""

from __future__ import annotations

from typing import List, Optional, Sequence, Tuple

import numpy as np

from ..frontend.state import StateKey
from ..frontend.attribute import owner_of
from .assembly import DofLayout

#: The bound on the step's relative error that a converged residual gives,
#: ||dx - dx*|| / ||dx*|| <= cond(H) ||r|| / ||g||, above which the solve
#: warns: past 1 it does not vouch for a single correct digit.
ERROR_BOUND_WARNING = 1.0


#: The scenes warned about their conditioning already: a Newton loop of a
#: thousand solves warns once, not a thousand times.
_WARNED: StateKey[bool] = StateKey("warned of an ill-conditioned solve")


def first_warning_for(scene) -> bool:
    """True the first time it is asked for ``scene``."""
    if _WARNED in scene.state:
        return False
    scene.state.set(_WARNED, True)
    return True


#: A target's f32 rounding, eps32 |x|_max, relative to its extent, above
#: which an f32 scene warns: elements are smaller than the extent, so
#: their edge vectors lose more than this (1e-5 of the extent: about three
#: digits of an element a hundredth of the scene).
F32_ROUNDING_WARNING = 1e-5
_EPS32 = float(np.finfo(np.float32).eps)
_WARNED_ROUNDING: StateKey[bool] = StateKey("warned of f32 rounding")


class PrecisionWarning(UserWarning):
    """An f32 scene whose targets lie so far from the origin, for their
    extent, that rounding them to f32 costs digits (docs/accuracy.md)."""


def f32_rounding_losses(layout: DofLayout) -> List[Tuple[str, float]]:
    """Per target of more than one instance: eps32 |x|_max over the
    target's extent (the largest spread of one of its entries across
    instances), where that exceeds F32_ROUNDING_WARNING."""
    out = []
    for target in layout.targets:
        values = target.value
        if values is None or len(values) < 2:
            continue
        values = np.asarray(values, dtype=float).reshape(len(values), -1)
        extent = float((values.max(axis=0) - values.min(axis=0)).max())
        if extent <= 0:
            continue
        loss = _EPS32 * float(np.abs(values).max()) / extent
        if loss > F32_ROUNDING_WARNING:
            out.append((target.describe(), loss))
    return out


def first_rounding_warning_for(scene) -> bool:
    """True the first time it is asked for ``scene``."""
    if _WARNED_ROUNDING in scene.state:
        return False
    scene.state.set(_WARNED_ROUNDING, True)
    return True


class IllConditionedSolve(UserWarning):
    """PCG converged, but the system's conditioning makes its residual say
    little about the step (see :func:`residual_error_bound`)."""


def residual_error_bound(pcg) -> float:
    """An estimate from below of the residual bound on the step's relative
    2-norm error, cond(H) ||r|| / ||g||, for this solve: the relative
    residual recomputed from the step times the larger of H's diagonal
    ratio (max / min diagonal entry, a lower bound of cond(H)) and the
    condition number CG's Ritz values show (of the preconditioned H). Past
    1 the residual does not vouch for one correct digit."""
    estimates = [float(pcg.diagonal_ratio), float(pcg.condition_estimate)]
    known = [e for e in estimates if not np.isnan(e)]
    if not known:
        return 0.0
    return max(known) * float(pcg.relative_residual)


def unread_targets(layout: DofLayout, read: np.ndarray,
                   mask: Optional[np.ndarray]) -> List[str]:
    """The targets (described) none of whose free DoFs any energy instance
    of this assembly reads (``read``: per DoF): their step would be zero
    without meaning it."""
    out = []
    for target in layout.targets:
        start = layout.offset[id(target)]
        stop = start + owner_of(target).numInstances * target.rows * target.cols
        wanted = np.ones(stop - start, dtype=bool) if mask is None else \
            mask[start:stop] == 0
        if wanted.any() and not read[start:stop][wanted].any():
            out.append(target.describe())
    return out


def _first_non_finite(array) -> Optional[int]:
    """The first instance (leading index) of a host array with a NaN or
    infinity, or None."""
    values = np.asarray(array)
    bad = ~np.isfinite(values.reshape(len(values), -1)).all(axis=1)
    return int(np.argmax(bad)) if bad.any() else None


def non_finite_sources(contributions) -> List[Tuple[str, str, int]]:
    """(energy, which derivative, first instance) for every energy whose
    local gradient or Hessian holds a NaN or infinity, as far as they are in
    host memory; ("", "", -1) stands for those on a device."""
    out = []
    for energy, inputs in contributions:
        parts: Sequence[Tuple[str, object]] = inputs.arrays()
        for what, array in parts:
            if array is None or inputs.count == 0:
                continue
            if not isinstance(array, np.ndarray):
                out.append((energy.describe(), what, -1))
                break
            instance = _first_non_finite(array.reshape(inputs.count, -1))
            if instance is not None:
                out.append((energy.describe(), what, instance))
                break
    return out


def describe_non_finite(sources: List[Tuple[str, str, int]]) -> str:
    """The sentence naming where NaNs came from."""
    if not sources:
        return ("the assembled system holds a NaN or infinity that no local "
                "derivative shows")
    found = [f"the local {what} of {energy} at instance {i}" if i >= 0 else
             f"{energy} (derivatives on the device: run on the CPU to find "
             f"the instance)" for energy, what, i in sources]
    return "NaN or infinity in " + "; ".join(found)
