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
from typing import Dict, List, Optional, Tuple

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
from benchlib.timing import median  # noqa: E402
from yasps import energies as E  # noqa: E402
from yasps.compiler.cpu import compile_cpu  # noqa: E402
from yasps.compiler.pipelines import differentiation_pipeline  # noqa: E402
from yasps.ir import emit_scene  # noqa: E402
from yasps.runtime.inputs import host_input  # noqa: E402
from yasps.compiler.params import ArgumentKind  # noqa: E402

#: bench/benchlib/elastic_scenes.py's constants.
DT2, MU, LAM, MASS, NOISE, SEED = 1e-4, 1e4, 4e4, 1e-3, 1e-3, 0
TOLERANCE = 1e-4
DRIVERS = HERE / "cpp" / "peers"
PEERS = ("TinyAD", "SymX")
Results = Dict[str, object]


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


def run_driver(command: List[str], out: Path, check: int) -> Results:
    """Runs a driver; its "@peer key value" lines, and its check values
    ``grad`` (check, 12) and ``hess`` (check, 12, 12)."""
    out.mkdir(parents=True, exist_ok=True)
    print("  $ " + shlex.join(command), flush=True)
    done = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True)
    if done.returncode != 0:
        sys.stdout.write(done.stdout[-6000:])
        raise SystemExit(f"cpu_peers: {Path(command[0]).name} failed ({done.returncode})")
    results: Results = {}
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

def yasps_results(work: Work, repeat: int) -> Results:
    """yasps' per-tet kernel times, its Newton direction and its check
    values, one thread."""
    yasps.config.num_threads = 1
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
        launches.append(lambda p=path, b=buffers: kernels.launch(p, count, b, 1))
    grad_k, hess_k, proj_k = launches
    for launch in launches:
        launch()  # warm: output pages touched
    kind = kernels.kernel(paths[2]).projection
    results: Results = {
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


def check_agrees(name: str, peer: Results, ours: Results, check: int) -> Tuple[float, float]:
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

def table(results: Dict[str, Results], count: int) -> List[str]:
    """The comparison table (Markdown): times and ratios peer / yasps."""
    peers = [p for p in PEERS if p in results]
    ours = results["yasps"]

    def per_tet(key: str):
        return lambda r: r[key] * 1e9 / count

    rows = [
        ("gradient+Hessian (ns/tet)", per_tet("grad_hess_s"), "{:.0f}"),
        ("+PSD projection (ns/tet)", per_tet("grad_hess_proj_s"), "{:.0f}"),
        ("projected matrix", lambda r: r["projection"], "{}"),
        ("Newton direction (ms)", lambda r: r["newton_s"] * 1e3, "{:.1f}"),
        ("of which solve (ms)", lambda r: r["solve_s"] * 1e3, "{:.1f}"),
        ("PCG iterations", lambda r: r["iterations"], "{:.0f}"),
        ("PCG per iteration (ms)", lambda r: r["solve_s"] * 1e3 / r["iterations"], "{:.3f}"),
    ]
    header = ["per tet / per step"] + peers + ["yasps"] + [f"yasps vs {p}" for p in peers]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for label, value, fmt in rows:
        cells = [label] + [fmt.format(value(results[p])) for p in peers + ["yasps"]]
        for p in peers:
            mine, theirs = value(ours), value(results[p])
            cells.append("" if isinstance(mine, str) else f"{theirs / mine:.2f}x")
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def one_round(args: argparse.Namespace, work: Work, check: int,
              wrapper: List[str]) -> Tuple[Dict[str, Results], Optional[Results]]:
    """One round: each peer's driver (--repeat runs of each stage), then
    yasps, and where yasps projects in F, yasps with the 12x12 projection."""
    results: Dict[str, Results] = {}
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
    full: Optional[Results] = None
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


def combine(rounds: List[Results]) -> Results:
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


def per_round_ratios(results: Dict[str, Results]) -> List[str]:
    """Each round's ratio peer / yasps of the stages the acceptance names,
    from times taken in the same round."""
    ours = results["yasps"]["rounds"]
    measures = (
        ("+PSD projection", lambda r: r["grad_hess_proj_s"]),
        ("Newton direction", lambda r: r["newton_s"]),
        ("PCG per iteration", lambda r: r["solve_s"] / r["iterations"]),
    )
    lines = []
    for name in PEERS:
        if name not in results:
            continue
        theirs = results[name]["rounds"]
        for label, value in measures:
            ratios = [value(t) / value(o) for t, o in zip(theirs, ours)]
            lines.append(f"{label}, yasps vs {name}, each round: "
                         + " ".join(f"{x:.2f}x" for x in ratios)
                         + f" (lowest {min(ratios):.2f}x, median "
                         f"{float(np.median(ratios)):.2f}x)")
    return lines


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
    rounds: List[Dict[str, Results]] = []
    fulls: List[Results] = []
    for number in range(1, args.rounds + 1):
        print(f"round {number} of {args.rounds}", flush=True)
        results, full = one_round(args, work, check, wrapper)
        rounds.append(results)
        if full is not None:
            fulls.append(full)
    results = {name: combine([r[name] for r in rounds]) for name in rounds[0]}
    full = combine(fulls) if fulls else None
    for name in PEERS:
        if name in results:
            g, h = check_agrees(name, results[name], results["yasps"], check)
            print(f"{name} agrees with yasps on {check} tets: gradients to "
                  f"{g:.1e}, Hessians to {h:.1e} (relative to each tet's largest entry)")

    print()
    print("\n".join(table(results, count)))
    print()
    if full is not None:
        print("yasps projecting the full 12x12 local Hessian as the peers do "
              "(yasps.config.linear_map_projection = False):")
        print()
        print("\n".join(table({**results, "yasps": full}, count)))
        print()
    print("ratios: peer / yasps (above 1: yasps takes less time or fewer iterations)")
    if len(rounds) > 1:
        print("\n".join(per_round_ratios(results)))
    for name, path in given.items():
        if path is None:
            print(f"{name} skipped (no --{name.lower()} DIR)")
    for name in PEERS + ("yasps",):
        r = results.get(name)
        if r is None:
            continue
        print(f"{name}: {r['solver']}, relative residual ||g - H dx||/||g|| = "
              f"{r['relative_residual']:.2e}")
    split = results["yasps"]["split"]
    print("yasps Newton direction split: " + ", ".join(
        f"{stage} {seconds * 1e3:.1f} ms" for stage, seconds in split.items()))
    tinyad = results.get("TinyAD")
    if tinyad is not None:
        print(f"TinyAD Newton direction split: eval_with_hessian_proj (derivatives, "
              f"projection, triplet assembly) "
              f"{(tinyad['newton_s'] - tinyad['solve_s']) * 1e3:.1f} ms, solve "
              f"{tinyad['solve_s'] * 1e3:.1f} ms")
    symx = results.get("SymX")
    if symx is not None:
        print(f"SymX Newton direction split: derivatives "
              f"{symx['newton_derivatives_s'] * 1e3:.1f} ms, projection "
              f"{symx['newton_projection_s'] * 1e3:.1f} ms, assembly "
              f"{symx['newton_assembly_s'] * 1e3:.1f} ms, solve {symx['solve_s'] * 1e3:.1f} ms")


if __name__ == "__main__":
    main()
