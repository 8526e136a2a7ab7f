"""Old spellings of public names, kept for a release: each still works as it
did and warns once (per old name and process) with
:class:`YaspsDeprecationWarning`, naming its replacement.

The package's naming rule (``docs/python.md``, "Names and old
spellings"): the scene API that the paper defines is camelCase as the paper
writes it; the layers built on it (``yasps.contact``, ``yasps.sim``,
``yasps.sweep``) are snake_case.
"""

from __future__ import annotations

import warnings
from typing import Any, Dict, Mapping, Set

from .errors import ArgumentTypeError


class YaspsDeprecationWarning(FutureWarning):
    """A public name that was renamed; the old one works for a release.
    A FutureWarning, so that Python shows it to users of scripts (it hides
    DeprecationWarning outside ``__main__``)."""


_warned: Set[str] = set()


def warn_renamed(old: str, new: str, stacklevel: int = 3) -> None:
    """Warns, the first time only, that ``old`` is now spelled ``new``."""
    if old in _warned:
        return
    _warned.add(old)
    warnings.warn(f"{old} is deprecated: use {new} (the old name goes in a "
                  f"later release)", YaspsDeprecationWarning,
                  stacklevel=stacklevel)


def renamed_member(owner: str, old: str, new: str) -> property:
    """A property named ``old`` on class ``owner`` that forwards reads,
    writes and calls (a method is read, then called) to ``new``."""
    qualified_old, qualified_new = f"{owner}.{old}", f"{owner}.{new}"

    def get(self: Any) -> Any:
        warn_renamed(qualified_old, qualified_new)
        return getattr(self, new)

    def set_(self: Any, value: Any) -> None:
        warn_renamed(qualified_old, qualified_new)
        setattr(self, new, value)

    return property(get, set_, doc=f"Deprecated: {qualified_new}.")


def add_renamed_members(cls: type, renames: Mapping[str, str]) -> None:
    """Adds ``renamed_member`` for each ``old: new`` of ``renames``."""
    for old, new in renames.items():
        setattr(cls, old, renamed_member(cls.__name__, old, new))


def renamed_argument(where: str, old: str, new: str, value: Any,
                     keywords: Dict[str, Any]) -> Any:
    """The argument ``new`` (given as ``value``, None if not) or its old
    keyword ``old``, taken out of ``keywords`` with a warning (once). Both
    is an ArgumentTypeError (a TypeError, as Python makes a repeated
    keyword)."""
    if old not in keywords:
        return value
    if value is not None:
        raise ArgumentTypeError(f"{where}: got {old}= and {new}=; give "
                                f"{new}= only")
    warn_renamed(f"{where}({old}=)", f"{where}({new}=)", stacklevel=4)
    return keywords.pop(old)
