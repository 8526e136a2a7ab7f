#!/usr/bin/env python3
"""The trade between accuracy and speed, measured on three small scenes.

Scenes (each run for N frames of implicit Euler, dt = 0.01):

- ``drop``: the soft box of ``examples/drop.py`` falling onto the ground
  (its ground barrier and step bound);
- ``cloth``: a cloth draped over a static box with IPC contact and
  friction (``test_cloth_draped_over_a_static_box``);
- ``contact``: a soft box dropped on a soft box resting on a ground
  half-space (``test_soft_box_dropped_on_a_soft_box_on_the_ground``).

Settings vary one axis at a time from a default (f64, CG tolerance 1e-4,
the scene's Newton tolerance, clamp projection, linear-map projection on,
the scene's dhat and barrier stiffness): Newton tolerance (the stepper's
``velocity_tolerance``), projection method (``clamp``, ``abs``, ``none``,
for every energy of the scene), reduced projection off
(``yasps.config.linear_map_projection``), dhat (x0.5, x2) and a fixed
barrier stiffness (contact scenes: x0.1, x1, x10 of the stiffness the
reference's adaptive rule ended with; drop: x0.1, x10 of its fixed one).
Precision (``yasps.config.precision`` f64 or f32; "mixed": f32 plus
``yasps.config.hessian_storage = "f32"``) is crossed with the CG
tolerance axis. Each setting builds its scene afresh.

The reference of a scene is f64 with CG tolerance 1e-10 and a Newton
tolerance 100 times smaller, over the same frames. Per setting the bench
reports:

- the wall time of the N frames (one thread; the kernels are compiled by a
  one-frame warm-up of the same setting on a throwaway build, and a run
  during which something was still compiled is repeated);
- its speed-up over the default setting;
- the trajectory error after N frames: the largest position difference to
  the reference over the scene's size (the diagonal of its bounding box at
  the start);
- the total energy's (``scene.evaluateEnergy()``, the step's incremental
  potential) difference to the reference's after N frames, relative to the
  largest size of the reference's over its frames (a cloth in free fall
  has an energy of ~0; a different dhat or stiffness changes the energy
  itself, not only its accuracy);
- the smallest distance over the run: between surface primitives closer
  than 4 x the scene's default dhat (ipctk, on a collision mesh of the
  bench's own) and to the ground; for the drop its lowest z;
- whether some frame had intersections (ipctk's ``has_intersections`` on
  that mesh, or a vertex below the ground);
- the Newton and CG iterations of the run.

It prints a table per scene, writes every number to --json (default
bench/results/accuracy_speed.json: the tables ``drop``, ``cloth`` and
``contact`` as printed, ``summary`` with every scene's settings in the
columns of docs/accuracy.md, and every figure of every run in its
values) and a Pareto plot per scene (``DIR/pareto_<scene>.png``, DIR from
--output: time against trajectory error, each setting a labelled point,
the Pareto front drawn).

    python3 bench/accuracy_speed.py [--frames 20] [--scenes drop,cloth,contact]
                                    [--output out/accuracy_speed] [--quick]
                                    [--json PATH]

``--quick`` runs 2 frames of 4 settings (a smoke test).
"""

from __future__ import annotations

import argparse
import gc
import math
import os
import platform
import sys
import tempfile
import time
import warnings
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable, Dict, Iterator, List, Optional, Sequence, Tuple

os.environ.setdefault("YASPS_CACHE_DIR", tempfile.mkdtemp(prefix="yasps-bench-"))
HERE = Path(__file__).resolve().parent
REPO = HERE.parent
import benchlib  # noqa: E402

benchlib.use_this_checkout()
sys.path.insert(0, str(REPO / "examples"))

import ipctk  # noqa: E402
from benchlib.results import Results, add_json_argument  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

import cloth_drape  # noqa: E402
import drop  # noqa: E402
import soft_boxes  # noqa: E402
import yasps  # noqa: E402
from yasps.compiler.cpu import kernels_compiled  # noqa: E402
from yasps.sim import ImplicitEuler, NewtonReport, NewtonSettings  # noqa: E402

