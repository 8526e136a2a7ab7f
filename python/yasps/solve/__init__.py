"""The solve layer: local derivatives per energy, host-side compression
before projection, assembly of the static/dynamic Newton system, and
``minimizeEnergy``."""

from .assembly import DofLayout, assemble
from .derivatives import (LocalDerivatives, NoDerivativesError,
                          assembly_inputs, energy_derivatives)
from .minimize import SolverError, fixed_dof_mask, minimize_energy
from .prepare import CompileSummary, compile_scene

__all__ = ["CompileSummary", "DofLayout", "LocalDerivatives", "NoDerivativesError",
           "SolverError", "assemble", "assembly_inputs", "compile_scene",
           "energy_derivatives",
           "fixed_dof_mask", "minimize_energy"]
