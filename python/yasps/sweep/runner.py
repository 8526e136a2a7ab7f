"""Running a sweep: Ray tasks over the parameter sets, at most ``workers``
at a time, the first one alone so that it compiles the kernels every other
run then loads from the shared cache; failures and overruns are retried,
every finished run is written to the manifest at once."""

from __future__ import annotations

import csv
import inspect
import os
import sys
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Sequence

from .. import config
from .._native import BUILD_DIR
from .manifest import Manifest, plain, run_id
from .worker import STARTED, execute
from ..frontend.errors import ArgumentError, ArgumentTypeError

#: Seconds a worker may take, beyond an attempt's time limit, to start it
#: (Ray starts a fresh process where the last one was killed).
STARTUP_SECONDS = 60.0


@dataclass
class SweepResult:
    """The rows of a sweep, one per parameter set in the order given: its
    ``id``, ``params``, ``status`` ("ok", "error", "timeout"),
    ``attempts``, ``seconds`` (of the last attempt), ``outputs`` (what
    ``simulate`` returned), ``error`` (the last failure), ``files`` (in
    ``folder``), ``kernels_compiled``, ``newton_iterations`` and
    ``cg_iterations``."""
    rows: List[Dict[str, Any]]
    output: Path

    @property
    def failed(self) -> List[Dict[str, Any]]:
        return [r for r in self.rows if r["status"] != "ok"]

    def column(self, name: str) -> List[Any]:
        """One output (or parameter) of every row, None where missing."""
        return [r.get("outputs", {}).get(name, r["params"].get(name))
                for r in self.rows]

    def write_csv(self, path: Path) -> None:
        """The table, parameters and outputs as columns of their own."""
        params = sorted({k for r in self.rows for k in r["params"]})
        outputs = sorted({k for r in self.rows for k in r.get("outputs", {})})
        fixed = ["id", "status", "attempts", "seconds", "kernels_compiled",
                 "newton_iterations", "cg_iterations", "error"]
        with open(path, "w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(fixed + [f"param.{k}" for k in params] +
                            [f"out.{k}" for k in outputs])
            for r in self.rows:
                writer.writerow([r.get(k, "") for k in fixed] +
                                [r["params"].get(k, "") for k in params] +
                                [r.get("outputs", {}).get(k, "")
                                 for k in outputs])


def _worker_environment(simulate: Callable) -> Dict[str, str]:
    """PYTHONPATH for the workers: this yasps and the folder of the module
    that defines ``simulate`` (so that they import both as here); and the
    build tree this yasps loads its extensions from, as an absolute path
    (workers start in other folders)."""
    paths = [str(Path(__file__).resolve().parents[2])]
    module = sys.modules.get(getattr(simulate, "__module__", ""))
    source = getattr(module, "__file__", None)
    if source:
        paths.append(str(Path(source).resolve().parent))
    if os.environ.get("PYTHONPATH"):
        paths.append(os.environ["PYTHONPATH"])
    environment = {"PYTHONPATH": os.pathsep.join(paths)}
    if os.environ.get("YASPS_BUILD_DIR"):
        environment["YASPS_BUILD_DIR"] = str(BUILD_DIR)
    return environment