DT = 0.01
#: The soft box of the drop scene has DROP_CELLS^3 cells (6 tets each).
DROP_CELLS = 3
DEFAULT_FRAMES = 20
QUICK_FRAMES = 2
CG_TOLERANCES = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6)
NEWTON_FACTORS = (10.0, 3.0, 0.3, 0.1)
PRECISIONS = ("f64", "f32", "mixed")
#: Minimum distances are looked for below this many times the default dhat.
DISTANCE_QUERY = 4.0
#: Zero errors are drawn here on the log scale.
ERROR_FLOOR = 1e-16


# ----------------------------------------------------------------- settings

@dataclass(frozen=True)
class Setting:
    """One point of the grid. ``precision``: "f64", "f32" or "mixed" (f32
    derivatives and f32 Hessian storage in the solve); ``newton_factor``
    scales the scene's Newton (velocity) tolerance, ``dhat_factor`` its
    dhat (a distance); ``kappa_factor``: None for the scene's own barrier
    stiffness (adaptive with IPC contact), else a fixed stiffness of this
    many times the scene's base one (see :class:`SceneSpec`)."""
    name: str
    axis: str
    precision: str = "f64"
    cg_tolerance: float = 1e-4
    newton_factor: float = 1.0
    projection: str = "clamp"
    linear_maps: bool = True
    dhat_factor: float = 1.0
    kappa_factor: Optional[float] = None
    reference: bool = False

    @property
    def max_iterations(self) -> int:
        """Newton iterations per step (more for the tight reference)."""
        return 200 if self.reference else 20

    @property
    def cg_max_iterations(self) -> int:
        """PCG iterations per direction (more for the tight reference)."""
        return 20000 if self.reference else 1000


DEFAULT = Setting("default", "default")
REFERENCE = Setting("reference", "reference", cg_tolerance=1e-10,
                    newton_factor=0.01, reference=True)


def _e(value: float) -> str:
    """1e-03 -> 1e-3."""
    return f"{value:.0e}".replace("e-0", "e-").replace("e+0", "e+")


def grid(contact: bool, quick: bool) -> List[Setting]:
    """The settings of a scene: one axis at a time from DEFAULT, plus the
    precision axis crossed with the CG tolerance axis. ``contact``: the
    scene's barrier stiffness is adaptive (IPC contact), so a fixed one of
    1x the reference's is a setting too."""
    if quick:
        return [DEFAULT, Setting("f32", "precision x cg", precision="f32"),
                Setting("cg=1e-2", "precision x cg", cg_tolerance=1e-2),
                Setting("proj=abs", "projection", projection="abs")]
    settings = []
    for precision in PRECISIONS:
        for cg in CG_TOLERANCES:
            if precision == "f64" and cg == DEFAULT.cg_tolerance:
                settings.append(DEFAULT)
                continue
            name = (f"cg={_e(cg)}" if precision == "f64" else
                    precision if cg == DEFAULT.cg_tolerance else
                    f"{precision} cg={_e(cg)}")
            settings.append(Setting(name, "precision x cg",
                                    precision=precision, cg_tolerance=cg))
    settings += [Setting(f"newton x{f:g}", "newton", newton_factor=f)
                 for f in NEWTON_FACTORS]
    settings += [Setting(f"proj={p}", "projection", projection=p)
                 for p in ("abs", "none")]
    settings.append(Setting("linmaps off", "linear maps", linear_maps=False))
    settings += [Setting(f"dhat x{f:g}", "dhat", dhat_factor=f)
                 for f in (0.5, 2.0)]
    kappas = (0.1, 1.0, 10.0) if contact else (0.1, 10.0)
    settings += [Setting(f"kappa x{f:g}" + (" fixed" if contact else ""),
                         "kappa", kappa_factor=f) for f in kappas]
    return settings


#: The fields of yasps.config that a setting changes.
CONFIG_FIELDS = ("precision", "hessian_storage", "linear_map_projection")


