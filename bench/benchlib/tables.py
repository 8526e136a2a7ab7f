"""Bench results rendered as Markdown tables in the documents.

A document marks each generated table::

    <!-- bench-table: <bench> <table> -->
    (generated: the table, then where its numbers come from)
    <!-- /bench-table -->

and ``update`` rewrites what lies between the markers from
``<results>/<bench>.json`` (benchlib.results). Everything outside the
markers is left as it is.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Dict, List, Tuple

from benchlib.results import Table, load

START = re.compile(r"^<!-- bench-table: (\S+) (\S+) -->$")
END = "<!-- /bench-table -->"


class TableError(ValueError):
    """A marker that names no results, or markers that do not pair up."""


def cell_text(value: Any, fmt: str) -> str:
    """One cell: empty for None, else ``fmt.format(value)`` (``str`` when
    fmt is empty)."""
    if value is None:
        return ""
    text = fmt.format(value) if fmt else str(value)
    return text.replace("|", "\\|")


def provenance(meta: Dict[str, Any]) -> str:
    """The line under a table: the command, commit, date and machine."""
    m = meta.get("machine", {})
    where = f"{m.get('cores', '?')} cores, {m.get('cpu', 'unknown CPU')}"
    line = (f"`{meta['command']}` at {meta['commit']}, {meta['date']}; "
            f"{where}")
    if meta.get("transcribed"):
        line = (f"{meta['transcribed']} Measured by {line}. Rerun the "
                "command to regenerate.")
    return f"<sub>{line}</sub>"


def render(table: Dict[str, Any], meta: Dict[str, Any]) -> List[str]:
    """The Markdown lines of one table of a results file."""
    columns, formats = table["columns"], table["formats"]
    numeric = [all(isinstance(r[i], (int, float)) or r[i] is None
                   for r in table["rows"]) and bool(table["rows"])
               for i in range(len(columns))]
    lines = ["| " + " | ".join(columns) + " |",
             "|" + "|".join("---:" if n else "---" for n in numeric) + "|"]
    for row in table["rows"]:
        lines.append("| " + " | ".join(cell_text(v, f)
                                       for v, f in zip(row, formats)) + " |")
    lines.append("")
    if table.get("note"):
        lines += [table["note"], ""]
    lines.append(provenance(meta))
    return lines


@dataclass
class Marker:
    bench: str
    table: str
    start: int  # line index of the start marker
    end: int    # line index of the end marker


def markers(lines: List[str], name: str) -> List[Marker]:
    """The generated places of a document (``name`` for messages)."""
    found, open_at = [], None
    for i, line in enumerate(lines):
        match = START.match(line.strip())
        if match:
            if open_at is not None:
                raise TableError(f"{name}:{i + 1}: bench-table opened before "
                                 f"the one at line {open_at[0] + 1} closed")
            open_at = (i, match.group(1), match.group(2))
        elif line.strip() == END:
            if open_at is None:
                raise TableError(f"{name}:{i + 1}: {END} without a start")
            found.append(Marker(open_at[1], open_at[2], open_at[0], i))
            open_at = None
    if open_at is not None:
        raise TableError(f"{name}:{open_at[0] + 1}: bench-table never closed")
    return found


def update(text: str, results: Path, name: str = "document") -> Tuple[str, List[str]]:
    """``text`` with every marked table regenerated from ``results``, and
    the (bench, table) pairs it rendered. Raises TableError for a marker
    whose results file or table does not exist."""
    lines = text.split("\n")
    cache: Dict[str, Dict[str, Any]] = {}
    used = []
    for marker in reversed(markers(lines, name)):
        path = results / f"{marker.bench}.json"
        if marker.bench not in cache:
            if not path.exists():
                raise TableError(f"{name}:{marker.start + 1}: no results "
                                 f"{path.name}: run bench/{marker.bench}.py")
            cache[marker.bench] = load(path)
        data = cache[marker.bench]
        if marker.table not in data["tables"]:
            raise TableError(
                f"{name}:{marker.start + 1}: {path.name} has no table "
                f"{marker.table!r} (it has: {', '.join(sorted(data['tables']))})")
        body = render(data["tables"][marker.table], data["meta"])
        lines[marker.start + 1:marker.end] = [""] + body + [""]
        used.append(f"{marker.bench} {marker.table}")
    return "\n".join(lines), used[::-1]


def markdown(table: Table) -> str:
    """A results table as Markdown, its cells formatted as the documents
    show them (for a bench's own printout)."""
    lines = ["| " + " | ".join(table.columns) + " |",
             "|" + "---|" * len(table.columns)]
    lines += ["| " + " | ".join(cell_text(v, f) for v, f in
                                zip(row, table.formats)) + " |"
              for row in table.rows]
    return "\n".join(lines)
