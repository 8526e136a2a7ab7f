"""The stability map's layout and its runner: which cells bench/extremes.py
runs (each axis alone from every kind's defaults, the pairs that interact,
with and without friction, or a reduced map of the axes' ends), and the
worker processes that run them, each cell within a time budget, so that a
crash or a hang of one cell is recorded and the map goes on."""

from __future__ import annotations

import multiprocessing as mp
import os
import time
from dataclasses import replace
from multiprocessing.connection import Connection, wait
from typing import Callable, Dict, List, Optional, Sequence, Tuple

from benchlib.extremes_cells import (KINDS, TET_KINDS, Cell, Record, base,
                                     run_cell, with_axis)

#: Each axis' values (its kind's default among them) and the kinds it
#: applies to.
AXES: Dict[str, Tuple[Sequence, Sequence[str]]] = {
    "young": ((1e2, 1e4, 1e5, 1e6, 1e8, 1e11),
              ("soft", "affine", "stack", "union", "collide")),
    "stretch": ((1.0, 1e2, 1e3, 1e5, 1e7), ("cloth", "union")),
    "poisson": ((0.0, 0.3, 0.45, 0.49, 0.499), TET_KINDS),
    "mass_ratio": ((1.0, 1e2, 1e4, 1e6), ("stack", "union", "collide")),
    "dt": ((1e-4, 1e-3, 1e-2, 1e-1), KINDS),
    "speed": ((0.0, 1.0, 10.0, 100.0, 1000.0), KINDS),
    "dhat": ((1e-6, 1e-4, 1e-3, 1e-2, 1e-1), KINDS),
    "size": ((1e-3, 1e-1, 1e1, 1e3), KINDS),
    "aspect": ((1.0, 1e-2, 1e-4), ("soft", "affine", "stack", "union",
                                    "collide")),
    "within_dhat": ((False, True), KINDS),
    "precision": (("f64", "f32"), KINDS),
}

#: The pairs of axes that interact, and the kinds they are mapped on.
PAIRS: Dict[Tuple[str, str], Sequence[str]] = {
    ("young", "dt"): ("soft", "affine", "stack"),
    ("mass_ratio", "speed"): ("stack", "union", "collide"),
}

#: The friction coefficients every cell runs with.
FRICTIONS = (0.0, 0.5)


def single_axis_cells(friction: float) -> List[Tuple[str, Cell]]:
    """(axis, cell) for each kind, axis and value, the others at the
    kind's defaults."""
    cells = []
    for kind in KINDS:
        for axis, (values, kinds) in AXES.items():
            if kind in kinds:
                for value in values:
                    cells.append((axis, with_axis(
                        replace(base(kind), friction=friction), axis, value)))
    return cells


def pair_cells(friction: float) -> List[Tuple[str, Cell]]:
    """("a x b", cell) over the product of each pair's values."""
    cells = []
    for (a, b), kinds in PAIRS.items():
        for kind in kinds:
            for x in AXES[a][0]:
                for y in AXES[b][0]:
                    cell = replace(base(kind), friction=friction,
                                   **{a: x, b: y})
                    cells.append((f"{a} x {b}", cell))
    return cells


def full_map() -> List[Tuple[str, Cell]]:
    """Every cell of the map, without repeats (a kind's defaults appear on
    every axis; they run once)."""
    seen, cells = set(), []
    for friction in FRICTIONS:
        for axis, cell in single_axis_cells(friction) + pair_cells(friction):
            if (axis, cell) not in seen:
                seen.add((axis, cell))
                cells.append((axis, cell))
    return cells


def reduced_map() -> List[Tuple[str, Cell]]:
    """Each axis' two ends on the first kind it applies to (the soft box
    for most), without friction, and the soft box with friction."""
    cells = []
    for axis, (values, kinds) in AXES.items():
        for value in (values[0], values[-1]):
            cells.append((axis, with_axis(base(kinds[0]), axis, value)))
    cells.append(("friction", replace(base("soft"), friction=0.5)))
    return cells


