"""The errors of misuse, for the frontend's modules: defined in
:mod:`yasps.errors`, below every layer, so that ``yasps.config`` raises
them too."""

from ..errors import (ArgumentError, ArgumentTypeError, IndexRangeError,
                      IRError, LineageError, NameLookupError, SceneError,
                      ShapeError, ValueUpdateError, YaspsError)

__all__ = ["ArgumentError", "ArgumentTypeError", "IndexRangeError",
           "IRError", "LineageError", "NameLookupError", "SceneError",
           "ShapeError", "ValueUpdateError", "YaspsError"]
