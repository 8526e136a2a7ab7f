"""Symbolic attributes: per-instance matrix expressions over a scene.

An :class:`Attribute` stands for a function from the instances of its owner
(a scene, mesh, primitive or primitive union) to ``rows x cols`` matrices.
Stored attributes hold values; every other attribute is an expression built
with Python operators and methods, evaluated per instance (paper section 4.3).
Shapes and owners are known eagerly: a mistake raises where it is made.
"""

from __future__ import annotations

import itertools

import numbers
import os
import sys
from typing import TYPE_CHECKING, Any, Iterable, Optional, Sequence, Tuple, Union

import numpy as np

from .errors import (ArgumentError, ArgumentTypeError, IndexRangeError,
                     LineageError, ShapeError, ValueUpdateError)
from . import values as _values
from .services import services

if TYPE_CHECKING:  # pragma: no cover
    from types import FrameType
    from typing import TypeGuard  # Python 3.10; only the checker reads it

    from .scene import Entity

#: Kinds of attribute. Stored kinds hold values; named kinds live on an entity.
STORED_KINDS = ("data", "constant")
NAMED_KINDS = ("data", "constant", "computed", "join", "union")

#: PSD projection methods of :meth:`Attribute.project`.
PROJECTION_METHODS = ("clamp", "abs", "none")

#: The yasps package: frames in it are not the user's.
_PACKAGE_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

Operand = Union["Attribute", float, numbers.Real, np.ndarray, Sequence]


def _user_location() -> Optional[Tuple[str, int]]:
    """The first stack frame outside the yasps package: where the user is."""
    frame: Optional[FrameType] = sys._getframe(1)
    while frame is not None:
        filename = frame.f_code.co_filename
        if not os.path.abspath(filename).startswith(_PACKAGE_DIR):
            return filename, frame.f_lineno
        frame = frame.f_back
    return None


def _is_scalar(value: Any) -> "TypeGuard[numbers.Real]":
    return isinstance(value, numbers.Real) and not isinstance(value, bool)



#: Versions of stored values: each updateValue gets a new one.
_value_versions = itertools.count(1)

