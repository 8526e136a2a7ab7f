"""What a bench measured, written as JSON.

A bench builds a :class:`Results`, adds its tables (columns, rows of raw
numbers, and how each column is shown) and writes it, by default to
``bench/results/<bench>.json``. ``scripts/gen_bench_tables.py`` renders the
tables into the documents that mark a place for them::

    <!-- bench-table: stark_peer twist -->
    ...the generated table and the line saying where it comes from...
    <!-- /bench-table -->

so a table in ``docs/`` is the last run's, never typed in by hand. The JSON
keeps the numbers unrounded; the document shows them with each column's
format.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

from benchlib import BENCH, ROOT

#: Where results go unless a bench is told otherwise (--json).
RESULTS = BENCH / "results"

#: A number, a string, None (shown as an empty cell), or a dict of numbers
#: for a cell that shows several (its column's format names them:
#: ``"{0[BJ]} / {0[ML]}"``), so that the JSON keeps every number raw.
Cell = Any


@dataclass
class Table:
    """One table: ``columns`` headers, ``rows`` of cells, and per column a
    format (``str.format`` text such as ``"{:.2f}"`` or ``"{:,}"``; ``""``:
    ``str(cell)``)."""

    columns: List[str]
    rows: List[List[Cell]]
    formats: List[str] = field(default_factory=list)
    note: str = ""

    def __post_init__(self) -> None:
        if not self.formats:
            self.formats = [""] * len(self.columns)
        if len(self.formats) != len(self.columns):
            raise ValueError(f"{len(self.formats)} formats for "
                             f"{len(self.columns)} columns")
        for row in self.rows:
            if len(row) != len(self.columns):
                raise ValueError(f"row {row!r} has {len(row)} cells for "
                                 f"{len(self.columns)} columns")


def machine() -> Dict[str, Any]:
    """The facts of this machine a reader needs to weigh the numbers."""
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"cpu": model, "cores": os.cpu_count(),
            "python": platform.python_version(), "system": platform.system()}


def commit() -> str:
    """The checkout's commit (with ``+`` when it has uncommitted changes)."""
    def git(*args: str) -> str:
        return subprocess.run(["git", "-C", str(ROOT), *args], check=True,
                              capture_output=True, text=True).stdout.strip()
    try:
        head = git("rev-parse", "--short", "HEAD")
        dirty = git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+" if dirty else "")


class Results:
    """The results of one run of bench ``bench`` (its file name, no .py)."""

    def __init__(self, bench: str, command: Optional[Sequence[str]] = None):
        self.bench = bench
        argv = list(command) if command is not None else sys.argv[1:]
        self.meta: Dict[str, Any] = {
            "bench": bench,
            "command": " ".join(["python3", f"bench/{bench}.py", *argv]),
            "commit": commit(),
            "date": datetime.date.today().isoformat(),
            "machine": machine(),
        }
        self.tables: Dict[str, Table] = {}
        self.values: Dict[str, Any] = {}

    def table(self, name: str, columns: Sequence[str],
              rows: Sequence[Sequence[Cell]],
              formats: Optional[Sequence[str]] = None,
              note: str = "") -> Table:
        """Adds (or replaces) table ``name`` and returns it."""
        table = Table(list(columns), [list(r) for r in rows],
                      list(formats or []), note)
        self.tables[name] = table
        return table

    def to_json(self) -> Dict[str, Any]:
        return {"meta": self.meta, "values": self.values,
                "tables": {k: asdict(t) for k, t in self.tables.items()}}

    def write(self, path: Optional[Path] = None) -> Path:
        """Writes the results (to RESULTS/<bench>.json by default) and
        returns where."""
        path = Path(path) if path is not None else RESULTS / f"{self.bench}.json"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(self.to_json(), indent=1) + "\n")
        return path


def add_json_argument(parser: argparse.ArgumentParser, bench: str) -> None:
    """--json PATH: where the results go (default RESULTS/<bench>.json)."""
    parser.add_argument(
        "--json", type=Path, default=RESULTS / f"{bench}.json",
        help=f"where the results go (default: bench/results/{bench}.json, "
        "which scripts/gen_bench_tables.py renders into docs/)")


def load(path: Path) -> Dict[str, Any]:
    """A results file as written by Results.write."""
    data = json.loads(Path(path).read_text())
    for key in ("meta", "tables"):
        if key not in data:
            raise ValueError(f"{path}: no {key!r} (not a bench results file)")
    return data
