"""The errors of misuse, for the frontend's modules: defined in
:mod:`yasps.errors`, below every layer, so that ``yasps.config`` raises
them too."""

from ..errors import (ArgumentError, ArgumentTypeError, CheckpointError,
                      IndexRangeError, IRError, LineageError, NameLookupError,
                      SceneError, ShapeError, ValueUpdateError, YaspsError)

__all__ = ["ArgumentError", "ArgumentTypeError", "CheckpointError",
           "IndexRangeError", "IRError", "LineageError", "NameLookupError",
           "SceneError", "ShapeError", "ValueUpdateError", "YaspsError"]
