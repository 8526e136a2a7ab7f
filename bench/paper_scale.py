#!/usr/bin/env python3
"""The paper's Table 1 scene at the paper's scale, whole, on this machine.

`examples/paper/cloths_on_bunny.py --scale paper`: the 19,193-vertex bunny
(79,935 tets) dropped on a pinned cloth of 10,201 vertices, with one to
three cloth layers of 10,201 vertices dropped on it (39,595, 49,796 and
59,997 vertices), dt = 0.01 s, for the paper's 200 frames (or ``--frames``).
Every frame is checked for intersections by ipctk (``simulate``'s check,
apart from yasps' own queries). The table has the columns of the paper's
Table 1, with the paper's own rows for the same scene beside (an RTX 4090
and an i9-13900F; GIPC and YASPS as the paper ran them), and the last frame
of each run goes to ``docs/gallery/``.

    python3 bench/paper_scale.py [--layers 1 2 3] [--frames 200]
        [--threads 0] [--json PATH]

Long: on this project's 2-core machine one layer's 200 frames take tens of
minutes. Not part of the test command.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Any, Dict, List

import benchlib
from benchlib import ROOT
from benchlib.results import Results, add_json_argument

benchlib.use_this_checkout()

import yasps  # noqa: E402
from yasps.sim import simulate  # noqa: E402

sys.path.insert(0, str(ROOT / "examples" / "paper"))
import cloths_on_bunny  # noqa: E402

#: The paper's Table 1 (YASPS' un-optimised rows and GIPC's), per number of
#: cloth layers: vertices, diff total (s), diff average (ms), CG total (s),
#: CG average (ms), total (s), Newton iterations, CG iterations, frames.
PAPER: Dict[int, Dict[str, List[float]]] = {
    1: {"YASPS (paper, RTX 4090)": [39595, 53.25, 13.53, 44.91, 0.075, 139.31,
                                    3934, 597428, 200],
        "GIPC (paper, RTX 4090)": [39595, 25.46, 8.81, 156.32, 0.97, 199.06,
                                   2889, 160751, 200]},
    2: {"YASPS (paper, RTX 4090)": [49796, 81.23, 15.83, 68.91, 0.083, 218.29,
                                    5132, 825519, 200],
        "GIPC (paper, RTX 4090)": [49796, 49.02, 14.80, 264.09, 1.31, 342.76,
                                   3313, 200886, 200]},
    3: {"YASPS (paper, RTX 4090)": [59997, 124.64, 18.99, 95.36, 0.092, 328.51,
                                    6564, 1036455, 200],
        "GIPC (paper, RTX 4090)": [59997, 92.13, 11.12, 439.22, 0.67, 586.46,
                                   8287, 655328, 200]},
}

COLUMNS = ["layers", "system", "vertices", "diff total (s)",
           "diff avg (ms)", "CG total (s)", "CG avg (ms)", "total (s)",
           "Newton its", "CG its", "frames", "CG / Newton",
           "unconverged frames", "intersections (ipctk)"]
FORMATS = ["", "", "{:,}", "{:.2f}", "{:.2f}", "{:.2f}", "{:.3f}", "{:.1f}",
           "{:,}", "{:,}", "", "{:.0f}", "", ""]


def run_layers(layers: int, frames: int, output: Path) -> Dict[str, Any]:
    """Builds and runs the scene with ``layers`` cloth layers; returns its
    row's numbers and the picture of its last frame."""
    stepper, contact, bodies = cloths_on_bunny.build("paper", layers)
    vertices = sum(len(b.now()) for b in bodies.values())
    # The kernels first (compiled or loaded), as the example does, so that
    # the run's time is stepping only.
    contact.update()
    stepper.scene.evaluateEnergy()
    stepper.scene.minimizeEnergy(fixed=stepper.fixed)
    summary = simulate(stepper, bodies, frames, output, contact=contact,
                       video=False, bounds=((-2.6, -2.6, -1.6),
                                            (2.6, 2.6, 2.2)))
    r = summary.report
    diff = r.seconds["derivatives"] + r.seconds["assembly"]
    cg = r.seconds["pcg"]
    cg_its = sum(r.cg_iterations)
    last = max((k for k in summary.files if k.startswith("frame_")),
               key=lambda k: int(k.split("_")[1]))
    return {"row": [vertices, diff, 1e3 * diff / max(r.iterations, 1), cg,
                    1e3 * cg / max(cg_its, 1), summary.seconds, r.iterations,
                    cg_its, summary.frames, cg_its / max(r.iterations, 1),
                    len(r.unconverged),
                    "yes" if summary.intersections else "none"],
            "picture": summary.files[last],
            "stages": dict(r.seconds)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--layers", type=int, nargs="+", default=[1],
                        choices=(1, 2, 3))
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--threads", type=int, default=0,
                        help="yasps.config.num_threads (0: every core)")
    add_json_argument(parser, "paper_scale")
    args = parser.parse_args()
    yasps.config.num_threads = args.threads
    results = Results("paper_scale")
    rows: List[List[Any]] = []
    stages = {}
    for layers in args.layers:
        out = Path(tempfile.mkdtemp(prefix=f"yasps-paper-{layers}-"))
        measured = run_layers(layers, args.frames, out)
        threads = args.threads or len(os.sched_getaffinity(0))
        rows.append([layers, f"yasps (this CPU, {threads} threads)",
                     *measured["row"]])
        for system, numbers in PAPER[layers].items():
            rows.append([layers, system, *numbers,
                         numbers[7] / numbers[6], None, None])
        stages[str(layers)] = measured["stages"]
        picture = ROOT / "docs" / "gallery" / \
            f"cloths_on_bunny_paper_{layers}.png"
        shutil.copy(measured["picture"], picture)
        print(f"{layers} layer(s): " + ", ".join(
            f"{c} {f.format(v) if f else v}" for c, f, v in
            zip(COLUMNS[2:], FORMATS[2:], measured["row"])))
    results.values.update(stages=stages)
    results.table("table1", COLUMNS, rows, FORMATS,
                  note="yasps: wall time of the frames (collision detection, "
                       "CCD, line search and pictures included); the paper's "
                       "rows: its Table 1, 200 frames each")
    print(f"wrote {results.write(args.json)}")


if __name__ == "__main__":
    main()
