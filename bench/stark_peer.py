#!/usr/bin/env python3
"""yasps against STARK on two whole contact scenes, one and two threads.

The scenes (bench/benchlib/stark_scenes.py): A, the twisting cloth of
examples/paper/mat_twist.py (625 vertices, 100 frames), and B, a soft tet
bunny (bunny-1.8k.msh) dropped onto a cloth pinned at its corners (2,494
vertices, 60 frames). Both at dt = 0.01 s, no friction, dhat = 1e-3 m,
block-diagonal PCG to relative residual 1e-4, Newton until its step is
below 1e-2 m/s, kernels warm. STARK gets yasps' own meshes, identical
stable Neo-Hookean constants, a Neo-Hookean membrane and a bending
stiffness matched to yasps' Baraff-Witkin cloth at small strain, and stiff
springs (1e5 N/m) where yasps fixes DoFs; every other set-up difference is
listed in docs/benchmarks.md ("yasps against STARK, whole contact
scenes").

yasps ships no STARK code: the script builds STARK with its Python
bindings (pystark) from the checkout given, with CMake into --build-dir
(kept between runs: the build, and the code STARK generates and compiles
at its first run, take minutes once), then runs each scene on each side in
its own process, side by side for each thread count: STARK through
bench/stark_driver.py (our code on pystark's public API), yasps through
bench/benchlib/stark_scenes.py. Every frame of both is checked by ipctk, apart from
either code: intersections and the closest distance. It prints per scene
and thread count the seconds per frame (compilation and STARK's
initialisation excluded), Newton iterations per frame, CG iterations per
Newton iteration, unconverged frames, the closest distance, ipctk's
verdict, a physical comparison of both results, and the ratios STARK /
yasps. With --rounds N each thread count runs both sides N times in turn
and the figures come from each side's median round (by seconds per
frame), with every round's seconds and ratios printed too.

    python3 bench/stark_peer.py --stark DIR [--frames-a 100 --frames-b 60]
        [--threads 1 2] [--rounds 1] [--scenes A B] [--quick] [--per-frame]
        [--build-dir /tmp/stark-build] [--build-wrapper "flock LOCK nice"]
        [--stark-wait-policy passive|active|default] [--json RESULTS.json]
        [--no-run]

STARK needs CMake >= 3.24, a C++20 compiler and nanobind from pip (``pip
install nanobind``; its own CMake would fetch nanobind from GitHub). The
build force-includes <cstddef> (a SymX header GCC 12 rejects without it)
and writes nothing into the checkout: pystark's module goes to
--build-dir/python/pystark, beside links to the checkout's Python files.
--build-wrapper prefixes every compile: CMake's, STARK's run-time code
generation (through CXX) and yasps' kernel compilation (a warm-up run),
e.g. "flock /tmp/build.lock nice -n 10". STARK's OpenMP threads wait as
STARK ships them (spinning a while); ``--stark-wait-policy passive`` makes
them sleep, which a machine busy with other work needs for two threads and
which costs STARK's PCG twice its time on an idle 2-core one. ``--quick``
runs 5 frames of each scene, to check that everything works; ``--no-run``
only summarises the runs an earlier invocation left in --build-dir/runs.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Dict, List, Optional, Tuple

HERE = Path(__file__).resolve().parent
import benchlib  # noqa: E402

benchlib.use_this_checkout()
from benchlib.results import RESULTS, Results, add_json_argument  # noqa: E402

import numpy as np  # noqa: E402

from benchlib import stark_scenes  # noqa: E402

SCENES = {"A": ("twist", "A, twisting cloth"),
          "B": ("bunny", "B, bunny on pinned cloth"),
          "B-4.3k": ("bunny-4.3k", "B at 4,270 vertices"),
          "B-28.6k": ("bunny-28.6k", "B at 28,602 vertices"),
          "B-56k": ("bunny-56k", "B at 56,442 vertices")}
#: The scale series (--series): scene B grown from 2,494 to 56,442 vertices
#: (bench/benchlib/stark_scenes.py, BUNNY_SIZES).
SERIES = ("B", "B-4.3k", "B-28.6k", "B-56k")
SIDES = ("STARK", "yasps")
Run = Dict[str, np.ndarray]


# --- building STARK -----------------------------------------------------------

#: Included after STARK's project(): puts pystark's module into the build
#: tree (STARK's CMake writes it into the checkout's pystark/pystark).
OUTPUT_OVERRIDE = """\
# Written by yasps' bench/stark_peer.py.
function(_yasps_pystark_output)
  if(TARGET pystark)
    set_target_properties(pystark PROPERTIES
                          LIBRARY_OUTPUT_DIRECTORY "${YASPS_PYSTARK_DIR}")
  endif()
