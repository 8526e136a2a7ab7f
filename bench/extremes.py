#!/usr/bin/env python3
"""The stability map: which stiffnesses, mass ratios, time steps, speeds,
contact distances, scene sizes, element shapes and precisions a yasps
simulation survives, and what it does past them.

Six small scenes (a soft tet box, a cloth, an affine box, each dropped on
the ground; two soft boxes stacked; a cloth on a soft box on an affine box
in one UNION; two soft boxes meeting in free space) are run for 20 frames
each at every value of every axis of bench/benchlib/extremes_map.py, the
other axes at the scene's defaults, then over the pairs of axes that
interact (stiffness with time step, mass ratio with speed), all with and
without friction. Each cell is checked apart from yasps' own queries
(bench/benchlib/extremes_cells.py): ipctk for intersections, finite
positions, inverted tets, the momentum of the free collision, unconverged
frames, and the warnings and errors yasps gave. It ends "holds", "warned"
or "stopped" (yasps named the cause), or in a failure: "nan",
"intersection", "silent" (a problem nothing reported), "crash" (an error
that is not a YaspsError) or "hang" (past --budget seconds).

    python3 bench/extremes.py [--reduced] [--jobs N] [--budget S]
                              [--json PATH] [--pictures DIR]

The tables go to bench/results/extremes.json (docs/accuracy.md shows
them) and the pictures to docs/accuracy/extremes_*.png. ``--reduced`` runs
each axis' two ends on one scene (the test suite's map). Exits 1 if any
cell ended in a failure.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import Dict, List, Sequence, Tuple

os.environ.setdefault("YASPS_CACHE_DIR",
                      tempfile.mkdtemp(prefix="yasps-extremes-"))
HERE = Path(__file__).resolve().parent
import benchlib  # noqa: E402

benchlib.use_this_checkout()

from benchlib import ROOT  # noqa: E402
from benchlib.extremes_cells import (ALLOWED, FAILURES, KINDS, Cell,  # noqa: E402
                                     Record, as_row, outcome)
from benchlib.extremes_map import (AXES, PAIRS, default_jobs,  # noqa: E402
                                   full_map, reduced_map, run_cells)
from benchlib.results import Results, add_json_argument  # noqa: E402

#: One letter per outcome in the tables, and the pictures' colours.
LETTERS = {"holds": "H", "warned": "W", "stopped": "S", "nan": "NaN",
           "intersection": "X", "silent": "silent", "crash": "crash",
           "hang": "hang"}
COLOURS = {"holds": "#4caf50", "warned": "#ffc107", "stopped": "#ff9800",
           "nan": "#b71c1c", "intersection": "#f44336",
           "silent": "#9c27b0", "crash": "#212121", "hang": "#757575"}


def _value_text(value) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def _progress(total: int):
    """A tqdm bar (a line per cell without it) and the callback that
    advances it."""
    try:
        from tqdm import tqdm
        bar = tqdm(total=total, unit="cell")
    except ImportError:  # pragma: no cover - tqdm is pinned
        bar = None

    def advance(index: int, record: Record, seconds: float) -> None:
        state, _ = outcome(record)
        if bar is not None:
            bar.update(1)
            bar.set_postfix(last=state)
        else:
            print(f"cell {index}: {state} ({seconds:.1f} s)", flush=True)
    return bar, advance


def axis_table(rows: List[Dict], axes: Sequence[str]) -> List[List[str]]:
    """Per axis and value, per kind: the outcomes without / with friction
    (letters), blank where the axis does not apply."""
    table = []
    index = {(r["axis"], r["kind"], r["friction"], _value_text(r[r["axis"]])):
             r["outcome"] for r in rows if r["axis"] in AXES}
    for axis in axes:
        for value in AXES[axis][0]:
            line = [axis, _value_text(value)]
            for kind in KINDS:
                states = [index.get((axis, kind, f, _value_text(value)))
                          for f in (0.0, 0.5)]
                line.append(" / ".join(LETTERS[s] for s in states if s)
                            if any(states) else "")
            table.append(line)
    return table


def draw_axes(rows: List[Dict], path: Path) -> None:
    """One panel per kind: axes down, values across; each square's left
    half without friction, right half with."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch, Rectangle

    index = {(r["axis"], r["kind"], r["friction"], _value_text(r[r["axis"]])):
             r["outcome"] for r in rows if r["axis"] in AXES}
    axes_names = list(AXES)
    width = max(len(v) for v, _ in AXES.values())
    fig, panels = plt.subplots(2, 3, figsize=(18, 11))
    for ax, kind in zip(panels.ravel(), KINDS):
        for y, axis in enumerate(axes_names):
            for x, value in enumerate(AXES[axis][0]):
                for half, friction in enumerate((0.0, 0.5)):
                    state = index.get((axis, kind, friction,
                                       _value_text(value)))
                    if state is None:
                        continue
                    ax.add_patch(Rectangle((x + 0.5 * half, y), 0.5, 1,
                                           color=COLOURS[state], ec="white"))
                if index.get((axis, kind, 0.0, _value_text(value))):
                    ax.text(x + 0.5, y + 0.5, _value_text(value),
                            ha="center", va="center", fontsize=7)
        ax.set_xlim(0, width)
        ax.set_ylim(len(axes_names), 0)
        ax.set_yticks([y + 0.5 for y in range(len(axes_names))])
        ax.set_yticklabels(axes_names)
        ax.set_xticks([])
        ax.set_title(kind)
    fig.legend(handles=[Patch(color=c, label=s) for s, c in COLOURS.items()],
               loc="lower center", ncol=len(COLOURS))
    fig.suptitle("Stability map, one axis at a time (left half: no "
                 "friction; right half: friction 0.5)")
    fig.savefig(path, dpi=80)
    plt.close(fig)


