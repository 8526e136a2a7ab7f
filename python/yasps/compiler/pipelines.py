"""The pass pipelines Python runs, by the names the C++ compiler registers
(``yasps-opt --help`` lists them; docs/passes.md describes them)."""

from __future__ import annotations

from .. import config

#: Energies to their local derivatives and placement indices:
#: yasps-inline-reads, canonicalize, cse, yasps-differentiate,
#: yasps-generate-indices (docs/passes.md).
DIFFERENTIATION_PIPELINE = "yasps-differentiate-pipeline"


#: yasps-differentiate's hessian-factors for config.separate_reduced_hessians.
_FACTORS = {None: "auto", True: "always", False: "never"}


def differentiation_pipeline() -> str:
    """DIFFERENTIATION_PIPELINE with the options of ``config``: whether
    reduced-space Hessians stay factored (``separate_reduced_hessians``)
    and whether they are projected through linear maps
    (``linear_map_projection``)."""
    factors = _FACTORS[config.separate_reduced_hessians]
    linear = "true" if config.linear_map_projection else "false"
    return (f"{DIFFERENTIATION_PIPELINE}{{hessian-factors={factors} "
            f"linear-maps={linear}}}")