@contextmanager
def configured(setting: Setting) -> Iterator[None]:
    """Sets yasps.config for ``setting`` and restores it afterwards."""
    config = yasps.config
    saved = {name: getattr(config, name) for name in CONFIG_FIELDS}
    try:
        config.precision = "f64" if setting.precision == "f64" else "f32"
        # "mixed": and f32 storage of the Hessian's blocks in the solve.
        config.hessian_storage = "f32" if setting.precision == "mixed" else "f64"
        config.linear_map_projection = setting.linear_maps
        yield
    finally:
        for name, value in saved.items():
            setattr(config, name, value)


# ------------------------------------------------------------------- scenes

@dataclass
class Sim:
    """A built scene and its stepper. ``targets``: the vertex positions
    simulated; ``obstacle``: static vertices that follow them in
    ``faces`` (the triangles ipctk checks; None for no mesh check);
    ``ground``: whether the plane z = 0 is an obstacle; ``kappa``: the
    barrier stiffness now."""
    scene: yasps.Scene
    stepper: ImplicitEuler
    targets: list
    obstacle: np.ndarray
    faces: Optional[np.ndarray]
    ground: bool
    kappa: Callable[[], float]

    def positions(self) -> np.ndarray:
        """The simulated vertices' positions now, (N, 3)."""
        return np.concatenate([t.value[:, :, 0] for t in self.targets])

    def world(self) -> np.ndarray:
        """Every vertex of the collision mesh now (targets, then obstacle)."""
        return np.concatenate([self.positions(), self.obstacle])


def _stepper_options(setting: Setting, velocity_tolerance: float) -> dict:
    return dict(velocity_tolerance=velocity_tolerance * setting.newton_factor,
                settings=NewtonSettings(
                    cg_tolerance=setting.cg_tolerance,
                    max_iterations=setting.max_iterations,
                    cg_max_iterations=setting.cg_max_iterations))


def build_drop(setting: Setting, kappa_base: Optional[float]) -> Sim:
    """``examples/drop.py``'s scene and stepper (``drop.build``, with the
    setting's projection, dhat and stiffness): a soft box 10 cm above the
    ground, stable Neo-Hookean, inertia and the IPC barrier to the ground.
    ``kappa_base`` is ignored: the barrier's stiffness is drop.KAPPA (per
    unit mass) times ``kappa_factor``."""
    kappa = drop.KAPPA * (1.0 if setting.kappa_factor is None
                          else setting.kappa_factor)
    # dhat is a squared distance here: the distance scales by dhat_factor.
    s, x, x_hat = drop.build(DROP_CELLS, projection=setting.projection or
                             "clamp", dhat=drop.DHAT * setting.dhat_factor ** 2,
                             kappa=kappa)
    stepper = ImplicitEuler(s, x, x_hat, drop.DT, gravity=drop.GRAVITY,
                            step_bound=drop.stay_above_ground,
                            **_stepper_options(setting, 1e-2))
    factor = 1.0 if setting.kappa_factor is None else setting.kappa_factor
    return Sim(s, stepper, [x], np.zeros((0, 3)), None, True,
               lambda: drop.KAPPA * factor)


def _contact_kappa(setting: Setting,
                   kappa_base: Optional[float]) -> Optional[float]:
    """A fixed barrier stiffness, or None for IPC's adaptive one."""
    if setting.kappa_factor is None:
        return None
    if kappa_base is None:
        raise ValueError(f"{setting.name}: no base stiffness (the "
                         f"reference failed)")
    return kappa_base * setting.kappa_factor


CLOTH_DHAT = cloth_drape.DHAT


def build_cloth(setting: Setting, kappa_base: Optional[float]) -> Sim:
    """``examples/cloth_drape.py``: a 10x10 cloth 1 cm above a static box
    (its vertices constants in the UNION), IPC contact with friction 0.3."""
    drape = cloth_drape.build(projection=setting.projection,
                              dhat=CLOTH_DHAT * setting.dhat_factor,
                              kappa=_contact_kappa(setting, kappa_base))
    s, x, bv, faces = drape.scene, drape.x, drape.box, drape.faces
    contact = drape.contact
    stepper = drape.stepper(**_stepper_options(setting, 1e-2))
    return Sim(s, stepper, [x], bv, faces, False, lambda: contact.kappa)