def draw_pairs(rows: List[Dict], path: Path) -> None:
    """One panel per pair and kind: the first axis across, the second
    down, halves as in draw_axes."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch, Rectangle

    panels_wanted = [(pair, kind) for pair, kinds in PAIRS.items()
                     for kind in kinds]
    fig, panels = plt.subplots(len(PAIRS), 3, figsize=(15, 5 * len(PAIRS)),
                               squeeze=False)
    for ax, ((a, b), kind) in zip(panels.ravel(), panels_wanted):
        name = f"{a} x {b}"
        index = {(r["friction"], _value_text(r[a]), _value_text(r[b])):
                 r["outcome"] for r in rows
                 if r["axis"] == name and r["kind"] == kind}
        xs, ys = AXES[a][0], AXES[b][0]
        for i, x in enumerate(xs):
            for j, y in enumerate(ys):
                for half, friction in enumerate((0.0, 0.5)):
                    state = index.get((friction, _value_text(x),
                                       _value_text(y)))
                    if state is not None:
                        ax.add_patch(Rectangle((i + 0.5 * half, j), 0.5, 1,
                                               color=COLOURS[state],
                                               ec="white"))
        ax.set_xlim(0, len(xs))
        ax.set_ylim(len(ys), 0)
        ax.set_xticks([i + 0.5 for i in range(len(xs))])
        ax.set_xticklabels([_value_text(x) for x in xs])
        ax.set_yticks([j + 0.5 for j in range(len(ys))])
        ax.set_yticklabels([_value_text(y) for y in ys])
        ax.set_xlabel(a)
        ax.set_ylabel(b)
        ax.set_title(f"{kind}: {name}")
    fig.legend(handles=[Patch(color=c, label=s) for s, c in COLOURS.items()],
               loc="lower center", ncol=len(COLOURS))
    fig.savefig(path, dpi=80)
    plt.close(fig)


def main(argv: Sequence[str] = ()) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--reduced", action="store_true",
                        help="each axis' two ends on one scene")
    parser.add_argument("--jobs", type=int, default=default_jobs(),
                        help="worker processes (default: one per core)")
    parser.add_argument("--budget", type=float, default=120.0,
                        help="seconds a cell may take before it is a hang")
    parser.add_argument("--pictures", type=Path,
                        default=ROOT / "docs" / "accuracy",
                        help="where extremes_axes.png and extremes_pairs.png "
                             "go ('' for none)")
    parser.add_argument("--frames", type=int, default=None,
                        help="frames per cell (default: each cell's own, 20)")
    parser.add_argument("--guard", action="store_true",
                        help="every soft body's tets with guard_inversion="
                             "True (stable Neo-Hookean made inversion-free); "
                             "give --json bench/results/extremes_guarded.json")
    add_json_argument(parser, "extremes")
    args = parser.parse_args(list(argv) or None)

    plan: List[Tuple[str, Cell]] = reduced_map() if args.reduced \
        else full_map()
    if args.guard:
        plan = [(axis, replace(cell, guard=True)) for axis, cell in plan]
    if args.frames is not None:
        if args.frames < 1:
            parser.error("--frames must be at least 1")
        plan = [(axis, replace(cell, frames=args.frames))
                for axis, cell in plan]
    cells = [cell for _, cell in plan]
    began = time.monotonic()
    bar, advance = _progress(len(cells))
    records = run_cells(cells, jobs=args.jobs, budget=args.budget,
                        done=advance)
    if bar is not None:
        bar.close()
    minutes = (time.monotonic() - began) / 60.0

    rows = []
    for (axis, cell), record in zip(plan, records):
        row = as_row(cell, record)
        row["axis"] = axis
        rows.append(row)
    counts = {state: sum(r["outcome"] == state for r in rows)
              for state in ALLOWED + FAILURES}
    results = Results("extremes")
    results.values.update(cells=len(rows), minutes=minutes, counts=counts,
                          rows=rows, reduced=args.reduced)
    summary = []
    for kind in KINDS:
        mine = [r for r in rows if r["kind"] == kind]
        if mine:
            summary.append([kind, len(mine)] + [
                sum(r["outcome"] == s for r in mine)
                for s in ALLOWED + FAILURES])
    results.table("summary", ["scene", "cells", *ALLOWED, *FAILURES],
                  summary, note=f"{len(rows)} cells in {minutes:.1f} min, "
                  f"{args.jobs} workers of one thread")
    results.table("axes", ["axis", "value", *KINDS],
                  axis_table(rows, list(AXES)),
                  note="H holds, W warned, S stopped (yasps named the "
                  "cause), X intersection; without / with friction 0.5")
    limits = [[r["cell"], r["friction"], r["outcome"], r["reason"],
               r["frames"], r["newton_per_frame"], r["seconds_per_frame"]]
              for r in rows if r["outcome"] != "holds"]
    results.table("limits", ["cell", "friction", "outcome", "reason",
                             "frames", "Newton/frame", "s/frame"], limits,
                  ["", "{:g}", "", "", "", "{:.1f}", "{:.3f}"])
    path = results.write(args.json)
    if str(args.pictures) and not args.reduced and not args.guard:
        args.pictures.mkdir(parents=True, exist_ok=True)
        draw_axes(rows, args.pictures / "extremes_axes.png")
        draw_pairs(rows, args.pictures / "extremes_pairs.png")
    failed = [r for r in rows if r["outcome"] in FAILURES]
    print(f"{len(rows)} cells in {minutes:.1f} min: " + ", ".join(
        f"{n} {s}" for s, n in counts.items() if n))
    for r in failed:
        print(f"  {r['outcome']}: {r['cell']} (friction {r['friction']:g}): "
              f"{r['reason']}")
    print(f"results: {path}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