class Attribute:
    """A symbolic per-instance matrix attribute.

    Do not construct directly: attributes come from ``addAttribute``,
    ``addConstant``, indexing an entity (``entity["name"]``), or operations on
    other attributes.
    """

    __array_ufunc__ = None  # make NumPy defer to our reflected operators

    def __init__(self, *, owner: Optional["Entity"], rows: int, cols: int,
                 kind: str, op: str = "", operands: Tuple["Attribute", ...] = (),
                 params: Optional[dict] = None, name: Optional[str] = None):
        self._owner = owner
        self._rows = int(rows)
        self._cols = int(cols)
        self._kind = kind
        self._op = op
        self._operands = operands
        self._params = params or {}
        self._name = name
        self._values: Optional[np.ndarray] = None  # flat, column-major
        # Changes with every new value, so that copies (on a GPU) notice.
        self._version = 0
        self._loc = _user_location()

    # ------------------------------------------------------------------ info

    @property
    def shape(self) -> Tuple[int, int]:
        """Per-instance shape ``(rows, cols)``."""
        return (self._rows, self._cols)

    @property
    def rows(self) -> int:
        return self._rows

    @property
    def cols(self) -> int:
        return self._cols

    @property
    def owner(self) -> Optional["Entity"]:
        """The entity the attribute belongs to (None for pure constants)."""
        return self._owner

    @property
    def name(self) -> Optional[str]:
        """The attribute's name on its owner, None for anonymous expressions."""
        return self._name

    @property
    def kind(self) -> str:
        """'data', 'constant', 'computed', 'join', 'union', 'expression' or
        'literal'."""
        return self._kind

    @property
    def isNamed(self) -> bool:
        return self._kind in NAMED_KINDS

    def describe(self) -> str:
        """Human-readable identification used in error messages."""
        shape = f"{self._rows}x{self._cols}"
        if self.isNamed:
            what = f"{self._kind} attribute '{self._name}'"
        elif self._kind == "literal":
            what = "constant"
        else:
            what = f"expression {self._op}(...)"
        where = f" on {self._owner.describe()}" if self._owner is not None else ""
        return f"{what} [{shape}]{where}"

    def __repr__(self) -> str:
        return f"<yasps.Attribute {self.describe()}>"

    def __bool__(self) -> bool:
        raise ArgumentTypeError(
            f"{self.describe()} is symbolic and has no truth value; use "
            "comparisons with select() to choose per instance")

    # ---------------------------------------------------------------- values

    def updateValue(self, values: Any) -> "Attribute":
        """Sets the values of a stored attribute (data or constant).

        Accepts NumPy arrays or nested lists of shape ``(N, rows, cols)``,
        ``(N, rows*cols)`` (each row read row-major into ``rows x cols``), flat
        ``N*rows*cols`` (read as ``(N, rows, cols)`` in C order), or
        ``(rows, cols)`` when ``N`` is 1. Values are stored as float64,
        column-major per instance.

        Raises:
            ValueUpdateError: for a computed attribute, a wrong size, a
                non-numeric dtype, or NaN/inf entries. The old values stay.
        """
        if self._kind not in STORED_KINDS:
            raise ValueUpdateError(
                f"{self.describe()} is computed from other attributes and has "
                "no stored values to update")
        count = owner_of(self).numInstances
        self._values = _values.to_column_major(
            values, count, self._rows, self._cols, self.describe())
        self._version = next(_value_versions)
        return self

    @property
    def value(self) -> np.ndarray:
        """The stored values as an array of shape ``(N, rows, cols)``."""
        if self._kind not in STORED_KINDS:
            raise ValueUpdateError(
                f"{self.describe()} is computed; it has no stored value")
        if self._values is None:
            raise ValueUpdateError(
                f"{self.describe()} has no values for the current "
                f"{owner_of(self).numInstances} instances; call updateValue")
        return _values.from_column_major(self._values, self._rows, self._cols)

    def compute(self, threads: Optional[int] = None):
        """Evaluates the attribute on every instance of its owner with a
        compiled kernel; ``.value`` of the result is an ``(N, rows, cols)``
        array. Intermediate attributes are not stored. ``threads``
        overrides ``yasps.config.num_threads`` (0: every core)."""
        return services().compute(self, threads)

    def _invalidate_values(self) -> None:
        self._values = None
        self._version = next(_value_versions)

    # ------------------------------------------------------------ operations

    def _new(self, op: str, operands: Sequence["Attribute"], rows: int,
             cols: int, **params: Any) -> "Attribute":
        owner = _common_owner(op, operands)
        return Attribute(owner=owner, rows=rows, cols=cols, kind="expression",
                         op=op, operands=tuple(operands), params=params)

    def _lift(self, other: Operand, like: Optional["Attribute"] = None,
              op: str = "") -> "Attribute":
        return lift(other, like=like, op=op)

    def _same_shape(self, op: str, other: "Attribute") -> None:
        # Lineage first: combining attributes of two primitive types is the
        # more fundamental mistake, whatever their shapes.
        _common_owner(op, (self, other))
        if self.shape != other.shape:
            raise ShapeError(
                f"{op}: shapes differ: {self.describe()} and {other.describe()}")

    def _elementwise(self, op: str, other: Operand,
                     reverse: bool = False) -> "Attribute":
        o = self._lift(other, like=self, op=op)
        lhs, rhs = (o, self) if reverse else (self, o)
        lhs._same_shape(op, rhs)
        return self._new(op, (lhs, rhs), self._rows, self._cols)

    def __add__(self, other: Operand) -> "Attribute":
        return self._elementwise("add", other)

    def __radd__(self, other: Operand) -> "Attribute":
        return self._elementwise("add", other, reverse=True)

    def __sub__(self, other: Operand) -> "Attribute":
        return self._elementwise("sub", other)

    def __rsub__(self, other: Operand) -> "Attribute":
        return self._elementwise("sub", other, reverse=True)

    def __neg__(self) -> "Attribute":
        return self._new("neg", (self,), self._rows, self._cols)

    def __pos__(self) -> "Attribute":
        return self

    def _product(self, lhs: "Attribute", rhs: "Attribute") -> "Attribute":
        _common_owner("mul", (lhs, rhs))
        # A 1x1 factor scales; otherwise it is the matrix product.
        if rhs.shape == (1, 1):
            return self._new("scale", (lhs, rhs), lhs._rows, lhs._cols)
        if lhs.shape == (1, 1):
            return self._new("scale", (rhs, lhs), rhs._rows, rhs._cols)
        return _matmul(lhs, rhs)

    def __mul__(self, other: Operand) -> "Attribute":
        return self._product(self, self._lift(other, op="mul"))

    def __rmul__(self, other: Operand) -> "Attribute":
        return self._product(self._lift(other, op="mul"), self)

    def __matmul__(self, other: Operand) -> "Attribute":
        return _matmul(self, self._lift(other, op="matmul"))

    def __rmatmul__(self, other: Operand) -> "Attribute":
        return _matmul(self._lift(other, op="matmul"), self)

    def __truediv__(self, other: Operand) -> "Attribute":
        o = self._lift(other, op="div")
        _common_owner("div", (self, o))
        if o.shape != (1, 1):
            raise ShapeError(
                f"div: the divisor must be 1x1, got {o.describe()} (dividing "
                f"{self.describe()}); use cwiseQuotient-style code with "
                "cwiseProduct and pow(-1) for entrywise division")
        return self._new("div", (self, o), self._rows, self._cols)

    def __rtruediv__(self, other: Operand) -> "Attribute":
        if self.shape != (1, 1):
            raise ShapeError(
                f"div: the divisor must be 1x1, got {self.describe()}")
        return self._new("div", (self._lift(other, op="div"), self), 1, 1)

    def pow(self, exponent: Operand) -> "Attribute":
        """Entrywise power; the exponent is a scalar, 1x1 or of this shape."""
        e = self._lift(exponent, op="pow")
        _common_owner("pow", (self, e))
        if e.shape != (1, 1) and e.shape != self.shape:
            raise ShapeError(
                f"pow: the exponent must be 1x1 or of the base's shape, got "
                f"{e.describe()} for base {self.describe()}")
        return self._new("pow", (self, e), self._rows, self._cols)

    __pow__ = pow

    def __rpow__(self, base: Operand) -> "Attribute":
        b = self._lift(base, like=self, op="pow")
        return b.pow(self)

    def _compare(self, predicate: str, other: Operand) -> "Attribute":
        o = self._lift(other, like=self, op="cmp")
        self._same_shape(f"cmp {predicate}", o)
        return self._new("cmp", (self, o), self._rows, self._cols,
                         predicate=predicate)

    def __lt__(self, other: Operand) -> "Attribute":
        return self._compare("lt", other)

    def __le__(self, other: Operand) -> "Attribute":
        return self._compare("le", other)

    def __gt__(self, other: Operand) -> "Attribute":
        return self._compare("gt", other)

    def __ge__(self, other: Operand) -> "Attribute":
        return self._compare("ge", other)

    def eq(self, other: Operand) -> "Attribute":
        """Entrywise ``==``: 1.0 where equal, 0.0 elsewhere."""
        return self._compare("eq", other)

    def ne(self, other: Operand) -> "Attribute":
        """Entrywise ``!=``: 1.0 where different, 0.0 elsewhere."""
        return self._compare("ne", other)

    def select(self, if_true: Operand, if_false: Operand) -> "Attribute":
        """Per entry (or for the whole matrix if this condition is 1x1),
        ``if_true`` where the condition is non-zero, else ``if_false``."""
        return select(self, if_true, if_false)

    # Linear algebra -------------------------------------------------------

    def dot(self, other: Operand) -> "Attribute":
        """Sum of entrywise products of two same-shape attributes (1x1)."""
        o = self._lift(other, op="dot")
        self._same_shape("dot", o)
        return self._new("dot", (self, o), 1, 1)

    def cross(self, other: Operand) -> "Attribute":
        """Cross product of two 3x1 (or two 1x3) vectors."""
        o = self._lift(other, op="cross")
        self._same_shape("cross", o)
        if self.shape not in ((3, 1), (1, 3)):
            raise ShapeError(
                f"cross: needs 3x1 or 1x3 vectors, got {self.describe()}")
        return self._new("cross", (self, o), self._rows, self._cols)

    def cwiseProduct(self, other: Operand) -> "Attribute":
        """Entrywise (Hadamard) product of two same-shape attributes."""
        return self._elementwise("elementwise_mul", other)

    def transpose(self) -> "Attribute":
        return self._new("transpose", (self,), self._cols, self._rows)

    @property
    def T(self) -> "Attribute":
        """The transpose."""
        return self.transpose()

    def _square(self, op: str) -> None:
        if self._rows != self._cols:
            raise ShapeError(f"{op}: needs a square matrix, got {self.describe()}")

    def determinant(self) -> "Attribute":
        self._square("determinant")
        return self._new("det", (self,), 1, 1)

    def inverse(self) -> "Attribute":
        self._square("inverse")
        return self._new("inverse", (self,), self._rows, self._cols)

    def cofactor(self) -> "Attribute":
        """The cofactor matrix (signed minors): the derivative of the
        determinant, ``det(A) A^-T`` for invertible A."""
        self._square("cofactor")
        return self._new("cofactor", (self,), self._rows, self._cols)

    def trace(self) -> "Attribute":
        self._square("trace")
        return self._new("trace", (self,), 1, 1)

    def singularValueSum(self) -> "Attribute":
        """The sum of the signed singular values (1x1) of a matrix of at
        most 3x3: ``tr(S)`` of its polar decomposition ``R S`` with R a
        rotation, so the smallest singular value counts negative where the
        determinant is negative. ``|F - R|^2 = |F|^2 - 2 tr(S) + n`` is
        fixed corotated elasticity's distance from a rotation. Computed
        without an SVD (see ``yasps.singular_value_sum`` in docs/dialect.md);
        its derivatives are singular where two signed singular values sum
        to zero."""
        self._square("singularValueSum")
        if self._rows > 3:
            raise ShapeError(f"singularValueSum: needs a matrix of at most "
                             f"3x3, got {self.describe()}")
        return self._new("singular_value_sum", (self,), 1, 1)

    def norm(self) -> "Attribute":
        """Frobenius norm (1x1)."""
        return self._new("norm", (self,), 1, 1)

    def squaredNorm(self) -> "Attribute":
        """Squared Frobenius norm (1x1)."""
        return self._new("squared_norm", (self,), 1, 1)

    def sum(self) -> "Attribute":
        """Sum of all entries (1x1)."""
        return self._new("sum", (self,), 1, 1)

    def project(self, method: str = "clamp") -> "Attribute":
        """PSD projection of a symmetric matrix: ``clamp`` sets negative
        eigenvalues to zero, ``abs`` flips them, ``none`` keeps them."""
        self._square("project")
        if method not in PROJECTION_METHODS:
            raise ArgumentError(f"project: method must be one of "
                                f"{', '.join(PROJECTION_METHODS)}, got {method!r}")
        return self._new("project", (self,), self._rows, self._cols,
                         method=method)

    # Entrywise functions ---------------------------------------------------

    def _unary(self, op: str) -> "Attribute":
        return self._new(op, (self,), self._rows, self._cols)

    def sqrt(self) -> "Attribute":
        return self._unary("sqrt")

    def log(self) -> "Attribute":
        return self._unary("log")

    def exp(self) -> "Attribute":
        return self._unary("exp")

    def sin(self) -> "Attribute":
        return self._unary("sin")

    def cos(self) -> "Attribute":
        return self._unary("cos")

    def abs(self) -> "Attribute":
        return self._unary("abs")

    __abs__ = abs

    def atan2(self, x: Operand) -> "Attribute":
        """Entrywise ``atan2(self, x)`` (self is the y coordinate)."""
        return self._elementwise("atan2", x)

    def min(self, other: Operand) -> "Attribute":
        """Entrywise minimum."""
        return self._elementwise("min", other)

    def max(self, other: Operand) -> "Attribute":
        """Entrywise maximum."""
        return self._elementwise("max", other)

    def asConstant(self) -> "Attribute":
        """The same value, treated as a constant by differentiation."""
        return self._unary("stop_gradient")

    # Extracting and rearranging entries ------------------------------------

    def _index(self, what: str, index: int, bound: int) -> int:
        if not isinstance(index, numbers.Integral) or isinstance(index, bool):
            raise ArgumentTypeError(f"{what} index must be an integer, got {index!r}")
        i = int(index) + (bound if index < 0 else 0)
        if not 0 <= i < bound:
            raise IndexRangeError(
                f"{what} {index} is out of range for {self.describe()}")
        return i

    def row(self, i: int) -> "Attribute":
        """Row ``i`` as a 1 x cols attribute."""
        r = self._index("row", i, self._rows)
        return self._new("row", (self,), 1, self._cols, index=r)

    def col(self, j: int) -> "Attribute":
        """Column ``j`` as a rows x 1 attribute."""
        c = self._index("column", j, self._cols)
        return self._new("col", (self,), self._rows, 1, index=c)

    def _range(self, what: str, key: slice, bound: int) -> Tuple[int, int]:
        start, stop, step = key.indices(bound)
        if step != 1 or stop <= start:
            raise IndexRangeError(
                f"{what} slice {key} of {self.describe()} must select a "
                "non-empty contiguous range")
        return start, stop - start

    def __getitem__(self, key: Any) -> "Attribute":
        """``a[i]``: entry i of a vector, row i of a matrix; ``a[i, j]``: one
        entry (1x1); slices select contiguous blocks, e.g. ``a[0:2, 1:3]``."""
        if not isinstance(key, tuple):
            if self._cols == 1:
                key = (key, 0)
            elif self._rows == 1:
                key = (0, key)
            else:
                key = (key, slice(None))
        if len(key) != 2:
            raise IndexRangeError(f"{self.describe()} takes one or two indices")
        rkey, ckey = key
        if not isinstance(rkey, slice) and not isinstance(ckey, slice):
            r = self._index("row", rkey, self._rows)
            c = self._index("column", ckey, self._cols)
            return self._new("element", (self,), 1, 1, row=r, col=c)
        if isinstance(rkey, slice):
            r0, nr = self._range("row", rkey, self._rows)
        else:
            r0, nr = self._index("row", rkey, self._rows), 1
        if isinstance(ckey, slice):
            c0, nc = self._range("column", ckey, self._cols)
        else:
            c0, nc = self._index("column", ckey, self._cols), 1
        if nr == 1 and (c0, nc) == (0, self._cols):
            return self._new("row", (self,), 1, self._cols, index=r0)
        if nc == 1 and (r0, nr) == (0, self._rows):
            return self._new("col", (self,), self._rows, 1, index=c0)
        if (r0, nr, c0, nc) == (0, self._rows, 0, self._cols):
            return self
        return self._new("slice", (self,), nr, nc, row_offset=r0,
                         col_offset=c0)

    def resize(self, rows: int, cols: int) -> "Attribute":
        """The same entries, read column-major as a rows x cols matrix (a 1x9
        JOIN of a 3x3 matrix resizes back to it)."""
        if rows < 1 or cols < 1 or rows * cols != self._rows * self._cols:
            raise ShapeError(
                f"resize: cannot resize {self.describe()} to {rows}x{cols}")
        return self._new("resize", (self,), rows, cols)