CONTACT_DHAT = soft_boxes.DHAT


def build_contact(setting: Setting, kappa_base: Optional[float]) -> Sim:
    """``examples/soft_boxes.py``: two soft boxes (2^3 cells each), one
    resting on the ground (a half-space), the other 3 cm above it."""
    boxes = soft_boxes.build(projection=setting.projection,
                             dhat=CONTACT_DHAT * setting.dhat_factor,
                             kappa=_contact_kappa(setting, kappa_base))
    s, xs, both, contact = boxes.scene, boxes.xs, boxes.faces, boxes.contact
    stepper = boxes.stepper(**_stepper_options(setting, 1e-2))
    return Sim(s, stepper, xs, np.zeros((0, 3)), both, True,
               lambda: contact.kappa)


@dataclass(frozen=True)
class SceneSpec:
    """A scene of the bench: its builder ``build(setting, kappa_base)``,
    its default dhat (a distance) and whether its barrier
    stiffness is IPC's adaptive one (then the fixed-stiffness settings
    take the reference's final stiffness as their base)."""
    name: str
    build: Callable[..., Sim]
    dhat: float
    adaptive: bool
    summary: str


SCENES: Dict[str, SceneSpec] = {
    "drop": SceneSpec("drop", build_drop, math.sqrt(drop.DHAT), False,
                      f"soft box ({DROP_CELLS}^3 cells) onto the ground"),
    "cloth": SceneSpec("cloth", build_cloth, CLOTH_DHAT, True,
                       "10x10 cloth over a static box, friction 0.3"),
    "contact": SceneSpec("contact", build_contact, CONTACT_DHAT, True,
                         "soft box onto a soft box on the ground"),
}


# -------------------------------------------------------------- measurement

@dataclass
class Trajectory:
    """What one run of a setting gave: per frame the positions, the
    total energy, the smallest distance and whether anything intersected; the time of the
    frames and the solver's counts; the energy and stiffness at the end."""
    positions: List[np.ndarray] = field(default_factory=list)
    energies: List[float] = field(default_factory=list)
    min_distance: List[float] = field(default_factory=list)
    intersecting: List[bool] = field(default_factory=list)
    seconds: float = 0.0
    newton: int = 0
    cg: int = 0
    inexact: int = 0
    unconverged: int = 0
    energy: float = float("nan")
    kappa: float = float("nan")
    warnings: List[str] = field(default_factory=list)


def clearance(sim: Sim, query: float) -> Tuple[float, bool]:
    """The smallest distance now (between surface primitives closer than
    ``query``, by ipctk on a collision mesh of the bench's own, and to the
    ground) and whether anything intersects (ipctk, or a vertex at or
    below the ground)."""
    distance, hit = float("inf"), False
    V = sim.positions()
    if sim.faces is not None:
        W = sim.world()
        mesh = ipctk.CollisionMesh(W, ipctk.edges(sim.faces), sim.faces)
        hit = bool(ipctk.has_intersections(mesh, W))
        collisions = ipctk.NormalCollisions()
        collisions.build(mesh, W, query)
        if not collisions.empty():
            distance = math.sqrt(collisions.compute_minimum_distance(mesh, W))
    if sim.ground:
        lowest = float(V[:, 2].min())
        distance = min(distance, lowest)
        hit = hit or lowest <= 0.0
    return distance, hit