endfunction()
cmake_language(DEFER CALL _yasps_pystark_output)
"""


def run_logged(command: List[str], log: Path, what: str,
               env: Optional[Dict[str, str]] = None) -> None:
    """Runs ``command`` with its output to ``log``; stops with the log's
    tail if it fails."""
    print("  $ " + shlex.join(command), flush=True)
    with open(log, "w") as out:
        done = subprocess.run(command, stdout=out, stderr=subprocess.STDOUT,
                              env=env)
    if done.returncode != 0:
        sys.stdout.write(log.read_text()[-6000:])
        raise SystemExit(f"stark_peer: {what} failed ({done.returncode}); "
                         f"see {log}")


def nanobind_dir() -> str:
    """nanobind's CMake package from pip."""
    done = subprocess.run([sys.executable, "-m", "nanobind", "--cmake_dir"],
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit("stark_peer: pystark needs nanobind: pip install "
                         "nanobind (STARK's own CMake would fetch it from "
                         "GitHub)")
    return done.stdout.strip()


def build_stark(stark: Path, build: Path, wrapper: List[str],
                jobs: int) -> Path:
    """Configures and builds pystark from the checkout ``stark`` into
    ``build``; returns the folder to put on PYTHONPATH."""
    if not (stark / "pystark" / "cpp" / "CMakeLists.txt").is_file():
        raise SystemExit(f"stark_peer: {stark} is not a STARK checkout (no "
                         "pystark/cpp/CMakeLists.txt)")
    cmake = shutil.which("cmake")
    version = subprocess.run([cmake, "--version"], capture_output=True,
                             text=True).stdout if cmake else ""
    found = re.search(r"(\d+)\.(\d+)", version)
    # 3.24: FetchContent tries find_package first (nanobind from pip).
    if not found or tuple(map(int, found.groups())) < (3, 24):
        raise SystemExit("stark_peer: building STARK needs CMake >= 3.24 "
                         f"(found {version.split(chr(10))[0] or 'none'})")
    build.mkdir(parents=True, exist_ok=True)
    override = build / "pystark_output.cmake"
    override.write_text(OUTPUT_OVERRIDE)
    package = build / "python" / "pystark"
    package.mkdir(parents=True, exist_ok=True)
    print(f"STARK: building pystark from {stark} into {build}", flush=True)
    run_logged(wrapper + [
        cmake, "-S", str(stark), "-B", str(build / "cmake"),
        "-DCMAKE_BUILD_TYPE=Release",
        "-DSTARK_BUILD_PYTHON_BINDINGS=ON", "-DSTARK_BUILD_EXAMPLES=OFF",
        f"-DSTARK_PYTHON_EXECUTABLE={sys.executable}",
        # nanobind from pip, nothing fetched (CMake >= 3.24).
        "-DFETCHCONTENT_TRY_FIND_PACKAGE_MODE=ALWAYS",
        "-DFETCHCONTENT_FULLY_DISCONNECTED=ON",
        f"-Dnanobind_DIR={nanobind_dir()}",
        # SymX's solver/mesh_ordering.h uses size_t without <cstddef>.
        "-DCMAKE_CXX_FLAGS=-include cstddef",
        f"-DCMAKE_PROJECT_stark_INCLUDE={override}",
        f"-DYASPS_PYSTARK_DIR={package}"], build / "configure.log",
        "configuring STARK")
    run_logged(wrapper + [cmake, "--build", str(build / "cmake"),
                          f"-j{jobs}", "--target", "pystark"],
               build / "build.log", "building pystark")
    # The package: the module just built beside the checkout's Python files.
    for source in (stark / "pystark" / "pystark").glob("*.py"):
        link = package / source.name
        if link.is_symlink() or link.exists():
            link.unlink()
        link.symlink_to(source.resolve())
    return package.parent


def commit(folder: Path) -> str:
    """The checkout's commit, "+changes" where its work tree differs."""
    def git(*words: str) -> str:
        done = subprocess.run(["git", "-C", str(folder), *words],
                              capture_output=True, text=True)
        return done.stdout.strip() if done.returncode == 0 else ""
    head = git("rev-parse", "--short", "HEAD") or "unknown"
    changed = git("status", "--porcelain", "--untracked-files=no")
    return head + (" +changes" if changed else "")


# --- running both sides --------------------------------------------------------

def thread_env(threads: int) -> Dict[str, str]:
    """The environment of a side's process on ``threads`` threads."""
    env = dict(os.environ)
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                "YASPS_NUM_THREADS"):
        env[var] = str(threads)
    return env


