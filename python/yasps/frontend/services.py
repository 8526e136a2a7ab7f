"""What the paper's API asks of the layers below it.

``Scene.minimizeEnergy``, ``Attribute.compute`` and the other methods that
need IR, kernels or a solver belong to the user API, but the frontend imports
nothing below it: the package installs these services once (``yasps``'s
``__init__``), from the IR, compiler, runtime and solve layers. A frontend
used on its own (``import yasps.frontend``) builds and checks scenes; asking
it to evaluate raises a clear error.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Optional

from .errors import YaspsError


@dataclass(frozen=True)
class Services:
    """The operations the frontend delegates, one per layer's job."""
    #: IR text of a scene (``locations``: with Python source locations).
    emit: Callable[[Any, bool], str]
    #: Parses and verifies a scene's IR; raises IRError.
    verify: Callable[[Any], None]
    #: ``Attribute.compute``: (attribute, threads) -> ComputedValue.
    compute: Callable[[Any, Optional[int]], Any]
    #: ``Scene.evaluateEnergy``: (scene, threads) -> the total energy.
    total_energy: Callable[[Any, Optional[int]], float]
    #: ``Scene.energyDerivatives``: (scene, energy, threads).
    energy_derivatives: Callable[[Any, Any, Optional[int]], Any]
    #: ``Scene.minimizeEnergy``: (scene, tolerance, maxIterations,
    #: threads, fixed) -> one array per target.
    minimize_energy: Callable[..., list]


_installed: Optional[Services] = None


def install(implementation: Services) -> None:
    """Makes ``implementation`` the services of every scene."""
    global _installed
    _installed = implementation


def services() -> Services:
    """The installed services; raises YaspsError before ``import yasps``."""
    if _installed is None:
        raise YaspsError("yasps' compiler and runtime are not loaded; "
                         "'import yasps' installs them")
    return _installed