def simulate(sim: Sim, frames: int, query: float) -> Trajectory:
    """Steps ``sim`` ``frames`` times; only the steps are timed."""
    out = Trajectory()
    clock = time.perf_counter
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(frames):
            start = clock()
            report: NewtonReport = sim.stepper.step()
            out.seconds += clock() - start
            out.newton += report.iterations
            out.cg += int(sum(report.cg_iterations))
            out.inexact += report.inexact_directions
            out.unconverged += not report.converged
            positions = sim.positions().copy()
            if not np.isfinite(positions).all():
                raise FloatingPointError("positions are not finite")
            out.positions.append(positions)
            out.energies.append(float(sim.scene.evaluateEnergy()))
            distance, hit = clearance(sim, query)
            out.min_distance.append(distance)
            out.intersecting.append(hit)
        out.energy = out.energies[-1]
        out.kappa = float(sim.kappa())
    out.warnings = sorted({f"{w.category.__name__}: {w.message}".split("\n")[0]
                           for w in caught})
    return out


def compiled_so_far() -> int:
    """CPU kernels compiled in this process so far (the bench's kernel
    cache starts empty, so every kernel is compiled once, here), to tell
    whether a timed run compiled something."""
    return kernels_compiled()


def run(spec: SceneSpec, setting: Setting, frames: int,
        kappa_base: Optional[float]) -> Tuple[Optional[Trajectory], dict]:
    """One setting: a one-frame warm-up on a throwaway build (compiles its
    kernels), then the timed run on a fresh build, repeated once if it
    still compiled something. Returns the trajectory (None if it failed)
    and the run's notes."""
    notes = {"compiled_during_run": False, "reruns": 0, "error": None}
    query = DISTANCE_QUERY * spec.dhat
    with configured(setting):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                spec.build(setting, kappa_base).stepper.step()
            gc.collect()
            for attempt in range(2):
                before = compiled_so_far()
                trajectory = simulate(spec.build(setting, kappa_base), frames,
                                      query)
                gc.collect()
                if compiled_so_far() == before:
                    break
                notes["compiled_during_run"] = attempt == 1
                notes["reruns"] += attempt == 0
            return trajectory, notes
        except Exception as error:  # a setting that breaks is a result too
            notes["error"] = f"{type(error).__name__}: {error}".split("\n")[0]
            return None, notes


def _finite(value: float) -> Optional[float]:
    return float(value) if value is not None and math.isfinite(value) else None


def summarise(setting: Setting, trajectory: Optional[Trajectory], notes: dict,
              reference: Optional[Trajectory], size: float) -> dict:
    """The numbers of one setting, compared with the reference."""
    row = {"name": setting.name, "axis": setting.axis,
           "setting": asdict(setting), **notes}
    if trajectory is None:
        return row
    errors = ([float(np.abs(p - q).max() / size) for p, q in
               zip(trajectory.positions, reference.positions)]
              if reference is not None else [0.0] * len(trajectory.positions))
    ref = reference if reference is not None else trajectory
    # The incremental potential can be ~0 (a cloth in free fall): the
    # difference is taken relative to its largest size over the run.
    scale = max(max(abs(e) for e in ref.energies), 1e-300)
    row.update({
        "seconds": trajectory.seconds,
        "trajectory_error": errors[-1],
        "max_trajectory_error": max(errors),
        "frame_errors": errors,
        "energy": _finite(trajectory.energy),
        "energy_rel_diff": _finite(abs(trajectory.energy - ref.energy)
                                   / scale),
        "frame_energies": trajectory.energies,
        "min_distance": _finite(min(trajectory.min_distance)),
        "frame_min_distances": [_finite(d) for d in trajectory.min_distance],
        "intersections": any(trajectory.intersecting),
        "intersecting_frames": int(sum(trajectory.intersecting)),
        "newton_iterations": trajectory.newton,
        "cg_iterations": trajectory.cg,
        "inexact_directions": trajectory.inexact,
        "unconverged_frames": trajectory.unconverged,
        "kappa": _finite(trajectory.kappa),
        "warnings": trajectory.warnings,
    })
    return row