def run_side(command: List[str], env: Dict[str, str], output: Path,
             log: Path, what: str) -> Run:
    """Runs a side's process; returns the arrays it wrote to ``output``."""
    run_logged(command, log, what, env)
    return load_run(output)


def run_stark(scene_dir: Path, frames: int, threads: int, python: Path,
              build: Path, wrapper: List[str], work: Path, tag: str,
              wait_policy: str) -> Run:
    """STARK on the scene exported to ``scene_dir`` (bench/stark_driver.py
    with the pystark in ``python``)."""
    env = thread_env(threads)
    env["PYTHONPATH"] = os.pathsep.join(
        [str(python)] + [p for p in [env.get("PYTHONPATH")] if p])
    # STARK's OpenMP threads spin a while between parallel regions by
    # default: on a machine with no spare core that starves whatever else
    # runs (the author needed "passive" on a busy 2-core machine);
    # on an idle one, sleeping costs STARK's PCG a wake-up per region.
    env.pop("OMP_WAIT_POLICY", None)
    if wait_policy != "default":
        env["OMP_WAIT_POLICY"] = wait_policy
    # SymX compiles the code STARK generates with $CXX.
    compiler = os.environ.get("CXX") or shutil.which("g++") or "g++"
    env["CXX"] = shlex.join(wrapper + shlex.split(compiler))
    output = work / f"stark-{scene_dir.name}-{tag}.npz"
    codegen = build / "codegen"
    codegen.mkdir(parents=True, exist_ok=True)
    return run_side([sys.executable, str(HERE / "stark_driver.py"),
                     str(scene_dir), "--frames", str(frames), "--threads",
                     str(threads), "--codegen", str(codegen), "--output",
                     str(output)], env, output,
                    work / f"stark-{scene_dir.name}-{tag}.log",
                    f"STARK on {scene_dir.name}")


def load_run(path: Path) -> Run:
    """A side's per-frame arrays, as its process wrote them."""
    with np.load(path) as data:
        return {k: data[k] for k in data.files}


def run_yasps(scene: str, frames: int, threads: int, wrapper: List[str],
              work: Path, tag: str, newton_cap: Optional[int]) -> Run:
    """yasps on the scene (bench/benchlib/stark_scenes.py), after a warm-up run that
    compiles its kernels under the build wrapper."""
    env = thread_env(threads)
    script = [sys.executable, str(HERE / "stark_yasps_side.py"), scene]
    if newton_cap is not None:
        script += ["--newton-cap", str(newton_cap)]
    output = work / f"yasps-{scene}-{tag}.npz"
    log = work / f"yasps-{scene}-{tag}.log"
    # Kernels compiled (or loaded from the cache) under the wrapper first.
    run_logged(wrapper + script + ["--frames", "0", "--threads", "1",
                                   "--output", str(output)], log,
               f"compiling yasps' kernels for {scene}", env)
    return run_side(script + ["--frames", str(frames), "--threads",
                              str(threads), "--output", str(output)],
                    env, output, log, f"yasps on {scene}")


