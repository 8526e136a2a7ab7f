"""Exceptions raised by yasps.

Every error a user can make while building a scene raises a subclass of
:class:`YaspsError` at the line that makes it, naming the attributes, their
owners and shapes. The scene is left as it was before the failing call.
"""


class YaspsError(Exception):
    """Base class of all yasps errors."""


class ShapeError(YaspsError, ValueError):
    """Operands whose per-instance shapes do not fit the operation."""


class LineageError(YaspsError, ValueError):
    """Attributes of different primitive types combined without JOIN or UNION."""


class SceneError(YaspsError, ValueError):
    """A structural mistake: unknown or duplicate names, wrong targets, ..."""


class ValueUpdateError(YaspsError, ValueError):
    """Values of the wrong size, dtype or with NaN/inf given to an attribute."""


class IRError(YaspsError, ValueError):
    """IR that the C++ compiler rejects; the message holds its diagnostics."""


class ArgumentError(YaspsError, ValueError):
    """An argument out of its range, or not one of the choices a function
    takes (a projection method, a precision, a renderer, ...)."""


class ArgumentTypeError(YaspsError, TypeError):
    """An argument of a type the function does not take."""


class NameLookupError(YaspsError, KeyError):
    """A name that is not there (``entity["nope"]``); a KeyError too."""

    def __str__(self) -> str:
        # KeyError shows its message quoted, as a key; this is a sentence.
        return str(self.args[0]) if self.args else ""


class IndexRangeError(YaspsError, IndexError):
    """An index outside its range (a row, a column, an instance)."""


class CheckpointError(YaspsError, OSError):
    """A checkpoint that cannot be read back: no file at the path (with or
    without its ``.npz``), or one cut short or not written by ``save``."""


class KernelNotCompiledError(YaspsError, LookupError):
    """A kernel that a run needs, on an installation without the compiler,
    is not in the kernel store (``yasps.compiler.store``): the message names
    the kernel and how to compile it ahead."""


class ModelFileError(YaspsError, ValueError):
    """A model file (URDF) that cannot be read, or that holds an element
    yasps does not support: the message names the element and where it
    is."""
