"""Conversion between NumPy values and the runtime's storage layout.

The runtime stores an attribute of N instances of shape r x c as one flat
float64 array of N*r*c values, each instance column-major (Eigen's default,
paper Fig. 5). Users think in NumPy's row-major ``(N, r, c)`` arrays; these
helpers convert between the two and reject values that cannot be right.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .errors import SceneError, ValueUpdateError


#: The most entries one instance's matrix may have: the verifier's limit
#: (``MatrixType::kMaxEntries``, docs/robustness.md).
MAX_MATRIX_ENTRIES = 16384

#: The most instances a primitive may have: counts are int64 in the IR and
#: the runtime.
MAX_INSTANCES = 2 ** 63 - 1

#: The most instances a connectivity can address: its indices are int32.
MAX_CONNECTIVITY_TARGET = 2 ** 31 - 1


def as_count(value: Any, what: str) -> int:
    """``value`` as an instance count: an integer (not a bool) in
    [0, MAX_INSTANCES], else a SceneError that starts with ``what``."""
    if (not isinstance(value, (int, np.integer)) or isinstance(value, bool)
            or not 0 <= int(value) <= MAX_INSTANCES):
        raise SceneError(f"{what} must be an integer in [0, 2^63-1], got "
                         f"{value!r}")
    return int(value)


def _is_real_number(x: Any) -> bool:
    return (isinstance(x, (int, float, np.integer, np.floating))
            and not isinstance(x, (bool, np.bool_)))


def _as_array(values: Any, what: str) -> np.ndarray:
    try:
        array = np.asarray(values)
    except Exception as err:  # ragged lists and the like
        raise ValueUpdateError(f"{what}: cannot read {type(values).__name__} "
                               f"as an array ({err})") from None
    return array


def to_column_major(values: Any, count: int, rows: int, cols: int,
                    what: str) -> np.ndarray:
    """Validates values for ``count`` instances of ``rows x cols`` and returns
    them flat, column-major per instance, as a new float64 array.

    Accepted shapes: ``(N, r, c)``, ``(N, r*c)`` (each row read row-major),
    flat ``N*r*c`` (read as ``(N, r, c)`` in C order), and ``(r, c)`` for N=1.
    """
    array = _as_array(values, what)
    # Python ints past int64 (2**70) make an object array of real numbers.
    if array.dtype == object and all(map(_is_real_number, array.flat)):
        try:
            array = array.astype(np.float64)
        except OverflowError:
            raise ValueUpdateError(f"{what}: values must be finite doubles; "
                                   "an integer is too large") from None
    if array.dtype == object or not (np.issubdtype(array.dtype, np.floating)
                                     or np.issubdtype(array.dtype, np.integer)):
        raise ValueUpdateError(
            f"{what}: values must be real numbers, got dtype {array.dtype}")
    size = count * rows * cols
    accepted = {(count, rows, cols), (count, rows * cols), (size,)}
    if count == 1:
        accepted.add((rows, cols))
    if array.shape not in accepted:
        raise ValueUpdateError(
            f"{what}: expected {count} instance(s) of {rows}x{cols}, i.e. an "
            f"array of shape ({count}, {rows}, {cols}), ({count}, "
            f"{rows * cols}) or ({size},); got shape {array.shape}")
    array = array.astype(np.float64).reshape(count, rows, cols)
    finite = np.isfinite(array)
    if not finite.all():
        bad = int(np.argwhere(~finite)[0][0])
        raise ValueUpdateError(
            f"{what}: values contain NaN or inf (first at instance {bad})")
    # Column-major per instance: instance i's (row, col) entry at
    # i*r*c + col*r + row.
    return np.ascontiguousarray(array.transpose(0, 2, 1)).reshape(-1)


def from_column_major(flat: np.ndarray, rows: int, cols: int,
                      copy: bool = True) -> np.ndarray:
    """The inverse of :func:`to_column_major`: an ``(N, rows, cols)`` array.
    Without ``copy``, a strided view of ``flat`` (no data movement)."""
    view = flat.reshape(-1, cols, rows).transpose(0, 2, 1)
    return view.copy() if copy else view


def to_indices(indices: Any, count: int, arity: int, bound: int,
               what: str) -> np.ndarray:
    """Validates connectivity indices for ``count`` instances of arity
    ``arity`` into a target with ``bound`` instances; returns flat int32."""
    if bound > MAX_CONNECTIVITY_TARGET:
        raise SceneError(f"{what}: the target has {bound} instances; "
                         f"connectivity indices are int32, so at most "
                         f"{MAX_CONNECTIVITY_TARGET}")
    array = _as_array(indices, what)
    # A list holding an index past int64 (or one past int64 beside small
    # ones) reads as objects or floats: keep Python's exact ints instead, so
    # that the range check below reports the index as given.
    exact = False
    if not isinstance(indices, np.ndarray) and array.dtype.kind in "Of":
        ints = np.array(indices, dtype=object)
        exact = ints.size > 0 and all(
            isinstance(i, int) and not isinstance(i, bool) for i in ints.flat)
        array = ints if exact else array
    if array.size == 0:
        array = array.reshape(0, arity).astype(np.int64)
    if not (exact or np.issubdtype(array.dtype, np.integer)):
        raise SceneError(f"{what}: indices must be integers, got dtype "
                         f"{array.dtype}")
    if array.shape not in ((count, arity), (count * arity,)):
        raise SceneError(
            f"{what}: expected {count} instance(s) of arity {arity}, i.e. "
            f"shape ({count}, {arity}) or ({count * arity},); got shape "
            f"{array.shape}")
    # Checked in the caller's own dtype: a uint64 past the int64 range
    # must be reported as itself, not as the negative number it wraps to.
    given = array.reshape(-1)
    bad = np.flatnonzero((given < 0) | (given >= bound))
    if bad.size:
        i = int(bad[0])
        raise SceneError(
            f"{what}: index {int(given[i])} (instance {i // arity}, slot "
            f"{i % arity}) is out of range: the target has {bound} instances")
    return given.astype(np.int32)