# -- running cells in worker processes ----------------------------------------

def _worker(connection: Connection, threads: int) -> None:
    """Runs the cells sent through ``connection`` one at a time, sending
    back each one's Record."""
    import yasps
    yasps.config.num_threads = threads
    while True:
        cell = connection.recv()
        if cell is None:
            return
        connection.send(run_cell(cell))


class _Worker:
    def __init__(self, context, threads: int):
        self.connection, theirs = context.Pipe()
        self.process = context.Process(target=_worker, args=(theirs, threads),
                                       daemon=True)
        self.process.start()
        theirs.close()
        self.job: Optional[int] = None
        self.deadline = 0.0
        self.cells = 0

    def stop(self, kill: bool = False) -> None:
        if kill:
            self.process.kill()
        else:
            try:
                self.connection.send(None)
            except (BrokenPipeError, OSError):
                pass
        self.process.join(timeout=10)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()
        self.connection.close()


#: Cells a worker runs before a fresh one replaces it: each cell's scene
#: and kernels stay in its process (about 4 MB a cell).
CELLS_PER_WORKER = 60


def run_cells(cells: Sequence[Cell], jobs: int = 1, budget: float = 120.0,
              threads: int = 1,
              done: Optional[Callable[[int, Record, float], None]] = None
              ) -> List[Record]:
    """Runs ``cells`` in ``jobs`` worker processes; a cell that takes more
    than ``budget`` seconds is killed with its worker and recorded as a
    hang, one whose worker dies as a crash (the worker is replaced, as is
    one that ran CELLS_PER_WORKER cells). ``done(index, record, seconds)``
    is called as each cell ends."""
    context = mp.get_context("spawn")
    records: List[Optional[Record]] = [None] * len(cells)
    pending = list(range(len(cells)))[::-1]
    workers = [_Worker(context, threads)
               for _ in range(max(1, min(jobs, len(cells))))]
    started: Dict[int, float] = {}

    def finish(index: int, record: Record) -> None:
        records[index] = record
        if done is not None:
            done(index, record, time.monotonic() - started[index])

    try:
        while pending or any(w.job is not None for w in workers):
            for k, worker in enumerate(workers):
                if worker.job is None and pending and \
                        worker.cells >= CELLS_PER_WORKER:
                    worker.stop()
                    workers[k] = worker = _Worker(context, threads)
                if worker.job is None and pending:
                    index = pending.pop()
                    worker.cells += 1
                    worker.job, started[index] = index, time.monotonic()
                    worker.deadline = started[index] + budget
                    worker.connection.send(cells[index])
            busy = [w for w in workers if w.job is not None]
            timeout = max(0.0, min(w.deadline for w in busy) -
                          time.monotonic())
            ready = wait([w.connection for w in busy] +
                         [w.process.sentinel for w in busy], timeout)
            for k, worker in enumerate(workers):
                if worker.job is None:
                    continue
                index = worker.job
                if worker.connection in ready:
                    try:
                        record = worker.connection.recv()
                    except EOFError:
                        record = None
                    if record is not None:
                        worker.job = None
                        finish(index, record)
                        continue
                dead = worker.process.sentinel in ready and \
                    not worker.process.is_alive()
                late = time.monotonic() > worker.deadline
                if dead or late:
                    record = Record()
                    record.error = (
                        "Hang" if late and not dead else "ProcessDied",
                        f"no result within {budget:g} s" if late and not dead
                        else f"the worker exited with code "
                             f"{worker.process.exitcode}")
                    worker.stop(kill=True)
                    workers[k] = _Worker(context, threads)
                    finish(index, record)
    finally:
        for worker in workers:
            worker.stop()
    return [r for r in records if r is not None]


def default_jobs() -> int:
    """One worker per core."""
    return max(1, os.cpu_count() or 1)