# --- figures ----------------------------------------------------------------------

def summarise(spec: stark_scenes.Spec, runs: List[Run], side: str,
              checker: stark_scenes.Checker) -> Dict:
    """A side's figures from its median round by seconds per frame (on
    several threads the rounds' counts differ too: round-off changes the
    path), with every round's seconds and Newton iterations per frame;
    every frame of every round checked by ipctk."""
    rounds = [float(r["seconds"].mean()) for r in runs]
    run = runs[int(np.argsort(rounds)[(len(runs) - 1) // 2])]
    frames = len(run["seconds"])
    verdicts = [[checker(V) for V in r["positions"][1:]] for r in runs]
    directions = float(run["directions"].sum())
    unconverged = (np.flatnonzero(run["failed"] > 0) if side == "STARK"
                   else np.flatnonzero(run["converged"] < 0.5)) + 1
    total = float(run["seconds"].sum())
    split = {str(k): float(v) / total
             for k, v in zip(run["timer_names"], run["timer_seconds"])}
    if side == "yasps":
        # Its stages are disjoint: the rest is Python around them (the
        # predictions, the stepper's bookkeeping).
        split["other"] = 1.0 - sum(split.values())
    figures = {
        "frames": frames,
        "s/frame": float(run["seconds"].mean()),
        "s/frame, each round": rounds,
        "Newton/frame, each round": [float(r["directions"].sum()) / frames
                                     for r in runs],
        "Newton/frame": directions / frames,
        "CG/Newton": float(run["cg"].sum()) / max(directions, 1.0),
        "unconverged frames": [int(f) for f in unconverged],
        "closest distance (m)": min(d for v in verdicts for _, d in v),
        "intersecting frames": sorted({i + 1 for v in verdicts
                                       for i, (x, _) in enumerate(v) if x}),
        "per frame": [dict(s=float(s), directions=int(n), cg=int(c),
                           crossing=x, closest=d)
                      for s, n, c, (x, d) in zip(run["seconds"],
                                                 run["directions"], run["cg"],
                                                 verdicts[0])],
        "physics": stark_scenes.physics(spec, run["positions"][-1]),
        "stiffness": float(run["stiffness"][-1]),
        "solves at the CG cap": int(run["capped"].sum()),
        "split": dict(sorted(split.items(), key=lambda item: -item[1])),
    }
    figures["retried solves"] = int(run["solves"].sum() - directions)
    figures["peak memory (MB)"] = float(run["peak_rss_kb"]) / 1024 \
        if "peak_rss_kb" in run else float("nan")
    # The linear solves' time over their CG iterations (STARK's
    # linear_system_solve timer; yasps' pcg stage, preconditioner setup
    # included on both sides).
    solve_timer = "linear_system_solve" if side == "STARK" else "pcg"
    solve_seconds = {str(k): float(v) for k, v in
                     zip(run["timer_names"], run["timer_seconds"])}
    figures["ms/CG iteration"] = 1e3 * solve_seconds.get(
        solve_timer, float("nan")) / max(float(run["cg"].sum()), 1.0)
    if side == "STARK":
        figures["time steps"] = int(run["steps"].sum())
        figures["failed attempts"] = int(run["failed"].sum())
    else:
        figures["Newton cap"] = int(run["newton_cap"])
        figures["projection"] = str(run["projection"])
    if "angle" in run:
        figures["edge angle (rad)"] = [float(a) for a in run["angle"]]
    return figures


def cell(value) -> str:
    """A table cell: lists as their length and first entries."""
    if isinstance(value, list):
        return str(len(value)) + (f" ({', '.join(map(str, value[:8]))}"
                                  f"{', ...' if len(value) > 8 else ''})"
                                  if value else "")
    if isinstance(value, float):
        return f"{value:.3g}" if abs(value) < 1e-2 or abs(value) >= 1e3 \
            else f"{value:.3f}"
    return str(value)


def scene_table(title: str, results: Dict[int, Dict[str, Dict]]
                ) -> Tuple[List[str], List[List[str]]]:
    """The table of a scene, columns and rows of cells: per thread count
    STARK, yasps and STARK / yasps."""
    header = [title]
    for threads in results:
        header += [f"STARK {threads}T", f"yasps {threads}T",
                   f"STARK/yasps {threads}T"]
    rows = []
    first = next(iter(results.values()))
    keys = ["s/frame", "Newton/frame", "CG/Newton", "unconverged frames",
            "closest distance (m)", "intersecting frames"] + \
        list(first["STARK"]["physics"])
    for key in keys:
        cells = [key]
        for sides in results.values():
            values = [sides[s]["physics"][key] if key in sides[s]["physics"]
                      else sides[s][key] for s in SIDES]
            cells += [cell(v) for v in values]
            ratio = ""
            if key in ("s/frame", "Newton/frame", "CG/Newton"):
                ratio = f"{values[0] / values[1]:.2f}x"
            cells.append(ratio)
        rows.append(cells)
    return header, rows


def markdown(columns: List[str], rows: List[List[str]]) -> List[str]:
    """A Markdown table of cells."""
    return ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)] + \
        ["| " + " | ".join(r) + " |" for r in rows]


def round_rows(key: str, results: Dict[int, Dict[str, Dict]]) -> List[List]:
    """Each round's seconds per frame of both sides and their ratio."""
    rows = []
    for threads, sides in results.items():
        pairs = zip(*(sides[s]["s/frame, each round"] for s in SIDES))
        for number, (stark, ours) in enumerate(pairs, 1):
            rows.append([key, threads, number, stark, ours, stark / ours])
    return rows


def split_rows(key: str, results: Dict[int, Dict[str, Dict]]) -> List[List]:
    """Each side's shares of its time (one thread, else the fewest), the
    largest first."""
    sides = results[min(results)]
    rows = []
    for side in SIDES:
        for stage, share in sides[side]["split"].items():
            rows.append([key, side, stage, 100 * share])
    return rows


def notes(results: Dict[int, Dict[str, Dict]], gaps: Dict[int, float],
          leading: str) -> List[str]:
    """The figures that are not in the table."""
    lines = []
    for threads, sides in results.items():
        stark, ours = sides["STARK"], sides["yasps"]
        lines.append(
            f"{threads} thread(s): STARK took {stark['time steps']} time steps "
            f"({stark['failed attempts']} attempts rejected and retried), "
            f"retried {stark['retried solves']} linear solves with more "
            f"projection, contact stiffness at the end {stark['stiffness']:.3g}; "
            f"yasps ({ours['projection']} projection, Newton cap "
            f"{ours['Newton cap']}) retried {ours['retried solves']}, its "
            f"kappa at the end {ours['stiffness']:.3g}; solves at "
            f"the CG cap: STARK {stark['solves at the CG cap']} (of 10,000), "
            f"yasps {ours['solves at the CG cap']} (of 1,000); largest "
            f"difference of the {leading} over the frames {gaps[threads]:.3g}")
        if len(stark["s/frame, each round"]) > 1:
            ratios = [a / b for a, b in zip(stark["s/frame, each round"],
                                            ours["s/frame, each round"])]
            lines.append("  s/frame STARK / yasps, each round: "
                         + " ".join(f"{r:.2f}x" for r in ratios))
            for side in SIDES:
                lines.append(f"  {side}, each round: s/frame " + " ".join(
                    f"{x:.3f}" for x in sides[side]["s/frame, each round"])
                    + ", Newton/frame " + " ".join(
                    f"{x:.2f}" for x in sides[side]["Newton/frame, each round"]))
        for side, what in zip(SIDES, ("its timers, nested", "its stages")):
            top = list(sides[side]["split"].items())[:7]
            lines.append(f"  {side}'s time ({what}): " + ", ".join(
                f"{k} {100 * v:.0f}%" for k, v in top))
        if "edge angle (rad)" in ours:
            reached, wanted = ours["edge angle (rad)"]
            lines.append(f"  yasps' held edges reached {reached:.3f} rad of "
                         f"the prescribed {wanted:.3f} (their motion is "
                         "limited by CCD)")
    return lines


def per_frame(results: Dict[int, Dict[str, Dict]]) -> List[str]:
    """Every frame of both sides (their median rounds)."""
    lines = []
    for threads, sides in results.items():
        lines.append(f"{threads} thread(s), per frame: seconds, Newton "
                     "directions, CG, closest distance, ipctk intersection")
        rows = zip(*(sides[s]["per frame"] for s in SIDES))
        for frame, pair in enumerate(rows, 1):
            lines.append(f"  {frame:4d}  " + "  |  ".join(
                f"{s} {r['s']:.3f} {r['directions']:3d} {r['cg']:6d} "
                f"{r['closest']:.2e} {'CROSSING' if r['crossing'] else 'ok'}"
                for s, r in zip(SIDES, pair)))
    return lines


#: The scale series' columns: (figure of summarise(), its header, format).
SERIES_FIGURES = (("s/frame", "s/frame", "{:.3f}"),
                  ("Newton/frame", "Newton/frame", "{:.1f}"),
                  ("CG/Newton", "CG/Newton", "{:.0f}"),
                  ("ms/CG iteration", "ms/CG iteration", "{:.3f}"),
                  ("peak memory (MB)", "peak memory (MB)", "{:.0f}"))


def series_table(measured: Dict[str, Dict]
                 ) -> Tuple[List[str], List[List], List[str]]:
    """The scale series: per size and thread count, both sides' figures
    side by side, the ratio STARK / yasps of the seconds per frame, and
    each side's three largest stages."""
    columns = ["vertices", "threads"]
    formats = ["{:,}", "{}"]
    for _, header, form in SERIES_FIGURES:
        columns += [f"{header} STARK", f"{header} yasps"]
        formats += [form, form]
    columns += ["STARK/yasps s/frame", "unconverged STARK / yasps",
                "intersecting frames", "STARK's stages", "yasps' stages"]
    formats += ["{:.2f}x", "{}", "{}", "{}", "{}"]
    rows = []
    for entry in measured.values():
        for threads, sides in entry["results"].items():
            row: List = [entry["vertices"], threads]
            for figure, _, _ in SERIES_FIGURES:
                row += [sides[side][figure] for side in SIDES]
            row.append(sides["STARK"]["s/frame"] / sides["yasps"]["s/frame"])
            row.append(" / ".join(str(len(sides[side]["unconverged frames"]))
                                  for side in SIDES))
            row.append(sum(len(sides[side]["intersecting frames"])
                           for side in SIDES))
            for side in SIDES:
                top = list(sides[side]["split"].items())[:3]
                row.append(", ".join(f"{k} {100 * v:.0f}%" for k, v in top))
            rows.append(row)
    return columns, rows, formats


def plot_series(measured: Dict[str, Dict], path: Path) -> Path:
    """Seconds per frame and CG iterations per Newton iteration against
    the vertices, both sides, one line per side and thread count, on log
    axes: what a user of each pays as the scene grows."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    vertices = [entry["vertices"] for entry in measured.values()]
    threads = sorted({t for entry in measured.values()
                      for t in entry["results"]})
    figure, axes = plt.subplots(1, 2, figsize=(10, 4))
    for side, colour in zip(SIDES, ("tab:grey", "tab:blue")):
        for count, style in zip(threads, ("-", "--", ":")):
            for axis, key in zip(axes, ("s/frame", "CG/Newton")):
                axis.plot(vertices, [entry["results"][count][side][key]
                                     for entry in measured.values()],
                          style, marker="o", color=colour,
                          label=f"{side}, {count} thread(s)")
    for axis, label in zip(axes, ("seconds per frame",
                                  "CG iterations per Newton iteration")):
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.set_xticks(vertices, [f"{v:,}" for v in vertices])
        axis.minorticks_off()
        axis.set_xlabel("vertices")
        axis.set_ylabel(label)
        axis.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8)
    figure.suptitle("Bunny on a pinned cloth, grown (bench/stark_peer.py "
                    "--series)")
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--stark", type=Path, required=True, help="STARK checkout")
    parser.add_argument("--scenes", nargs="+", choices=sorted(SCENES),
                        default=sorted(SCENES))
    parser.add_argument("--frames-a", type=int, default=100)
    parser.add_argument("--frames-b", type=int, default=60)
    parser.add_argument("--series", action="store_true",
                        help="the scale series: scene B at 2,494, 4,270, "
                        "28,602 and 56,442 vertices (--frames-series each), "
                        "its table and its plot (--plot)")
    parser.add_argument("--frames-series", type=int, default=30)
    parser.add_argument("--plot", type=Path,
                        default=HERE.parent / "docs" / "benchmarks" /
                        "stark_series.png",
                        help="where --series draws cost against vertices")
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--rounds", type=int, default=1,
                        help="runs of each side per thread count, in turn; "
                        "s/frame is their median")
    parser.add_argument("--quick", action="store_true",
                        help="5 frames of each scene")
    parser.add_argument("--per-frame", action="store_true",
                        help="print every frame's figures")
    parser.add_argument("--build-dir", type=Path,
                        default=Path(tempfile.gettempdir()) / "stark-build")
    parser.add_argument("--build-wrapper", default="",
                        help="command prefixed to every compile, e.g. "
                        "'flock /tmp/build.lock nice -n 10'")
    parser.add_argument("--jobs", type=int, default=2, help="parallel build jobs")
    parser.add_argument("--stark-wait-policy", default="default",
                        choices=("passive", "active", "default"),
                        help="STARK's OMP_WAIT_POLICY ('default': unset, as "
                        "STARK ships; 'passive' where other work shares "
                        "the cores)")
    parser.add_argument("--yasps-newton-cap", type=int, default=None,
                        help="yasps' Newton cap (default: ImplicitEuler's)")
    parser.add_argument("--no-run", action="store_true",
                        help="build nothing, run nothing: summarise the "
                        "runs an earlier invocation left in --build-dir")
    parser.add_argument("--measured-at", default="unknown",
                        help="with --no-run: the yasps commit the runs "
                        "measured, where they do not record it (runs "
                        "before they did)")
    add_json_argument(parser, "stark_peer")
    args = parser.parse_args()
    if args.quick:
        args.frames_a = args.frames_b = args.frames_series = 5
    if args.series:
        args.scenes = list(SERIES)
        # The series keeps its own results, beside scenes A and B's.
        if args.json == RESULTS / "stark_peer.json":
            args.json = RESULTS / "stark_series.json"
    wrapper = shlex.split(args.build_wrapper)
    build = args.build_dir.resolve()
    # yasps' kernels are kept between runs too.
    os.environ.setdefault("YASPS_CACHE_DIR", str(build / "yasps-cache"))
    python = build / "python" if args.no_run else \
        build_stark(args.stark.resolve(), build, wrapper, args.jobs)

    frames = {key: args.frames_series for key in SERIES[1:]}
    frames.update(A=args.frames_a,
                  B=args.frames_series if args.series else args.frames_b)
    versions = {"yasps": commit(HERE.parent), "STARK": commit(args.stark)}
    print(f"yasps at {versions['yasps']}, STARK at {versions['STARK']}; "
          f"threads {args.threads}, {args.rounds} round(s); STARK's "
          f"OMP_WAIT_POLICY {args.stark_wait_policy}")
    everything: Dict[str, Dict] = {"versions": versions}
    out = Results("stark_peer")
    measured: set = set()
    rounds: List[List] = []
    shares: List[List] = []
    work = build / "runs"
    work.mkdir(exist_ok=True)
    for key in args.scenes:
        name, title = SCENES[key]
        scene = stark_scenes.SCENES[name]()
        spec = scene.spec
        scene_dir = work / name
        constants = stark_scenes.export(spec, scene_dir)
        checker = stark_scenes.Checker(spec)
        shown = {k: constants[k] for k in ("cloth", "bunny", "contact",
                                           "pin_stiffness") if k in constants}
        print(f"\nscene {title}: {len(spec.vertices):,} vertices, "
              f"{frames[key]} frames; STARK's constants: {json.dumps(shown)}",
              flush=True)
        results: Dict[int, Dict[str, Dict]] = {}
        gaps: Dict[int, float] = {}
        for threads in args.threads:
            runs: Dict[str, List[Run]] = {side: [] for side in SIDES}
            # Side by side: each round runs STARK, then yasps.
            for round_ in range(args.rounds):
                tag = f"{threads}t-{round_}"
                if args.no_run:
                    for side in SIDES:
                        runs[side].append(load_run(
                            work / f"{side.lower()}-{name}-{tag}.npz"))
                    continue
                runs["STARK"].append(run_stark(scene_dir, frames[key], threads,
                                               python, build, wrapper, work,
                                               tag, args.stark_wait_policy))
                runs["yasps"].append(run_yasps(name, frames[key], threads,
                                               wrapper, work, tag,
                                               args.yasps_newton_cap))
            if args.no_run:
                # The yasps commit those runs measured, where they say.
                measured.update(str(r["commit"]) if "commit" in r
                                else args.measured_at for r in runs["yasps"])
            results[threads] = {side: summarise(spec, runs[side], side,
                                                checker) for side in SIDES}
            gaps[threads] = stark_scenes.trajectory_gap(
                spec, runs["STARK"][0]["positions"],
                runs["yasps"][0]["positions"])
        leading = next(iter(results[args.threads[0]]["STARK"]["physics"]))
        print()
        columns, rows = scene_table(f"scene {title}", results)
        print("\n".join(markdown(columns, rows)))
        out.table(name, columns, rows)
        rounds += round_rows(key, results)
        shares += split_rows(key, results)
        print("\n".join(notes(results, gaps, leading)))
        if args.per_frame:
            print("\n".join(per_frame(results)))
        everything[key] = dict(constants=constants, gaps=gaps,
                               results=results,
                               vertices=len(spec.vertices))
    series = [key for key in SERIES if key in everything]
    if args.series and series:
        columns, rows, formats = series_table(
            {key: everything[key] for key in series})
        print("\n" + "\n".join(markdown(columns, [
            [f.format(c) if c is not None else "" for f, c in zip(formats, r)]
            for r in rows])))
        out.table("series", columns, rows, formats,
                  note="Scene B grown: bunny-1.8k on 25 x 25 and 49 x 49 "
                  "cloths, bunny-19k on 97 x 97 and 193 x 193.")
        print(f"plot: {plot_series({key: everything[key] for key in series}, args.plot)}")
    out.table("rounds", ["scene", "threads", "round", "STARK s/frame",
                         "yasps s/frame", "STARK/yasps"], rounds,
              ["", "", "", "{:.3f}", "{:.3f}", "{:.2f}x"])
    out.table("split", ["scene", "side", "stage", "share of a frame (%)"],
              shares, ["", "", "", "{:.0f}"],
              note="STARK's timers nest (their shares may sum past 100%); "
              "yasps' stages are disjoint, 'other' is Python around them.")
    if args.no_run:
        out.meta["commit"] = ", ".join(sorted(measured))
        out.meta["command"] += " (summarised from earlier runs)"
    everything["STARK wait policy"] = args.stark_wait_policy
    out.values = everything
    print(f"\nresults: {out.write(args.json)}")


if __name__ == "__main__":
    main()