def bench_scene(spec: SceneSpec, frames: int, quick: bool) -> Optional[dict]:
    """The reference and every setting of one scene (None, said on
    stderr, if the reference fails)."""
    settings = grid(spec.adaptive, quick)
    with tqdm(total=1 + len(settings), desc=spec.name, unit="setting",
              file=sys.stderr, leave=False) as bar:
        bar.set_postfix_str(REFERENCE.name)
        ref_trajectory, notes = run(spec, REFERENCE, frames, None)
        bar.update()
        if ref_trajectory is None:
            tqdm.write(f"{spec.name}: skipped, the reference failed: "
                       f"{notes['error']}", file=sys.stderr)
            return None
        with configured(DEFAULT):
            first = spec.build(DEFAULT, None).world()
        size = float(np.linalg.norm(first.max(axis=0) - first.min(axis=0)))
        reference = summarise(REFERENCE, ref_trajectory, notes, None, size)
        kappa_base = ref_trajectory.kappa if spec.adaptive else None
        rows = []
        for setting in settings:
            bar.set_postfix_str(setting.name)
            trajectory, notes = run(spec, setting, frames, kappa_base)
            rows.append(summarise(setting, trajectory, notes, ref_trajectory,
                                  size))
            bar.update()
    default = next((r for r in rows if r["name"] == DEFAULT.name), None)
    base = default.get("seconds") if default else None
    for row in rows + [reference]:
        if base and row.get("seconds"):
            row["speedup"] = base / row["seconds"]
    return {"scene": spec.name, "summary": spec.summary, "frames": frames,
            "size": size, "distance_query": DISTANCE_QUERY * spec.dhat,
            "kappa_base": kappa_base if spec.adaptive else drop.KAPPA,
            "reference": reference, "settings": rows}


# ------------------------------------------------------------------ output

#: The columns of a scene's table in the JSON: (header, format).
SCENE_COLUMNS = (("setting", ""), ("time (s)", "{:.2f}"), ("speed-up", "{:.2f}x"),
                 ("trajectory error", "{:.1e}"), ("energy error", "{:.1e}"),
                 ("min distance (m)", "{:.1e}"), ("intersecting frames", ""),
                 ("Newton", ""), ("CG", ""), ("notes", ""))


def row_notes(row: dict) -> List[str]:
    """What a setting's line says besides its numbers."""
    notes = []
    if row["unconverged_frames"]:
        notes.append(f"{row['unconverged_frames']} frames unconverged")
    if row["inexact_directions"]:
        notes.append(f"{row['inexact_directions']} inexact directions")
    if row["compiled_during_run"]:
        notes.append("compiled during the run")
    if row["warnings"]:
        notes.append(f"{len(row['warnings'])} kinds of warnings")
    return notes


def scene_rows(result: dict) -> List[list]:
    """The scene's table, one row per setting (SCENE_COLUMNS); a failed
    setting has its name and the error alone."""
    rows = []
    for row in result["settings"]:
        if row.get("seconds") is None:
            rows.append([row["name"]] + [None] * (len(SCENE_COLUMNS) - 2)
                        + [f"failed: {row['error']}"])
            continue
        rows.append([row["name"], row["seconds"], row.get("speedup"),
                     row["trajectory_error"], row["energy_rel_diff"],
                     row["min_distance"], row["intersecting_frames"],
                     row["newton_iterations"], row["cg_iterations"],
                     "; ".join(row_notes(row))])
    return rows


def scene_title(result: dict) -> str:
    ref = result["reference"]
    return (f"{result['scene']}: {result['summary']}; {result['frames']} "
            f"frames, size {result['size']:.3f} m; reference (f64, CG 1e-10, "
            f"Newton tolerance /100) {ref['seconds']:.2f} s, Newton "
            f"{ref['newton_iterations']}, CG {ref['cg_iterations']}")


