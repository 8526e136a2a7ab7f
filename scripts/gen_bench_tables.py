#!/usr/bin/env python3
"""Regenerates the bench tables in docs/ from bench/results/*.json.

Every table between ``<!-- bench-table: <bench> <table> -->`` and
``<!-- /bench-table -->`` in docs/*.md and README.md is rendered from the
results its bench wrote (bench/benchlib/results.py). Run without arguments
to rewrite the documents; with --check to fail (exit 1) when one is stale,
as the test suite does. A results file no document shows is reported too.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench"))

from benchlib.results import RESULTS  # noqa: E402
from benchlib.tables import TableError, update  # noqa: E402


def documents() -> list[Path]:
    return sorted((ROOT / "docs").glob("*.md")) + [ROOT / "README.md"]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--check", action="store_true",
                        help="fail when a document is stale; write nothing")
    parser.add_argument("--results", type=Path, default=RESULTS)
    opts = parser.parse_args()
    stale, shown = [], set()
    for path in documents():
        text = path.read_text()
        try:
            wanted, used = update(text, opts.results, str(path.relative_to(ROOT)))
        except TableError as error:
            print(error, file=sys.stderr)
            return 1
        shown.update(u.split()[0] for u in used)
        if wanted != text:
            stale.append(str(path.relative_to(ROOT)))
            if not opts.check:
                path.write_text(wanted)
    unshown = sorted(p.stem for p in opts.results.glob("*.json")
                     if p.stem not in shown)
    if unshown:
        print("results no document shows: " + ", ".join(unshown),
              file=sys.stderr)
        return 1
    if opts.check and stale:
        print("stale bench tables: " + ", ".join(stale) +
              "\nrun: python3 scripts/gen_bench_tables.py", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
