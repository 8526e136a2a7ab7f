"""The cells of the stability map (bench/extremes.py): small whole
simulations at one setting of the map's axes, and what each one ended in.

A cell is a :class:`Cell`: a kind of scene (:data:`KINDS`) and its values on
the axes (stiffness, Poisson's ratio, mass ratio, time step, impact speed,
contact distance, scene size, element shape, a start within the contact
distance, precision, friction). :func:`run_cell` builds the scene, steps it
and watches every frame with checks of its own: positions finite, no
intersection by ipctk (a collision mesh built here, apart from the
runtime's queries), no inverted tet, the momentum of a free collision, the
mechanical energy, the time per frame, and every warning and error yasps
gave. :func:`outcome` sorts the record into "holds", "warned" or "stopped"
(yasps said what went wrong) and the failures the map must not have:
"nan", "intersection", "silent" (something went wrong and nothing said so),
"crash" (an error that is not a YaspsError) and "hang" (bench/extremes.py
kills a cell past its time budget).

Every scene stands above the ground half-space z = 0 (except the free
collision) with gravity, implicit Euler, IPC's adaptive barrier stiffness,
Newton's tolerance relative to the scene's size (``Relative(1e-2)`` per
second, IPC's rule, so that one setting means the same at every size).
"""

from __future__ import annotations

import math
import time
import traceback
import warnings
from dataclasses import asdict, dataclass, field, replace
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

#: The kinds of scene: one soft tet box, one cloth, one affine box (each
#: dropped on the ground), two soft boxes stacked, a cloth on a soft box on
#: an affine box (one UNION of the three kinds), and two soft boxes meeting
#: in free space (no gravity, no ground: momentum is conserved).
KINDS = ("soft", "cloth", "affine", "stack", "union", "collide")

#: The kinds with tets (inverted elements are counted on them).
TET_KINDS = ("soft", "stack", "union", "collide")

#: Outcomes; the first three are allowed, the others are the map's failures.
ALLOWED = ("holds", "warned", "stopped")
FAILURES = ("nan", "intersection", "silent", "crash", "hang")

GRAVITY = (0.0, 0.0, -9.81)
#: Densities of the tet bodies (kg/m^3) and the cloth (kg/m^2).
DENSITY, CLOTH_DENSITY = 1000.0, 0.2
#: Newton stops when a step moves no vertex faster than this fraction of
#: the scene's size per second.
VELOCITY_TOLERANCE = 1e-2


@dataclass(frozen=True)
class Cell:
    """One simulation of the map. ``young``: Young's modulus (Pa) of tets
    and affine bodies, None for the kind's default; ``stretch``: the
    cloth's stretch stiffness (N/m); ``mass_ratio``: the density of the
    upper (or right) body over the lower one's; ``speed``: the falling (or
    approaching) body's start velocity (m/s); ``dhat``: the contact
    distance as a fraction of the scene's size (its bounding box's
    diagonal); ``size``: the scene's edge length (m); ``aspect``: the tet
    boxes' height over their width (slivers below 1); ``within_dhat``: the
    bodies start at half the contact distance from what they land on;
    ``guard``: the soft tets with ``guard_inversion=True`` (stable
    Neo-Hookean made inversion-free)."""
    kind: str
    young: float = 1e5
    poisson: float = 0.3
    stretch: float = 1e3
    mass_ratio: float = 1.0
    dt: float = 1e-2
    speed: float = 0.0
    dhat: float = 1e-3
    size: float = 0.1
    aspect: float = 1.0
    within_dhat: bool = False
    precision: str = "f64"
    friction: float = 0.0
    frames: int = 20
    guard: bool = False

    def name(self) -> str:
        """What differs from the kind's defaults, as 'axis=value' pairs."""
        default = base(self.kind)
        changed = [f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                   for k, v in asdict(self).items()
                   if k != "kind" and v != getattr(default, k)]
        return f"{self.kind}: " + (", ".join(changed) or "defaults")


def base(kind: str) -> Cell:
    """The kind's cell at the defaults (the free collision at 1 m/s)."""
    return Cell(kind, speed=1.0 if kind == "collide" else 0.0)


