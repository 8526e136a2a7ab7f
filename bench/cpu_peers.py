#!/usr/bin/env python3
"""yasps on the CPU against TinyAD and SymX on the same work, one thread.

The work is bench/benchlib/elastic_scenes.py's: stable Neo-Hookean (yasps.energies'
formula: dt2 = 1e-4, mu = 1e4, lambda = 4e4, alpha = 1 + 3 mu / (4 lambda))
plus inertia (mass 1e-3) on the tets of ../shared/data/bunny-<mesh>.msh,
the vertices moved by normal noise of 1e-3 (seed 0). Three stages are timed
(wall time, one thread each; the median of --repeat runs, in each of --rounds
rounds that run every tool in turn, and the median over rounds; with several
rounds, each round's ratios are printed too):

1. per tet: gradient + Hessian of the elastic energy, into per-tet buffers;
2. per tet: gradient + PSD-projected Hessian (eigenvalues clamped at 0);
   the table says what each tool projects;
3. one Newton direction: derivatives, projection, assembly and a PCG solve
   to relative residual 1e-4 (yasps: ``minimizeEnergy``, warm; TinyAD:
   ``ScalarFunction.eval_with_hessian_proj`` + Eigen's ConjugateGradient
   with its diagonal preconditioner; SymX: its second-order path,
   ``SecondOrderCompiledGlobal`` + ``ElementHessians`` projection and
   assembly + its block-diagonal PCG), and of it the solve alone.

yasps ships no peer code: the script configures bench/cpp/peers (our
drivers, which call the peers' public API) with the checkouts given here,
builds them with CMake into --build-dir (kept between runs; SymX's library
and the code it generates are built once) and runs them. Before timing, it
checks every peer's per-tet gradients and unprojected Hessians against
yasps' on the first --check tets and stops if they disagree.

    python3 bench/cpu_peers.py --tinyad DIR --symx DIR [--repeat 5] [--rounds 3] [--mesh 19k]

The tables go to --json (default bench/results/cpu_peers.json):
``comparison`` (the table above), ``comparison_full_projection`` (yasps
projecting the 12x12 local Hessian as the peers do), ``rounds`` (each
round's ratios), ``agreement``, ``residuals`` and ``split`` (each tool's
Newton direction by stage).

Either peer may be left out (its columns are then skipped). TinyAD needs
Eigen 3: --eigen DIR, else /usr/include/eigen3, else the copy bundled with
SymX. --build-wrapper prefixes every compile command (CMake's and the
compiler SymX runs on its generated code), e.g. ``flock /tmp/build.lock``.
"""

from __future__ import annotations

import argparse
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple

# One thread for everyone, the drivers included (they inherit this).
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
             "YASPS_NUM_THREADS"):
    os.environ[_var] = "1"
os.environ.setdefault("YASPS_CACHE_DIR", tempfile.mkdtemp(prefix="yasps-bench-"))

HERE = Path(__file__).resolve().parent
import benchlib  # noqa: E402

benchlib.use_this_checkout()

import numpy as np  # noqa: E402

import yasps  # noqa: E402
from benchlib.meshes import bunny  # noqa: E402
from benchlib.results import Results, add_json_argument  # noqa: E402
from benchlib.tables import markdown  # noqa: E402
from benchlib.timing import median  # noqa: E402
from yasps import energies as E  # noqa: E402
from yasps.compiler.cpu import compile_cpu  # noqa: E402
from yasps.compiler.pipelines import differentiation_pipeline  # noqa: E402
from yasps.ir import emit_scene  # noqa: E402
from yasps.runtime.cpu import launch as launch_kernel  # noqa: E402
from yasps.runtime.inputs import host_input  # noqa: E402
from yasps.compiler.params import ArgumentKind  # noqa: E402

#: bench/benchlib/elastic_scenes.py's constants.
DT2, MU, LAM, MASS, NOISE, SEED = 1e-4, 1e4, 4e4, 1e-3, 1e-3, 0
TOLERANCE = 1e-4
DRIVERS = HERE / "cpp" / "peers"
PEERS = ("TinyAD", "SymX")
#: One tool's figures (times in seconds end in "_s").
ToolResults = Dict[str, Any]


