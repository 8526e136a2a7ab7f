"""The pass pipelines Python runs, by the names the C++ compiler registers
(``yasps-opt --help`` lists them; docs/passes.md describes them)."""

from __future__ import annotations

from .. import config

#: Energies to their local derivatives and placement indices:
#: yasps-inline-reads, canonicalize, cse, yasps-differentiate,
#: yasps-generate-indices (docs/passes.md).
DIFFERENTIATION_PIPELINE = "yasps-differentiate-pipeline"


def differentiation_pipeline() -> str:
    """DIFFERENTIATION_PIPELINE with the options of ``config``."""
    if config.separate_reduced_hessians:
        return DIFFERENTIATION_PIPELINE + "{separate-reduced-hessians=true}"
    return DIFFERENTIATION_PIPELINE
