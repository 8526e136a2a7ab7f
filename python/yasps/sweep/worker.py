"""What a Ray worker does for one run: the user's function in the run's own
folder, with the sweep's kernel cache, counting the kernels it compiled and
the Newton and CG iterations it did."""

from __future__ import annotations

import inspect
import os
import time
from pathlib import Path
from typing import Any, Callable, Dict

#: The file a run's folder gets when a worker starts the run.
STARTED = ".started"


def execute(simulate: Callable[..., Dict[str, Any]], params: Dict[str, Any],
            folder: str, cache_dir: str) -> Dict[str, Any]:
    """Runs ``simulate(params)`` (or ``simulate(params, folder)`` if it
    takes two arguments) with the working directory in ``folder`` and
    ``yasps.config.cache_dir`` set to ``cache_dir``; returns its outputs,
    the seconds it took, the files it wrote and what it compiled and
    iterated. Exceptions propagate (the sweep records and retries them)."""
    from .. import config
    from ..compiler.cpu import kernels_compiled
    from ..sim.newton import iteration_totals

    if cache_dir:
        config.cache_dir = cache_dir
    compiled, iterations = kernels_compiled(), iteration_totals()
    here = Path(folder)
    here.mkdir(parents=True, exist_ok=True)
    # The sweep's time limit counts from here, not from when Ray was asked
    # for a worker: a new one takes seconds to start, and to import yasps,
    # on a busy machine.
    (here / STARTED).touch()
    cwd = os.getcwd()
    start = time.perf_counter()
    os.chdir(here)
    try:
        takes_folder = len(inspect.signature(simulate).parameters) >= 2
        outputs = simulate(params, here) if takes_folder else simulate(params)
    finally:
        os.chdir(cwd)
    after = iteration_totals()
    return {
        "outputs": dict(outputs or {}),
        "seconds": time.perf_counter() - start,
        "files": sorted(str(p.relative_to(here)) for p in here.rglob("*")
                        if p.is_file() and p.name != STARTED),
        "kernels_compiled": kernels_compiled() - compiled,
        "newton_iterations": after["newton"] - iterations["newton"],
        "cg_iterations": after["cg"] - iterations["cg"],
    }