def run(simulate: Callable[..., Dict[str, Any]],
        params: Sequence[Dict[str, Any]], workers: Optional[int] = None,
        output: Optional[os.PathLike] = None, retries: int = 1,
        timeout: Optional[float] = None, address: Optional[str] = None,
        progress: bool = True) -> SweepResult:
    """Runs ``simulate(params) -> dict`` for every parameter set as a Ray
    task and returns the table of results.

    - ``workers``: runs at a time (default: the cluster's CPUs); without
      ``address`` a local Ray is started with that many CPUs.
    - ``output``: the sweep's folder (default ``out/sweep``): each run works
      in ``runs/<id>/`` (its current directory; a ``simulate`` taking a
      second argument gets that folder), ``manifest.json`` records every
      run and ``results.csv`` the table. Runs the manifest says finished
      are not run again (an interrupted sweep resumes).
    - ``retries``: further attempts of a run that raises or overruns.
    - ``timeout``: seconds an attempt may take from when its worker starts
      it (then the worker is killed); a worker that has not started it
      STARTUP_SECONDS after the limit is stopped too.
    - The kernel cache is ``yasps.config.cache_dir``, shared by the
      workers (on a cluster it must be a folder every node sees); the first
      run goes alone so that the others find its kernels there.
    """
    import ray
    from tqdm import tqdm

    params = [dict(p) for p in params]
    keys = [run_id(p) for p in params]
    if len(set(keys)) != len(keys):
        raise ArgumentError("sweep.run: the same parameter set is given twice")
    if len(inspect.signature(simulate).parameters) not in (1, 2):
        raise ArgumentTypeError("sweep.run: simulate must take (params) or "
                                "(params, folder)")
    folder = Path(output if output is not None else "out/sweep").resolve()
    manifest = Manifest.open(folder)
    pending = deque(k for k in keys if not manifest.finished(k))
    by_key = dict(zip(keys, params))
    cache = str(Path(config.cache_dir).resolve()) if config.cache_dir else ""

    started = not ray.is_initialized()
    if started:
        ray.init(address=address,
                 num_cpus=workers if address is None else None,
                 runtime_env={"env_vars": _worker_environment(simulate)},
                 include_dashboard=False, log_to_driver=False,
                 configure_logging=False)
    limit = workers or max(int(ray.cluster_resources().get("CPU", 1)), 1)
    task = ray.remote(num_cpus=1, max_retries=0)(execute)
    attempts: Dict[str, int] = {k: 0 for k in pending}
    running: Dict[Any, tuple] = {}   # ref -> (key, submitted)
    started_at: Dict[Any, float] = {}  # ref -> when its worker started it
    bar = tqdm(total=len(keys), initial=len(keys) - len(pending),
               desc="sweep", unit="run", disable=not progress)
    first = bool(pending)

    def submit(key: str) -> None:
        attempts[key] += 1
        directory = folder / "runs" / key
        (directory / STARTED).unlink(missing_ok=True)
        ref = task.remote(simulate, by_key[key], str(directory), cache)
        running[ref] = (key, time.monotonic())

    def overrun(ref, key: str, since: float, now: float) -> Optional[str]:
        """Why the attempt ``ref`` of ``key`` (submitted at ``since``) is
        stopped now, or None: the time limit counts from the start its
        worker marks, which a worker has STARTUP_SECONDS to reach."""
        assert timeout is not None  # only called with a time limit
        begun = started_at.get(ref)
        if begun is None and (folder / "runs" / key / STARTED).exists():
            begun = started_at[ref] = now
        if begun is not None:
            return f"ran past the time limit of {timeout:g} s" \
                if now - begun > timeout else None
        if now - since > timeout + STARTUP_SECONDS:
            return (f"did not start within {timeout + STARTUP_SECONDS:g} s "
                    f"(the time limit of {timeout:g} s plus "
                    f"{STARTUP_SECONDS:g} s for a worker to start)")
        return None

    def finish(key: str, status: str, **entry) -> None:
        if status != "ok" and attempts[key] <= retries:
            pending.appendleft(key)   # retried before the others
            return
        manifest.record(key, dict(entry, id=key, params=by_key[key],
                                  status=status, attempts=attempts[key],
                                  folder=str(folder / "runs" / key)))
        bar.update(1)

    try:
        while pending or running:
            # The first run alone: it compiles what the others load.
            room = 1 if first else limit
            while pending and len(running) < room:
                submit(pending.popleft())
            ready, _ = ray.wait(list(running), num_returns=1, timeout=0.2)
            for ref in ready:
                key, _ = running.pop(ref)
                first = False
                try:
                    result = ray.get(ref)
                except Exception as err:  # the user's exception, recorded
                    finish(key, "error", error=str(err))
                else:
                    finish(key, "ok", error="", **plain(result))
            if timeout is not None:
                now = time.monotonic()
                for ref, (key, since) in list(running.items()):
                    why = overrun(ref, key, since, now)
                    if why is not None:
                        ray.cancel(ref, force=True)
                        running.pop(ref)
                        first = False
                        finish(key, "timeout", error=why)
    finally:
        bar.close()
        if started:
            ray.shutdown()
    result = SweepResult(manifest.rows(keys), folder)
    result.write_csv(folder / "results.csv")
    return result
