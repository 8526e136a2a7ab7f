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
