"""How Newton solves a step: one settings object that :func:`newton` and
:class:`ImplicitEuler` take (``settings=NewtonSettings(...)``), checked when
it is made."""

from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass
from typing import Any, Dict, Optional

from ..deprecation import warn_renamed
from ..frontend.errors import ArgumentError, ArgumentTypeError
from ..solve.minimize import STOPPING_RULES

#: Newton's default iteration cap: a guard, not a budget (STARK has none);
#: the twisting cloth at dt = 0.01 s needs 40 to 43 in its hardest frame.
MAX_ITERATIONS = 100

#: How Newton treats indefinite local Hessians: project every instance's
#: ("full", projected Newton), or progressively (SymX's and STARK's
#: default): exact Hessians first, and where a solve breaks down or does
#: not descend, projected for the instances whose DoF blocks' gradients
#: reach a threshold that falls to a quarter at each such failure and
#: doubles after each direction taken.
PROJECTIONS = ("progressive", "full")


@dataclass(frozen=True)
class NewtonSettings:
    """The Newton solver's settings (frozen: ``dataclasses.replace`` makes a
    changed copy).

    ``max_iterations``: the cap on Newton iterations per solve.
    ``projection``: one of :data:`PROJECTIONS` ("progressive": exact local
    Hessians, projected where a solve needs it; "full": every instance's
    projected). ``cg_tolerance``: PCG's relative residual for a direction
    that may end the solve. ``cg_max_iterations``: PCG's cap (a direction
    that reaches it is used as it is, counted in the report's
    ``inexact_directions``). ``cg_stopping``: minimizeEnergy's stopping rule
    ("residual", "energy_norm" or "preconditioned"). ``cg_forcing``: solve
    each direction only as tightly as an inexact Newton method needs
    (:mod:`yasps.sim.forcing`), re-solving to ``cg_tolerance`` a direction
    that would end the solve; False: every direction to ``cg_tolerance``.
    """

    max_iterations: int = MAX_ITERATIONS
    projection: str = "progressive"
    cg_tolerance: float = 1e-4
    cg_max_iterations: int = 1000
    cg_stopping: str = "residual"
    cg_forcing: bool = True

    def __post_init__(self) -> None:
        # Frozen: normalised values are set through object.__setattr__.
        for name in ("max_iterations", "cg_max_iterations"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value,
                                                         numbers.Integral):
                raise ArgumentTypeError(f"NewtonSettings: {name} must be a "
                                        f"whole number, got {value!r}")
            if value < 0:
                raise ArgumentError(f"NewtonSettings: {name} must not be "
                                    f"negative, got {value}")
            object.__setattr__(self, name, int(value))
        tolerance = self.cg_tolerance
        if isinstance(tolerance, bool) or not isinstance(tolerance,
                                                         numbers.Real):
            raise ArgumentTypeError(f"NewtonSettings: cg_tolerance must be a "
                                    f"number, got {tolerance!r}")
        if not (math.isfinite(tolerance) and tolerance >= 0):
            raise ArgumentError(f"NewtonSettings: cg_tolerance must be a "
                                f"finite number >= 0, got {tolerance!r}")
        object.__setattr__(self, "cg_tolerance", float(tolerance))
        if self.projection not in PROJECTIONS:
            raise ArgumentError(f"NewtonSettings: projection must be one of "
                                f"{', '.join(PROJECTIONS)}, got "
                                f"{self.projection!r}")
        if self.cg_stopping not in STOPPING_RULES:
            raise ArgumentError(f"NewtonSettings: cg_stopping must be one of "
                                f"{', '.join(STOPPING_RULES)}, got "
                                f"{self.cg_stopping!r}")
        object.__setattr__(self, "cg_forcing", bool(self.cg_forcing))


#: The settings' fields, which newton() and ImplicitEuler also took as
#: keywords before NewtonSettings.
SETTING_NAMES = tuple(f.name for f in dataclasses.fields(NewtonSettings))


def settings_with_keywords(where: str, settings: Optional[NewtonSettings],
                           keywords: Dict[str, Any]) -> NewtonSettings:
    """``settings`` (the defaults if None) changed by the old keywords in
    ``keywords`` (``cg_tolerance=...`` and the others of
    :data:`SETTING_NAMES`), each warning once that it is now a field of
    NewtonSettings. Any other keyword is a TypeError, as Python's own."""
    unknown = [k for k in keywords if k not in SETTING_NAMES]
    if unknown:
        raise ArgumentTypeError(f"{where}() got an unexpected keyword "
                                f"argument {unknown[0]!r}")
    if settings is not None and not isinstance(settings, NewtonSettings):
        raise ArgumentTypeError(f"{where}: settings must be a "
                                f"NewtonSettings, got {settings!r}")
    settings = settings or NewtonSettings()
    if not keywords:
        return settings
    for name in keywords:
        warn_renamed(f"{where}({name}=)",
                     f"{where}(settings=NewtonSettings({name}=...))",
                     stacklevel=4)
    return dataclasses.replace(settings, **keywords)


def add_settings_attributes(cls: type) -> None:
    """Gives ``cls`` (which holds a ``settings``) each field of
    NewtonSettings as a deprecated attribute: reading it reads
    ``settings.<field>``, setting it replaces ``settings`` with a copy
    changed there."""
    for name in SETTING_NAMES:
        setattr(cls, name, _settings_attribute(cls.__name__, name))


def _settings_attribute(owner: str, name: str) -> property:
    old, new = f"{owner}.{name}", f"{owner}.settings.{name}"

    def get(self: Any) -> Any:
        warn_renamed(old, new)
        return getattr(self.settings, name)

    def set_(self: Any, value: Any) -> None:
        warn_renamed(old, new)
        self.settings = dataclasses.replace(self.settings, **{name: value})

    return property(get, set_, doc=f"Deprecated: {new}.")
