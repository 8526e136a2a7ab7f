"""Parameter sweeps on Ray: one user function ``simulate(params) -> dict``
run over many parameter sets as Ray tasks, locally or on a cluster, with a
shared kernel cache (a sweep compiles its kernels once), retries, time
limits, a manifest to resume from, and a table of the results.

    from yasps import sweep
    result = sweep.run(simulate, [{"mu": 0.1}, {"mu": 0.5}], workers=2,
                       output="out/sweep")
    result.rows[0]["outputs"]

or ``python3 -m yasps.sweep my_scene.py --grid params.json --workers 8
--output out/`` (docs/sweeps.md).
"""

from .grid import parameter_sets
from .manifest import Manifest, run_id
from .runner import SweepResult, run

__all__ = ["Manifest", "SweepResult", "parameter_sets", "run", "run_id"]