class Work:
    """The mesh, the deformed positions and the per-tet constants, and the
    yasps scene built from them exactly as benchlib.elastic_scenes.snh_scene does."""

    def __init__(self, mesh: str) -> None:
        verts, tets = bunny(mesh)
        rest = verts[tets]
        dm = np.stack([rest[:, k] - rest[:, 0] for k in (1, 2, 3)], axis=2)
        rng = np.random.default_rng(SEED)
        self.mesh = mesh
        self.x_hat = verts
        self.x = verts + rng.normal(scale=NOISE, size=verts.shape)
        self.tets = tets
        self.inv = np.linalg.inv(dm)
        self.vol = np.abs(np.linalg.det(dm)) / 6
        s = yasps.scene("bunny")
        m = s.addMesh("bunny")
        v = m.addPrimitive("v", numInstances=len(verts))
        t = m.addPrimitive("t", numInstances=len(tets))
        x = v.addAttribute("x", rows=3)
        x.updateValue(self.x)
        v.addConstant("x_hat", rows=3).updateValue(verts)
        t.addConstant("inv", rows=3, cols=3).updateValue(self.inv)
        t.addConstant("vol", rows=1).updateValue(self.vol[:, None])
        t2v = t.addConnectivity("t2v", v, tets, 4)
        c = t.addAttribute("c", through=t2v, source=x)
        self.elastic = t.addAttribute("elastic", computed_attribute=DT2 * E.stable_neo_hookean(
            E.deformation_gradient(c, t["inv"]), MU, LAM, t["vol"]))
        s.addEnergy(self.elastic)
        s.addEnergy(v.addAttribute("inertia", computed_attribute=E.inertia(x, v["x_hat"], MASS)))
        s.addMinimizeTarget([x])
        self.scene = s
        self.base = "::".join("@" + p for p in t.path + ["elastic"])

    def write(self, folder: Path, repeat: int, check: int) -> None:
        """The drivers' inputs (bench/cpp/peers/peer_common.h)."""
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "params.txt").write_text(
            f"{len(self.x)} {len(self.tets)} {DT2!r} {MU!r} {LAM!r} {MASS!r} "
            f"{TOLERANCE!r} {repeat} {check}\n")
        for name, array, dtype in (("x", self.x, np.float64),
                                   ("x_hat", self.x_hat, np.float64),
                                   ("tets", self.tets, np.int32),
                                   ("inv", self.inv, np.float64),
                                   ("vol", self.vol, np.float64)):
            np.ascontiguousarray(array, dtype=dtype).tofile(folder / f"{name}.bin")


# --- building and running the peers -------------------------------------------

def find_eigen(given: Optional[Path], symx: Optional[Path]) -> Path:
    """The Eigen include directory for TinyAD: --eigen, the system's, or the
    copy SymX bundles."""
    candidates = [given] if given else [Path("/usr/include/eigen3")]
    if not given and symx:
        candidates.append(symx / "symx" / "extern" / "Eigen")
    for path in candidates:
        if path and (path / "Eigen" / "Dense").is_file():
            return path.resolve()
    raise SystemExit("cpu_peers: TinyAD needs Eigen 3 and none was found "
                     f"(looked in {', '.join(map(str, candidates))}); install "
                     "libeigen3-dev, pass --eigen DIR, or give --symx (it "
                     "bundles Eigen)")


def build_drivers(build: Path, tinyad: Optional[Path], symx: Optional[Path],
                  eigen: Optional[Path], wrapper: List[str], jobs: int) -> None:
    """Configures bench/cpp/peers with the peers' checkouts and builds the
    drivers of the peers given."""
    def run(command: List[str]) -> None:
        print("  $ " + shlex.join(command), flush=True)
        done = subprocess.run(wrapper + command, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True)
        if done.returncode != 0:
            sys.stdout.write(done.stdout[-6000:])
            raise SystemExit(f"cpu_peers: build step failed ({done.returncode})")

    def define(name: str, path: Optional[Path]) -> str:
        return f"-D{name}={path.resolve() if path else ''}"
    run(["cmake", "-S", str(DRIVERS), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
         define("TINYAD_DIR", tinyad), define("SYMX_DIR", symx),
         define("EIGEN_DIR", eigen)])
    targets = (["tinyad_peer"] if tinyad else []) + (["symx_peer"] if symx else [])
    run(["cmake", "--build", str(build), f"-j{jobs}", "--target", *targets])