# ---------------------------------------------------------------- free functions


def owner_of(attr: Attribute) -> "Entity":
    """The owner of an attribute known to have one, for the type checker:
    ``attr.owner`` is Optional because constants have none, but an entity
    creates its named attributes (data, constant, computed, JOIN, UNION)
    with itself as their owner, and an expression reading one has one."""
    owner = attr.owner
    assert owner is not None, f"{attr.describe()} has no owner"
    return owner


def _literal(array: np.ndarray) -> Attribute:
    lit = Attribute(owner=None, rows=array.shape[0], cols=array.shape[1],
                    kind="literal", op="constant")
    lit._params = {"value": array}
    return lit


def constant(value: Any) -> Attribute:
    """A constant matrix: a Python number (1x1), a 1-D array (a column vector)
    or a 2-D array. NaN and inf are rejected."""
    try:
        array = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise ValueUpdateError(f"constant: {value!r} is not numeric") from err
    if array.ndim == 0:
        array = array.reshape(1, 1)
    elif array.ndim == 1:
        array = array.reshape(-1, 1)
    if array.ndim != 2 or array.size == 0:
        raise ShapeError(f"constant: needs a scalar, 1-D or 2-D array, got "
                         f"shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueUpdateError("constant: NaN or inf entries are not allowed")
    return _literal(array)


def zeros(rows: int, cols: int = 1) -> Attribute:
    """The rows x cols zero matrix."""
    return _literal(np.zeros((rows, cols)))


def identity(n: int) -> Attribute:
    """The n x n identity matrix."""
    return _literal(np.eye(n))


def lift(value: Operand, like: Optional[Attribute] = None,
         op: str = "") -> Attribute:
    """Turns Python numbers and arrays into constant attributes. A number next
    to a matrix attribute (``like``) becomes a matrix of that number."""
    if isinstance(value, Attribute):
        return value
    if _is_scalar(value) and like is not None:
        return _literal(np.full(like.shape, float(value)))
    try:
        return constant(value)
    except (ShapeError, ValueUpdateError) as err:
        raise type(err)(f"{op}: {err}") from None


def _lineage(entity: Optional["Entity"]) -> list:
    chain = []
    while entity is not None:
        chain.append(entity)
        entity = entity.parent
    return chain


def _common_owner(op: str, operands: Iterable[Attribute]) -> Optional["Entity"]:
    """The deepest owner among the operands, checking they share a lineage."""
    deepest: Optional[Attribute] = None
    for operand in operands:
        if operand.owner is None:
            continue
        if deepest is None or len(_lineage(operand.owner)) > len(
                _lineage(deepest.owner)):
            deepest = operand
    if deepest is None:
        return None
    chain = _lineage(deepest.owner)
    for operand in operands:
        if operand.owner is not None and operand.owner not in chain:
            raise LineageError(
                f"{op}: {operand.describe()} and {deepest.describe()} are not "
                "on one lineage (entity, mesh, scene); bring one to the other "
                "with a JOIN (addAttribute(through=, source=)) or a UNION "
                "(addPrimitiveUnion)")
    return deepest.owner


def _matmul(lhs: Attribute, rhs: Attribute) -> Attribute:
    _common_owner("matrix product", (lhs, rhs))
    if lhs.cols != rhs.rows:
        raise ShapeError(
            f"matrix product: inner dimensions differ: {lhs.describe()} times "
            f"{rhs.describe()}")
    return lhs._new("matmul", (lhs, rhs), lhs.rows, rhs.cols)


def select(condition: Operand, if_true: Operand, if_false: Operand) -> Attribute:
    """Chooses ``if_true`` where ``condition`` is non-zero, else ``if_false``.

    The condition is 1x1 (one choice per instance) or of the values' shape.
    """
    a = if_true if isinstance(if_true, Attribute) else None
    b = if_false if isinstance(if_false, Attribute) else None
    like = a if a is not None else b
    t = lift(if_true, like=like, op="select")
    f = lift(if_false, like=t, op="select")
    t._same_shape("select", f)
    c = lift(condition, op="select")
    _common_owner("select", (c, t, f))
    if c.shape != (1, 1) and c.shape != t.shape:
        raise ShapeError(f"select: the condition must be 1x1 or of the "
                         f"values' shape, got {c.describe()} for {t.describe()}")
    return t._new("select", (c, t, f), t.rows, t.cols)


def concat(parts: Sequence[Operand], axis: int = 0) -> Attribute:
    """Stacks attributes vertically (``axis=0``) or side by side (``axis=1``)."""
    if axis not in (0, 1):
        raise ArgumentError(f"concat: axis must be 0 or 1, got {axis}")
    if not parts:
        raise ShapeError("concat: needs at least one operand")
    items = [lift(p, op="concat") for p in parts]
    _common_owner("concat", items)
    kept = [(a.cols if axis == 0 else a.rows) for a in items]
    if len(set(kept)) != 1:
        raise ShapeError(
            f"concat: {'vertical' if axis == 0 else 'horizontal'} "
            f"concatenation needs equal {'column' if axis == 0 else 'row'} "
            "counts, got " + ", ".join(a.describe() for a in items))
    total = sum((a.rows if axis == 0 else a.cols) for a in items)
    rows, cols = (total, kept[0]) if axis == 0 else (kept[0], total)
    return items[0]._new("concat", items, rows, cols,
                         axis="vertical" if axis == 0 else "horizontal")


def vstack(parts: Sequence[Operand]) -> Attribute:
    """Stacks attributes with equal column counts on top of each other."""
    return concat(parts, axis=0)


def hstack(parts: Sequence[Operand]) -> Attribute:
    """Places attributes with equal row counts side by side."""
    return concat(parts, axis=1)