@dataclass
class Record:
    """What a cell's run did."""
    frames: int = 0
    unconverged: int = 0
    #: the worst unconverged frame's residual (its direction over the
    #: tolerance)
    worst_residual: float = 0.0
    nan: bool = False
    intersecting_frames: int = 0
    inverted_tets: int = 0
    #: |change of total momentum| over (total mass x velocity tolerance)
    momentum_drift: float = 0.0
    #: the largest (E - E0) / E0 of kinetic plus gravitational energy
    energy_growth: float = 0.0
    seconds_per_frame: float = 0.0
    newton_per_frame: float = 0.0
    warnings: List[str] = field(default_factory=list)
    #: the error that stopped the run: (type, message), or None
    error: Optional[Tuple[str, str]] = None
    yasps_error: bool = False


def outcome(record: Record) -> Tuple[str, str]:
    """The cell's end state and a short reason."""
    if record.error is not None and record.error[0] == "Hang":
        return "hang", record.error[1]
    if record.error is not None and not record.yasps_error:
        return "crash", f"{record.error[0]}: {record.error[1]}"[:200]
    if record.nan:
        return "nan", "positions not finite"
    if record.intersecting_frames:
        return "intersection", f"{record.intersecting_frames} frames intersect"
    problems = []
    if record.unconverged:
        problems.append(f"{record.unconverged} frames unconverged")
    if record.inverted_tets:
        problems.append(f"{record.inverted_tets} tets inverted")
    if record.error is not None:
        return "stopped", f"{record.error[0]}: {record.error[1]}"[:200]
    if record.warnings:
        return "warned", record.warnings[0][:200]
    if problems:
        return "silent", "; ".join(problems)
    return "holds", ""


# -- scenes -------------------------------------------------------------------

@dataclass
class Body:
    """A body's world vertices in the contact UNION: its slice there, its
    vertex masses, its tets (None for a cloth or an affine body) and its
    start velocity."""
    start: int
    masses: np.ndarray
    tets: Optional[np.ndarray]
    velocity: np.ndarray


@dataclass
class Built:
    """A cell's scene: the stepper, its contact, the contact's surface
    triangles and the bodies in the UNION's order."""
    stepper: Any
    contact: Any
    faces: np.ndarray
    bodies: List[Body]


def _box(cell: Cell, width: float) -> Tuple[np.ndarray, np.ndarray]:
    """A tet box of width ``width`` and height ``aspect * width``, its
    bottom at z = 0, centred in x and y."""
    from yasps.sim import box_tet_mesh
    verts, tets = box_tet_mesh(2, size=1.0)
    verts = (verts - [0.5, 0.5, 0.0]) * [width, width, width * cell.aspect]
    return verts, tets.astype(np.int64)


def _gap(cell: Cell, dhat: float) -> float:
    """How far above what it lands on a body starts: half the contact
    distance for ``within_dhat``; else beyond it by what gravity and the
    start speed cover in three steps, so that every cell's bodies touch
    within its first frames, whatever its time step."""
    if cell.within_dhat:
        return 0.5 * dhat
    t = 3.0 * cell.dt
    return 1.5 * dhat + cell.speed * t + 0.5 * 9.81 * t * t