def run_driver(command: List[str], out: Path, check: int) -> ToolResults:
    """Runs a driver; its "@peer key value" lines, and its check values
    ``grad`` (check, 12) and ``hess`` (check, 12, 12)."""
    out.mkdir(parents=True, exist_ok=True)
    print("  $ " + shlex.join(command), flush=True)
    done = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True)
    if done.returncode != 0:
        sys.stdout.write(done.stdout[-6000:])
        raise SystemExit(f"cpu_peers: {Path(command[0]).name} failed ({done.returncode})")
    results: ToolResults = {}
    for line in done.stdout.splitlines():
        if line.startswith("@peer "):
            _, key, value = line.split(" ", 2)
            try:
                results[key] = float(value)
            except ValueError:
                results[key] = value
    results["grad"] = np.fromfile(out / "grad.bin").reshape(check, 12)
    results["hess"] = np.fromfile(out / "hess.bin").reshape(check, 12, 12)
    return results


# --- yasps ------------------------------------------------------------------------

def yasps_results(work: Work, repeat: int) -> ToolResults:
    """yasps' per-tet kernel times, its Newton direction and its check
    values, one thread."""
    yasps.config.num_threads = 1
    # The peers' solves are Jacobi-preconditioned CG; "auto" would try the
    # multilevel preconditioner on some of the timed solves.
    yasps.config.preconditioner = "block-jacobi"
    s = work.scene
    count = len(work.tets)
    paths = [work.base + k for k in ("__grad", "__hess", "__hess_proj")]
    # The pipeline minimizeEnergy compiles with (it follows yasps.config).
    kernels = compile_cpu(emit_scene(s), paths, s.name, differentiation_pipeline())
    launches = []
    for path in paths:
        kernel = kernels.kernel(path)
        out = np.empty(count * kernel.rows * kernel.cols, dtype=kernel.out_dtype)
        buffers = [out if a.kind is ArgumentKind.out else host_input(s, a) for a in kernel.arguments]
        launches.append(lambda p=path, b=buffers: launch_kernel(kernels, p, count, b, 1))
    grad_k, hess_k, proj_k = launches
    for launch in launches:
        launch()  # warm: output pages touched
    kind = kernels.kernel(paths[2]).projection
    results: ToolResults = {
        "projection_kind": kind,
        "grad_hess_s": median(lambda: (grad_k(), hess_k()), repeat),
        # The projected kernel recomputes the Hessian: with the gradient
        # kernel it is the whole "gradient + projected Hessian".
        "grad_hess_proj_s": median(lambda: (grad_k(), proj_k()), repeat),
        "projection": {"full": "12x12 (full local Hessian)",
                       "reduced": "9x9 (reduced, in F; J^T P J)",
                       "separate": "9x9 (reduced, in F; factors J, P)"}.get(kind, kind),
    }
    derivatives = s.energyDerivatives(work.elastic, threads=1)
    results["grad"], results["hess"] = derivatives.gradient, derivatives.hessian

    s.minimizeEnergy(tolerance=TOLERANCE)  # compiles the scene's kernels
    stages: Dict[str, List[float]] = {}
    for _ in range(repeat):
        # The positions written back unchanged: a new version, so that the
        # call computes the derivatives again (an assembly at the point of
        # the last one reuses them), as at a new point.
        x = s.minimizeTargets[0]
        x.updateValue(x.value)
        s.minimizeEnergy(tolerance=TOLERANCE)
        seconds = dict(s.lastSolve["seconds"])
        seconds["total"] = sum(seconds.values())
        for stage, value in seconds.items():
            stages.setdefault(stage, []).append(value)
    split = {stage: float(np.median(values)) for stage, values in stages.items()}
    results["newton_s"] = split.pop("total")
    results["solve_s"] = split["solve"]
    results["split"] = split
    results["iterations"] = s.lastSolve["iterations"]
    results["relative_residual"] = s.lastSolve["relativeResidual"]
    results["solver"] = "yasps block-Jacobi PCG"
    return results


def check_agrees(name: str, peer: ToolResults, ours: ToolResults, check: int) -> Tuple[float, float]:
    """Stops unless the peer's gradients and unprojected Hessians agree with
    yasps' to 1e-12, relative to each tet's largest entry; returns the
    largest relative differences."""
    errors = []
    for key, tolerance in (("grad", 1e-12), ("hess", 1e-12)):
        want = np.asarray(ours[key][:check])
        got = np.asarray(peer[key])
        scale = np.abs(want).reshape(check, -1).max(axis=1)
        error = (np.abs(got - want).reshape(check, -1).max(axis=1) / scale).max()
        if not error <= tolerance:
            raise SystemExit(f"cpu_peers: {name}'s per-tet {key} disagrees with "
                             f"yasps' on the first {check} tets: relative "
                             f"difference {error:.2e} > {tolerance:g}")
        errors.append(float(error))
    return errors[0], errors[1]


