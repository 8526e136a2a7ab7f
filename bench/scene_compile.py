#!/usr/bin/env python3
"""Time to first frame per scene: building the scene and ``yasps.compile``,
cold (a fresh process and an empty kernel cache) and warm (a new process
with the cache the cold run left), with the kernel count. Building cold
includes compiling what building computes (Contact's world positions for
its collision mesh).

Scenes: the README demo (examples/contact_demo.py), the same three bodies
with contact and friction at 209 vertices ("three"), and the paper's
scenes of examples/paper at small scale (the repulsive curve, which has no
Newton system of this kind, is left out). Each measurement runs in a
process of its own, ``--repeat`` times; the table has the medians.

    python3 bench/scene_compile.py [--repeat 2] [--scenes demo,three,...]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from typing import Callable, Tuple

import benchlib  # noqa: E402

benchlib.use_this_checkout()
from benchlib import ROOT  # noqa: E402
from benchlib.results import Results, add_json_argument  # noqa: E402

sys.path[1:1] = [str(ROOT / "examples"), str(ROOT / "examples" / "paper")]

SCENES = ["demo", "three", "cloths_on_bunny", "many_bunnies",
          "caged_bunny_tet4", "caged_bunny_hex8", "mixed_materials",
          "pendulum", "mat_twist"]


def _builder(name: str) -> Callable[[], Tuple[object, list]]:
    """A function that builds the scene ``name`` and returns (scene,
    attributes to compile besides its energies); its modules are imported
    here, so that timing it times building alone."""
    if name in ("demo", "three"):
        # "three": the demo's bodies at 8x8 cloth cells and 3^3 box cells,
        # 209 vertices.
        import contact_demo
        sizes = (40, 4) if name == "demo" else (8, 3)

        def demo():
            s, _, contact, bodies = contact_demo.build(*sizes)
            return s, [contact.positions, bodies["rigid"].positions]
        return demo
    if name == "pendulum":
        import pendulum
        return lambda: (pendulum.build()[0], [])
    if name.startswith("caged_bunny"):
        import caged_bunny
        module = caged_bunny
        arguments = ("small", name.rsplit("_", 1)[1], 6)
    else:
        module = __import__(name)
        arguments = ("small",) + {"cloths_on_bunny": (1,),
                                  "many_bunnies": (4,)}.get(name, ())

    def paper():
        stepper, contact, bodies, *_ = module.build(*arguments)
        shown = [b.positions for b in bodies.values()
                 if b.positions.kind not in ("data", "constant")]
        return stepper.scene, [contact.positions] + shown
    return paper


def worker(name: str) -> dict:
    """In a fresh process: builds the scene and compiles it."""
    import yasps
    build = _builder(name)
    start = time.perf_counter()
    s, also = build()
    built = time.perf_counter() - start
    summary = yasps.compile(s, also=also, progress=False)
    return {"build": built, "compile": summary.seconds,
            "kernels": summary.kernels, "compiled": summary.compiled}


def run_worker(name: str, cache: str) -> dict:
    env = dict(os.environ, YASPS_CACHE_DIR=cache)
    done = subprocess.run([sys.executable, __file__, "--worker", name],
                          env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{name}: {done.stderr[-2000:]}")
    return json.loads(done.stdout.splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--scenes", default=",".join(SCENES))
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    add_json_argument(parser, "scene_compile")
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(args.worker)))
        return
    columns = ["scene", "build, cold (s)", "build, warm (s)", "kernels",
               "compile, cold (s)", "compile, warm (s)"]
    formats = ["", "{:.2f}", "{:.2f}", "", "{:.2f}", "{:.2f}"]
    print("| " + " | ".join(columns) + " |")
    print("|" + " --- |" * len(columns))
    rows = []
    for name in args.scenes.split(","):
        cold, warm = [], []
        for _ in range(args.repeat):
            with tempfile.TemporaryDirectory() as cache:
                cold.append(run_worker(name, cache))
                warm.append(run_worker(name, cache))
        assert all(w["compiled"] == 0 for w in warm), f"{name} recompiled"

        def median(runs, key):
            return statistics.median(r[key] for r in runs)

        rows.append([name, median(cold, "build"), median(warm, "build"),
                     cold[0]["kernels"], median(cold, "compile"),
                     median(warm, "compile")])
        print("| " + " | ".join(f.format(v) if f else str(v)
                                for v, f in zip(rows[-1], formats)) + " |",
              flush=True)
    results = Results("scene_compile")
    results.table("scenes", columns, rows, formats,
                  note=f"Medians of {args.repeat} runs, each in a process "
                  "of its own.")
    print(f"results: {results.write(args.json)}")


if __name__ == "__main__":
    main()