def build(cell: Cell) -> Built:
    """The cell's scene and stepper."""
    import yasps
    from yasps.contact import Contact, Relative, surface_of
    from yasps.sim import (ImplicitEuler, add_affine_body, add_cloth,
                           add_elastic_tets, add_free_vertices, cloth_grid,
                           lame, lumped_masses)

    if cell.kind not in KINDS:
        raise ValueError(f"unknown kind {cell.kind!r}")
    L = cell.size
    # The contact distance in metres: a fraction of the diagonal of the
    # scene's bounding box, about 2 L for every kind.
    dhat = cell.dhat * 2.0 * L
    gap = _gap(cell, dhat)
    s = yasps.scene(f"extremes_{cell.kind}", precision=cell.precision)
    dt2 = cell.dt * cell.dt
    mu, lam = lame(cell.young, cell.poisson)
    members, faces, bodies, targets, predicted = [], [], [], [], []
    gravity, velocities = [], []
    count = 0
    free_collision = cell.kind == "collide"

    def add_soft(name: str, offset, density: float, velocity) -> None:
        nonlocal count
        verts, tets = _box(cell, L)
        verts = verts + offset
        masses = lumped_masses(verts, tets, density)
        body = add_free_vertices(s.addMesh(name), verts, masses)
        add_elastic_tets(getattr(s, name), body.x, verts, tets, mu, lam,
                         scale=dt2, guard_inversion=cell.guard or None)
        members.append(body.primitive)
        faces.append(surface_of(tets) + count)
        bodies.append(Body(count, masses, tets, np.asarray(velocity, float)))
        targets.append(body.x)
        predicted.append(body.x_hat)
        gravity.append(None if free_collision else GRAVITY)
        velocities.append(np.tile(velocity, (len(verts), 1)))
        count += len(verts)

    def add_affine(name: str, offset, density: float) -> None:
        nonlocal count
        verts, tets = _box(cell, L)
        masses = lumped_masses(verts, tets, density)
        volume = masses.sum() / density
        body = add_affine_body(s.addMesh(name), verts, masses,
                               stiffness=cell.young * volume, scale=dt2,
                               translation=offset)
        members.append(body.vertices)
        faces.append(surface_of(tets) + count)
        bodies.append(Body(count, masses, None, np.zeros(3)))
        targets.extend([body.A, body.t])
        predicted.extend([body.A_hat, body.t_hat])
        gravity.extend([None, GRAVITY])
        velocities.extend([None, None])
        count += len(verts)

    def add_sheet(name: str, height: float, velocity) -> None:
        nonlocal count
        verts, tri = cloth_grid(6, size=L, height=0.0)
        # Tilted by 10 degrees about x: a corner lands first.
        c, s_ = math.cos(0.17), math.sin(0.17)
        verts = verts @ np.array([[1, 0, 0], [0, c, s_], [0, -s_, c]])
        verts[:, 2] += height - verts[:, 2].min()
        masses = lumped_masses(verts, tri, CLOTH_DENSITY)
        body = add_free_vertices(s.addMesh(name), verts, masses)
        add_cloth(getattr(s, name), body.x, verts, tri, cell.stretch,
                  cell.stretch, 1e-3 * cell.stretch * L * L, scale=dt2)
        members.append(body.primitive)
        faces.append(tri.astype(np.int64) + count)
        bodies.append(Body(count, masses, None, np.asarray(velocity, float)))
        targets.append(body.x)
        predicted.append(body.x_hat)
        gravity.append(GRAVITY)
        velocities.append(np.tile(velocity, (len(verts), 1)))
        count += len(verts)

    down = np.array([0.0, 0.0, -cell.speed])
    light, heavy = DENSITY, DENSITY * cell.mass_ratio
    if cell.kind == "soft":
        add_soft("soft", [0, 0, gap], DENSITY, down)
    elif cell.kind == "cloth":
        add_sheet("cloth", gap, down)
    elif cell.kind == "affine":
        add_affine("rigid", [0, 0, gap], DENSITY)
    elif cell.kind == "stack":
        lower = 1.5 * dhat
        add_soft("lower", [0, 0, lower], light, np.zeros(3))
        add_soft("upper", [0, 0, lower + cell.aspect * L + gap], heavy, down)
    elif cell.kind == "union":
        lower = 1.5 * dhat
        add_affine("rigid", [0, 0, lower], light)
        top = lower + cell.aspect * L + gap
        add_soft("soft", [0, 0, top], heavy, down)
        add_sheet("cloth", top + cell.aspect * L + gap, down)
    else:  # collide: the right box approaches the left one along x
        left = np.array([-0.5 * L - 0.5 * gap, 0, 0])
        add_soft("left", left, light, -0.5 * np.array([-cell.speed, 0, 0]))
        add_soft("right", -left, heavy, 0.5 * np.array([-cell.speed, 0, 0]))
    union = s.addMesh("all").addPrimitiveUnion("v", members)
    union.addAttribute("position")
    planes = [] if free_collision else [((0, 0, 0), (0, 0, 1))]
    contact = Contact(s, union, faces=np.concatenate(faces), dhat=dhat,
                      halfspaces=planes, friction=cell.friction,
                      eps_v=Relative(1e-3), points=False)
    s.addMinimizeTarget(targets)
    stepper = ImplicitEuler(
        s, targets, predicted, dt=cell.dt, gravity=gravity,
        contact=contact, velocity_tolerance=Relative(VELOCITY_TOLERANCE),
        velocities=velocities)
    return Built(stepper, contact, np.concatenate(faces), bodies)


# -- running ------------------------------------------------------------------

def _inverted(V: np.ndarray, bodies: Sequence[Body]) -> int:
    from yasps.sim.inversion import signed_volumes
    return sum(int((signed_volumes(V, body.start + body.tets) <= 0).sum())
               for body in bodies if body.tets is not None)