# --- the table --------------------------------------------------------------------

#: The tools' cells of the comparison carry their row's format: a cell is
#: {"value": number or text, "format": format spec}.
TOOL_CELL = "{0[value]:{0[format]}}"


def comparison(results: Dict[str, ToolResults], count: int
               ) -> Tuple[List[str], List[list], List[str]]:
    """The comparison table's columns, rows and formats: times and ratios
    peer / yasps."""
    peers = [p for p in PEERS if p in results]
    ours = results["yasps"]

    def per_tet(key: str):
        return lambda r: r[key] * 1e9 / count

    measures = [
        ("gradient+Hessian (ns/tet)", per_tet("grad_hess_s"), ".0f"),
        ("+PSD projection (ns/tet)", per_tet("grad_hess_proj_s"), ".0f"),
        ("projected matrix", lambda r: r["projection"], ""),
        ("Newton direction (ms)", lambda r: r["newton_s"] * 1e3, ".1f"),
        ("of which solve (ms)", lambda r: r["solve_s"] * 1e3, ".1f"),
        ("PCG iterations", lambda r: r["iterations"], ".0f"),
        ("PCG per iteration (ms)", lambda r: r["solve_s"] * 1e3 / r["iterations"], ".3f"),
    ]
    columns = (["per tet / per step"] + peers + ["yasps"]
               + [f"yasps vs {p}" for p in peers])
    rows = []
    for label, value, spec in measures:
        cells: list = [label] + [{"value": value(results[p]), "format": spec}
                                 for p in peers + ["yasps"]]
        for p in peers:
            mine, theirs = value(ours), value(results[p])
            cells.append(None if isinstance(mine, str) else theirs / mine)
        rows.append(cells)
    formats = [""] + [TOOL_CELL] * (len(peers) + 1) + ["{:.2f}x"] * len(peers)
    return columns, rows, formats


def plain(r: ToolResults) -> Dict[str, Any]:
    """A tool's figures for the JSON: no check values, numbers as Python's."""
    out: Dict[str, Any] = {}
    for key, value in r.items():
        if key in ("grad", "hess"):
            continue
        if key == "rounds":
            value = [plain(x) for x in value]
        elif isinstance(value, dict):
            value = {k: float(v) for k, v in value.items()}
        elif isinstance(value, np.generic):
            value = value.item()
        out[key] = value
    return out


def one_round(args: argparse.Namespace, work: Work, check: int,
              wrapper: List[str]) -> Tuple[Dict[str, ToolResults], Optional[ToolResults]]:
    """One round: each peer's driver (--repeat runs of each stage), then
    yasps, and where yasps projects in F, yasps with the 12x12 projection."""
    results: Dict[str, ToolResults] = {}
    if args.tinyad or args.symx:
        with tempfile.TemporaryDirectory(prefix="yasps-cpu-peers-") as tmp:
            inputs = Path(tmp) / "inputs"
            work.write(inputs, args.repeat, check)
            if args.tinyad:
                results["TinyAD"] = run_driver(
                    [str(args.build_dir / "tinyad_peer"), str(inputs), f"{tmp}/tinyad"],
                    Path(tmp) / "tinyad", check)
            if args.symx:
                codegen = args.build_dir / "symx_codegen"
                codegen.mkdir(parents=True, exist_ok=True)
                compiler = shutil.which("g++") or shutil.which("clang++") or "g++"
                results["SymX"] = run_driver(
                    [str(args.build_dir / "symx_peer"), str(inputs), f"{tmp}/symx",
                     str(codegen), shlex.join(wrapper + [compiler])],
                    Path(tmp) / "symx", check)

    print("yasps: compiling and timing", flush=True)
    results["yasps"] = yasps_results(work, args.repeat)
    # Where yasps projects in F (9x9), also the peers' 12x12 projection.
    full: Optional[ToolResults] = None
    if results["yasps"]["projection_kind"] != "full" and \
            getattr(yasps.config, "linear_map_projection", None) is True:
        print("yasps: again with the 12x12 projection "
              "(yasps.config.linear_map_projection = False)", flush=True)
        yasps.config.linear_map_projection = False
        try:
            full = yasps_results(Work(args.mesh), args.repeat)
        finally:
            yasps.config.linear_map_projection = True
    return results, full