def print_table(result: dict) -> None:
    """The scene's table: one line per setting."""
    print(f"\n{scene_title(result)}")
    header = (f"{'setting':18s}{'time s':>8s}{'speed-up':>9s}{'traj err':>10s}"
              f"{'energy':>9s}{'min dist':>10s}{'isect':>6s}{'Newton':>7s}"
              f"{'CG':>7s}  notes")
    print(header)
    print("-" * len(header))
    for (name, seconds, speedup, error, energy, distance, isect, newton, cg,
         notes) in scene_rows(result):
        if seconds is None:
            print(f"{name:18s}  {notes}")
            continue
        print(f"{name:18s}{seconds:8.2f}"
              + ("       -x" if speedup is None else f"{speedup:8.2f}x")
              + ("         -" if error is None else f"{error:10.1e}")
              + ("        -" if energy is None else f"{energy:9.1e}")
              + ("       inf" if distance is None else f"{distance:10.1e}")
              + f"{'yes' if isect else 'no':>6s}{newton:7d}{cg:7d}  {notes}")


def describe(setting: dict) -> str:
    """A setting in words, as docs/accuracy.md's table names it."""
    axis = setting["axis"]
    s = setting["setting"]
    if axis == "default":
        return f"default ({s['precision']}, CG {_e(s['cg_tolerance'])})"
    if axis == "precision x cg":
        if s["precision"] == "f64":
            return f"CG {_e(s['cg_tolerance'])}"
        if s["cg_tolerance"] == DEFAULT.cg_tolerance:
            return s["precision"]
        return f"{s['precision']}, CG {_e(s['cg_tolerance'])}"
    if axis == "newton":
        return f"Newton tolerance x{s['newton_factor']:g}"
    if axis == "projection":
        return ("no projection" if s["projection"] == "none"
                else f"{s['projection']} projection")
    if axis == "linear maps":
        return "linear-map projection off"
    return setting["name"]  # dhat x0.5, kappa x10 fixed


def summary_rows(results: Dict[str, dict]) -> List[list]:
    """Every scene's settings in docs/accuracy.md's columns: "scene:
    setting", time (s and speed-up), trajectory error, Newton / CG, and the
    notes."""
    rows = []
    for name, result in results.items():
        for row in result["settings"]:
            label = f"{name}: {describe(row)}"
            if row.get("seconds") is None:
                rows.append([label, None, None, None, f"failed: {row['error']}"])
                continue
            notes = row_notes(row)
            time_cell = None
            if row.get("speedup") is not None:
                time_cell = {"s": row["seconds"], "speedup": row["speedup"]}
            else:
                notes.insert(0, f"{row['seconds']:.2f} s (the default failed)")
            rows.append([label, time_cell, row["trajectory_error"],
                         {"newton": row["newton_iterations"],
                          "cg": row["cg_iterations"]}, "; ".join(notes)])
    return rows


def pareto_front(points: Sequence[Tuple[float, float]]) -> List[int]:
    """Indices of the points no other point beats in both time and error,
    by increasing time."""
    order = sorted(range(len(points)), key=lambda k: points[k])
    front, best = [], float("inf")
    for k in order:
        if points[k][1] < best:
            front.append(k)
            best = points[k][1]
    return front