def _mechanics(V: np.ndarray, before: np.ndarray, dt: float,
               bodies: Sequence[Body], gravity: bool
               ) -> Tuple[np.ndarray, float, float]:
    """Total momentum, kinetic plus gravitational energy (heights above
    the ground) and total mass of the world vertices moved from ``before``
    to ``V`` in ``dt``."""
    masses = np.concatenate([b.masses for b in bodies])
    velocity = (V - before) / dt
    momentum = (masses[:, None] * velocity).sum(axis=0)
    energy = 0.5 * float((masses * (velocity ** 2).sum(axis=1)).sum())
    if gravity:
        energy += 9.81 * float((masses * V[:, 2]).sum())
    return momentum, energy, float(masses.sum())


def run_cell(cell: Cell) -> Record:
    """Builds and steps the cell's scene, frame by frame, recording what
    happened (never raising)."""
    import ipctk
    import yasps
    from yasps.sim.newton import compile_kernels

    record = Record()
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            built = build(cell)
            stepper, contact = built.stepper, built.contact
            gravity = cell.kind != "collide"
            start = contact.world()
            mesh = ipctk.CollisionMesh(start, ipctk.edges(built.faces),
                                       built.faces)
            previous = start - _start_velocity(built) * cell.dt
            momentum0, energy0, mass = _mechanics(start, previous, cell.dt,
                                                  built.bodies, gravity)
            # Kernels compiled first: the time per frame is stepping's.
            compile_kernels(stepper.scene, contact, False)
            newton, began = 0, time.perf_counter()
            for frame in range(cell.frames):
                report = stepper.step()
                V = contact.world()
                record.frames += 1
                newton += report.iterations
                if not report.converged:
                    record.unconverged += 1
                    record.worst_residual = max(record.worst_residual,
                                                float(report.residual))
                if not np.isfinite(V).all():
                    record.nan = True
                    break
                # Through another surface (ipctk) or through the ground.
                if ipctk.has_intersections(mesh, V) or \
                        (gravity and V[:, 2].min() <= 0.0):
                    record.intersecting_frames += 1
                record.inverted_tets = max(record.inverted_tets,
                                           _inverted(V, built.bodies))
                momentum, energy, _ = _mechanics(V, start, cell.dt,
                                                 built.bodies, gravity)
                start = V
                if not gravity:
                    record.momentum_drift = max(
                        record.momentum_drift,
                        float(np.linalg.norm(momentum - momentum0)) /
                        (mass * VELOCITY_TOLERANCE * 2.0 * cell.size))
                if energy0 > 0:
                    record.energy_growth = max(record.energy_growth,
                                               (energy - energy0) / energy0)
            elapsed = time.perf_counter() - began
        record.seconds_per_frame = elapsed / max(record.frames, 1)
        record.newton_per_frame = newton / max(record.frames, 1)
        record.warnings = _messages(caught)
    except yasps.YaspsError as error:
        record.error = (type(error).__name__, str(error).splitlines()[0])
        record.yasps_error = True
    except Exception as error:  # noqa: BLE001 - the map records any error
        last = traceback.extract_tb(error.__traceback__)[-1]
        record.error = (type(error).__name__,
                        f"{error} ({last.filename}:{last.lineno})")
    return record


def _start_velocity(built: Built) -> np.ndarray:
    """The world vertices' start velocities (affine bodies start at rest)."""
    return np.concatenate([np.tile(b.velocity, (len(b.masses), 1))
                           for b in built.bodies])


def _messages(caught) -> List[str]:
    """The distinct warnings' first lines, in order."""
    seen: List[str] = []
    for w in caught:
        text = f"{w.category.__name__}: {str(w.message).splitlines()[0]}"
        if text not in seen:
            seen.append(text)
    return seen


def with_axis(cell: Cell, axis: str, value: Any) -> Cell:
    """``cell`` with ``axis`` set to ``value``."""
    return replace(cell, **{axis: value})


def as_row(cell: Cell, record: Record) -> Dict[str, Any]:
    """The cell and its record as one flat dict (JSON-ready)."""
    state, reason = outcome(record)
    row: Dict[str, Any] = {"cell": cell.name(), **asdict(cell)}
    row.update(asdict(record))
    row["outcome"], row["reason"] = state, reason
    return row