def combine(rounds: List[ToolResults]) -> ToolResults:
    """One tool's results over rounds: the median of each time (and of each
    stage of a split), everything else (check values, names, iteration
    counts, the same in every round) from the first round."""
    combined = dict(rounds[0])
    for key, value in rounds[0].items():
        if key.endswith("_s"):
            combined[key] = float(np.median([r[key] for r in rounds]))
        elif key == "split":
            combined[key] = {stage: float(np.median([r[key][stage] for r in rounds]))
                             for stage in value}
    combined["rounds"] = rounds
    return combined


def per_round_ratios(results: Dict[str, ToolResults]) -> List[list]:
    """Each round's ratio peer / yasps of the stages the acceptance names,
    from times taken in the same round: rows of the measure, the ratio of
    each round, the lowest and the median."""
    ours = results["yasps"]["rounds"]
    measures = (
        ("+PSD projection", lambda r: r["grad_hess_proj_s"]),
        ("Newton direction", lambda r: r["newton_s"]),
        ("PCG per iteration", lambda r: r["solve_s"] / r["iterations"]),
    )
    rows = []
    for name in PEERS:
        if name not in results:
            continue
        theirs = results[name]["rounds"]
        for label, value in measures:
            ratios = [value(t) / value(o) for t, o in zip(theirs, ours)]
            rows.append([f"{label}, yasps vs {name}", *ratios, min(ratios),
                         float(np.median(ratios))])
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--tinyad", type=Path, default=None, help="TinyAD checkout")
    parser.add_argument("--symx", type=Path, default=None, help="SymX checkout")
    parser.add_argument("--eigen", type=Path, default=None,
                        help="Eigen 3 include directory for TinyAD")
    parser.add_argument("--repeat", type=int, default=5,
                        help="runs of each stage per round (their median)")
    parser.add_argument("--rounds", type=int, default=3,
                        help="rounds, each running every tool in turn; the "
                        "table shows the median over rounds")
    parser.add_argument("--mesh", default="19k", help="bunny-<mesh>.msh of ../shared/data")
    parser.add_argument("--check", type=int, default=300,
                        help="tets whose derivatives are compared")
    parser.add_argument("--build-dir", type=Path,
                        default=Path(tempfile.gettempdir()) / "yasps-cpu-peers-build")
    parser.add_argument("--build-wrapper", default="",
                        help="command prefixed to every compile, e.g. 'flock LOCK'")
    parser.add_argument("--jobs", type=int, default=2, help="parallel build jobs")
    add_json_argument(parser, "cpu_peers")
    args = parser.parse_args()
    given = {"TinyAD": args.tinyad, "SymX": args.symx}
    for name, path in given.items():
        if path is not None and not path.is_dir():
            raise SystemExit(f"cpu_peers: --{name.lower()} {path} is not a directory")
    wrapper = shlex.split(args.build_wrapper)

    work = Work(args.mesh)
    count = len(work.tets)
    check = min(args.check, count)
    print(f"bunny-{args.mesh}: {len(work.x):,} vertices, {count:,} tets; stable "
          f"Neo-Hookean (dt2 {DT2:g}, mu {MU:g}, lambda {LAM:g}) + inertia (mass "
          f"{MASS:g}); one thread, median of {args.repeat} runs per round, "
          f"median over {args.rounds} rounds")
    for name, path in given.items():
        if path is None:
            print(f"{name} skipped: no --{name.lower()} DIR given")

    if args.tinyad or args.symx:
        eigen = find_eigen(args.eigen, args.symx) if args.tinyad else None
        if eigen is not None:
            print(f"Eigen for TinyAD: {eigen}")
        print(f"building the peers' drivers in {args.build_dir}")
        build_drivers(args.build_dir, args.tinyad, args.symx, eigen, wrapper, args.jobs)
    # Rounds alternate the tools: this host's speed drifts by up to 2x within
    # minutes, so each round's ratios compare times taken close together.
    rounds: List[Dict[str, ToolResults]] = []
    fulls: List[ToolResults] = []
    for number in range(1, args.rounds + 1):
        print(f"round {number} of {args.rounds}", flush=True)
        results, full = one_round(args, work, check, wrapper)
        rounds.append(results)
        if full is not None:
            fulls.append(full)
    results = {name: combine([r[name] for r in rounds]) for name in rounds[0]}
    full = combine(fulls) if fulls else None
    out = Results("cpu_peers")
    out.values.update(mesh=args.mesh, vertices=len(work.x), tets=count,
                      repeat=args.repeat, rounds=args.rounds, check=check,
                      skipped=[n for n, p in given.items() if p is None])
    agreement = []
    for name in PEERS:
        if name in results:
            g, h = check_agrees(name, results[name], results["yasps"], check)
            agreement.append([name, check, g, h])
            print(f"{name} agrees with yasps on {check} tets: gradients to "
                  f"{g:.1e}, Hessians to {h:.1e} (relative to each tet's largest entry)")

    setting = (f"bunny-{args.mesh} ({len(work.x):,} vertices, {count:,} tets), "
               f"stable Neo-Hookean + inertia, one thread, median of "
               f"{args.repeat} runs per round, median over {args.rounds} "
               f"rounds; ratios: peer / yasps (above 1: yasps takes less time "
               f"or fewer iterations)")
    print()
    print(markdown(out.table("comparison", *comparison(results, count),
                             note=setting + ".")))
    print()
    if full is not None:
        print("yasps projecting the full 12x12 local Hessian as the peers do "
              "(yasps.config.linear_map_projection = False):")
        print()
        print(markdown(out.table(
            "comparison_full_projection",
            *comparison({**results, "yasps": full}, count),
            note=setting + "; yasps projecting the full 12x12 local Hessian "
            "as the peers do (yasps.config.linear_map_projection = False).")))
        print()
    print("ratios: peer / yasps (above 1: yasps takes less time or fewer iterations)")
    if len(rounds) > 1 and len(results) > 1:
        ratios = out.table(
            "rounds", ["measure"] + [f"round {k}" for k in
                                     range(1, len(rounds) + 1)]
            + ["lowest", "median"], per_round_ratios(results),
            [""] + ["{:.2f}x"] * (len(rounds) + 2),
            "Each round's ratio peer / yasps, from times taken in the same "
            "round.")
        for label, *each, lowest, middle in ratios.rows:
            print(f"{label}, each round: " + " ".join(f"{x:.2f}x" for x in each)
                  + f" (lowest {lowest:.2f}x, median {middle:.2f}x)")
    for name, path in given.items():
        if path is None:
            print(f"{name} skipped (no --{name.lower()} DIR)")
    if agreement:
        out.table("agreement", ["peer", "tets", "gradients", "Hessians"],
                  agreement, ["", "", "{:.1e}", "{:.1e}"],
                  "The largest difference of the peer's per-tet gradients and "
                  "unprojected Hessians to yasps', relative to each tet's "
                  "largest entry.")
    residuals = out.table(
        "residuals", ["tool", "solver", "relative residual"],
        [[name, results[name]["solver"], results[name]["relative_residual"]]
         for name in PEERS + ("yasps",) if name in results],
        ["", "", "{:.2e}"], "The Newton direction's relative residual "
        "||g - H dx|| / ||g||, recomputed.")
    for name, solver, residual in residuals.rows:
        print(f"{name}: {solver}, relative residual ||g - H dx||/||g|| = "
              f"{residual:.2e}")
    split = [["yasps", stage, seconds * 1e3]
             for stage, seconds in results["yasps"]["split"].items()]
    tinyad = results.get("TinyAD")
    if tinyad is not None:
        split += [["TinyAD", "eval_with_hessian_proj (derivatives, projection, "
                   "triplet assembly)", (tinyad["newton_s"] - tinyad["solve_s"]) * 1e3],
                  ["TinyAD", "solve", tinyad["solve_s"] * 1e3]]
    symx = results.get("SymX")
    if symx is not None:
        split += [["SymX", "derivatives", symx["newton_derivatives_s"] * 1e3],
                  ["SymX", "projection", symx["newton_projection_s"] * 1e3],
                  ["SymX", "assembly", symx["newton_assembly_s"] * 1e3],
                  ["SymX", "solve", symx["solve_s"] * 1e3]]
    out.table("split", ["tool", "stage", "time (ms)"], split,
              ["", "", "{:.1f}"], "Each tool's Newton direction by stage.")
    for name in ("yasps",) + PEERS:
        stages = [f"{stage} {ms:.1f} ms" for tool, stage, ms in split
                  if tool == name]
        if stages:
            print(f"{name} Newton direction split: " + ", ".join(stages))
    out.values["tools"] = {name: plain(r) for name, r in results.items()}
    if full is not None:
        out.values["yasps_full_projection"] = plain(full)
    path = out.write(args.json)
    print(f"results: {path}")


if __name__ == "__main__":
    main()