def plot(result: dict, path: Path) -> None:
    """Time against trajectory error (log), each setting a labelled point
    coloured by its axis, the Pareto front as a step line and the
    reference's time as a dotted line."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in result["settings"] if r.get("seconds") is not None]
    fig, ax = plt.subplots(figsize=(9, 6))
    axes = list(dict.fromkeys(r["axis"] for r in rows))
    colours = plt.get_cmap("tab10")
    points = [(r["seconds"], max(r["trajectory_error"], ERROR_FLOOR))
              for r in rows]
    for a, axis in enumerate(axes):
        chosen = [p for p, r in zip(points, rows) if r["axis"] == axis]
        ax.scatter([p[0] for p in chosen], [p[1] for p in chosen],
                   color=colours(a % 10), label=axis, zorder=3,
                   marker="o" if axis != "default" else "*",
                   s=30 if axis != "default" else 120)
    for (t, err), r in zip(points, rows):
        label = r["name"] + (" (isect)" if r["intersections"] else "")
        ax.annotate(label, (t, err), fontsize=7, xytext=(4, 3),
                    textcoords="offset points")
    front = pareto_front(points)
    if front:
        ax.step([points[k][0] for k in front], [points[k][1] for k in front],
                where="post", color="k", lw=1, alpha=0.6)
        ax.scatter([points[k][0] for k in front],
                   [points[k][1] for k in front], s=160, facecolors="none",
                   edgecolors="k", lw=1, zorder=4, label="Pareto front")
    ax.axvline(result["reference"]["seconds"], color="grey", ls=":",
               label="reference's time")
    ax.set_yscale("log")
    ax.set_xlabel(f"wall time of {result['frames']} frames (s, one thread)")
    ax.set_ylabel("trajectory error after the last frame (/ scene size)")
    ax.set_title(f"{result['scene']}: {result['summary']}")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=None,
                        help=f"frames per run (default {DEFAULT_FRAMES}, "
                             f"{QUICK_FRAMES} with --quick)")
    parser.add_argument("--scenes", default=",".join(SCENES),
                        help="comma-separated scenes: " + ", ".join(SCENES))
    parser.add_argument("--quick", action="store_true",
                        help=f"{QUICK_FRAMES} frames, 4 settings (smoke test)")
    parser.add_argument("--output", type=Path,
                        default=Path("out/accuracy_speed"),
                        help="folder for the Pareto plots")
    add_json_argument(parser, "accuracy_speed")
    args = parser.parse_args()
    names = [n.strip() for n in args.scenes.split(",") if n.strip()]
    unknown = [n for n in names if n not in SCENES]
    if unknown:
        parser.error(f"unknown scenes {unknown}; choose from {list(SCENES)}")
    frames = args.frames or (QUICK_FRAMES if args.quick else DEFAULT_FRAMES)
    yasps.config.num_threads = 1
    print(f"accuracy against speed: {frames} frames, one thread, backend "
          f"{yasps.backend()}; 'mixed' = f32 derivatives + "
          f"hessian_storage f32")
    print("traj err: largest position difference to the reference after "
          "the last frame / scene size; energy: difference of the total "
          "energy then / the reference's largest; min dist: smallest distance over the run "
          "(m); isect: some frame intersected")
    args.output.mkdir(parents=True, exist_ok=True)
    results = {}
    started = time.perf_counter()
    for name in names:
        result = bench_scene(SCENES[name], frames, args.quick)
        if result is None:
            continue
        results[name] = result
        print_table(result)
        picture = args.output / f"pareto_{name}.png"
        plot(result, picture)
        print(f"plot: {picture}", flush=True)
    out = Results("accuracy_speed")
    for name, result in results.items():
        out.table(name, [c[0] for c in SCENE_COLUMNS], scene_rows(result),
                  [c[1] for c in SCENE_COLUMNS],
                  scene_title(result) + ". Time: the frames' wall time, one "
                  "thread; trajectory error: the largest position difference "
                  "to the reference after the last frame / scene size; energy "
                  "error: the total energy's difference to the reference's "
                  "then / the reference's largest; min distance: the smallest "
                  "over the run.")
    out.table("summary", ["scene: setting", "time", "trajectory error",
                          "Newton / CG", "notes"], summary_rows(results),
              ["", "{0[s]:.2f} s ({0[speedup]:.2f}x)", "{:.1e}",
               "{0[newton]} / {0[cg]}", ""],
              f"{frames} frames, one thread. Time: the frames' wall time "
              "(speed-up over the default setting); trajectory error: the "
              "largest position difference to the reference (f64, CG 1e-10, "
              "Newton tolerance /100) after the last frame, over the scene's "
              "size; Newton and CG: iteration counts.")
    seconds = time.perf_counter() - started
    out.values["run"] = {"frames": frames, "quick": args.quick, "threads": 1,
                         "backend": yasps.backend(), "host": platform.node(),
                         "seconds": seconds}
    out.values["scenes"] = results
    path = out.write(args.json)
    print(f"\nresults: {path} ({seconds:.0f} s in all)")


if __name__ == "__main__":
    main()
