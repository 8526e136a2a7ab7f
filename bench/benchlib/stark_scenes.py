"""The two contact scenes of bench/stark_peer.py: their yasps side, the
meshes and matched constants they give STARK, and the checks every frame
of both sides gets.

- ``twist``: the twisting cloth of examples/paper/mat_twist.py ("small",
  625 vertices) at dt = 0.01 s: its left and right edges turn about the x
  axis at 5 rad/s in opposite directions, no gravity.
- ``bunny``: the soft tet bunny of ../shared/data/bunny-1.8k.msh (1,869
  vertices, 7,356 tets; stable Neo-Hookean, Young's modulus 31.7 kPa,
  Poisson 0.226, 1 kg, 0.2 m tall) dropped from 2 cm onto a 1 m cloth of
  25 x 25 vertices pinned at its four corners (examples/paper/
  many_bunnies.py's materials), 2,494 vertices in all.

Both: implicit Euler, no friction, dhat = 1e-3 m, Newton until the step is
below 1e-2 m/s (at most ImplicitEuler's cap of iterations, or
--newton-cap), block-Jacobi PCG to relative residual 1e-4 (at most 1,000
iterations).

The yasps side runs in its own process (bench/stark_yasps_side.py, which
bench/stark_peer.py starts) and writes the same per-frame arrays as
bench/stark_driver.py.
"""

from __future__ import annotations

import functools
import json
import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Dict, Optional, Tuple

from benchlib import ROOT

sys.path.insert(0, str(ROOT / "examples" / "paper"))

import ipctk  # noqa: E402
import numpy as np  # noqa: E402

DT = 0.01
VELOCITY_TOLERANCE = 1e-2        # m/s: Newton's step rule, both sides
CG_TOLERANCE = 1e-4              # PCG's relative residual, both sides
DHAT = 1e-3                      # m: where the barrier starts, both sides
#: STARK's pins and held edges: penalty springs (N/m) on their targets.
PIN_STIFFNESS = 1e5
#: STARK's smallest contact stiffness (its barrier k (dhat - d)^3 / 3 grows
#: from there when a step would intersect): its own twisting-cloth example's
#: value for the cloth alone, its default for the bunny.
CONTACT_STIFFNESS = {"twist": 1e5, "bunny": 1e6}
#: STARK's membrane: thickness (m) and Poisson's ratio (> 0 in STARK;
#: Baraff-Witkin has no Poisson coupling, so as small as that allows).
MEMBRANE_THICKNESS = 1e-3
MEMBRANE_POISSON = 1e-3
#: ipctk's closest distance looks this far (m).
CHECK_RANGE = 1e-2

BUNNY_HEIGHT = 0.2               # m, as many_bunnies.py's
BUNNY_DROP = 0.02                # m above the cloth
BUNNY_MODULUS = (31.7e3, 0.226)  # Young's modulus (Pa), Poisson's ratio
BUNNY_MASS = 1.0                 # kg


@dataclass
class Spec:
    """A scene as both sides see it: every vertex (the cloth's first, then
    the bunny's), the contact surface's triangles in that numbering, the
    cloth's triangles, the bunny's tets (its own numbering), the pinned and
    the held vertices, and the materials in yasps' terms."""
    name: str
    vertices: np.ndarray
    faces: np.ndarray
    cloth_faces: np.ndarray
    cloth: Dict[str, float]
    gravity: Tuple[float, float, float]
    tets: Optional[np.ndarray] = None
    bunny: Dict[str, float] = field(default_factory=dict)
    pinned: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    held: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    sides: np.ndarray = field(default_factory=lambda: np.zeros(0))
    twist_speed: float = 0.0

    @property
    def cloth_vertices(self) -> int:
        return int(self.cloth_faces.max()) + 1


@dataclass
class YaspsScene:
    """The yasps side: its stepper, its contact, what runs before each step
    (the twist's edges turning) and the scene as STARK gets it."""
    stepper: object
    contact: object
    before_step: Callable[[], None]
    spec: Spec
    prescribed: Optional[object] = None


# --- the yasps side -----------------------------------------------------------

def build_twist() -> YaspsScene:
    """examples/paper/mat_twist.py at dt = 0.01 s."""
    import mat_twist

    mat_twist.DT["small"] = DT
    stepper, contact, bodies, edges = mat_twist.build("small")
    faces = np.asarray(bodies["cloth"].faces, dtype=np.int64)
    held = np.flatnonzero(edges.held)
    spec = Spec("twist", contact.world(), faces, faces,
                dict(mat_twist.CLOTH, density=mat_twist.DENSITY),
                (0.0, 0.0, 0.0), held=held, sides=edges.sides[held],
                twist_speed=mat_twist.SPEED)
    # The stepper turns the edges itself (prescribe).
    return YaspsScene(stepper, contact, lambda: None, spec, edges)


#: The scale series of the bunny on the pinned cloth: the bunny's mesh
#: (../shared/data) and the cloth's cells per side, by scene name. "bunny"
#: is scene B; the rest grow it to the field's sizes (vertices in all:
#: 2,494, 4,270, 28,602, 56,442).
BUNNY_SIZES: Dict[str, Tuple[str, int]] = {
    "bunny": ("bunny-1.8k.msh", 24),
    "bunny-4.3k": ("bunny-1.8k.msh", 48),
    "bunny-28.6k": ("bunny-19k.msh", 96),
    "bunny-56k": ("bunny-19k.msh", 192),
}


def build_bunny(name: str = "bunny") -> YaspsScene:
    """The tet bunny on the pinned cloth, as many_bunnies.py builds its
    soft bunnies (one, centred, no friction), at the size BUNNY_SIZES[name]
    gives."""
    import yasps
    from common import GRAVITY, bunny, lame, pinned_cloth
    from many_bunnies import CLOTH, CLOTH_DENSITY
    from yasps.contact import Contact
    from yasps.sim import (ImplicitEuler, add_elastic_tets, add_free_vertices,
                           lumped_masses)

    mesh_file, n = BUNNY_SIZES[name]
    s = yasps.scene("stark_bunny_on_cloth")
    cloth, cloth_faces, pinned = pinned_cloth(s, n, CLOTH, CLOTH_DENSITY)
    verts, tets, surface = bunny(mesh_file, BUNNY_HEIGHT)
    verts = verts + [0.0, 0.0, BUNNY_DROP]
    volume = lumped_masses(verts, tets, 1.0).sum()
    density = BUNNY_MASS / volume
    mu, lam = lame(*BUNNY_MODULUS)
    mesh = s.addMesh("bunny")
    soft = add_free_vertices(mesh, verts, lumped_masses(verts, tets, density))
    add_elastic_tets(mesh, soft.x, verts, tets, mu, lam, scale=DT * DT)
    union = s.addMesh("all").addPrimitiveUnion("v", [cloth.primitive,
                                                     soft.primitive])
    union.addAttribute("position")
    count = cloth.primitive.numInstances
    faces = np.concatenate([cloth_faces, surface + count]).astype(np.int64)
    # The bunny's inner vertices take no part (STARK's contact is between
    # surfaces too).
    contact = Contact(s, union, faces=faces, dhat=DHAT,
                      average_mass=CLOTH_DENSITY / (n + 1) ** 2, points=False)
    targets = [cloth.x, soft.x]
    s.addMinimizeTarget(targets)
    stepper = ImplicitEuler(s, targets, [cloth.x_hat, soft.x_hat], dt=DT,
                            gravity=[GRAVITY, GRAVITY], fixed=[pinned, None],
                            contact=contact)
    spec = Spec(name, contact.world(), faces,
                np.asarray(cloth_faces, dtype=np.int64),
                dict(CLOTH, density=CLOTH_DENSITY), tuple(GRAVITY),
                tets=np.asarray(tets, dtype=np.int64),
                bunny=dict(mu=mu, lam=lam, density=density),
                pinned=np.flatnonzero(pinned))
    return YaspsScene(stepper, contact, lambda: None, spec)


SCENES: Dict[str, Callable[[], YaspsScene]] = {"twist": build_twist}
SCENES.update({name: functools.partial(build_bunny, name)
               for name in BUNNY_SIZES})


def run_yasps(name: str, frames: int, threads: int,
              newton_cap: Optional[int] = None) -> Dict[str, np.ndarray]:
    """Steps the scene ``frames`` frames on ``threads`` threads (yasps'
    kernels, PCG and ipctk's detection alike); per frame: wall seconds
    (the twist's CCD-limited edge motion included), Newton directions, CG
    iterations, whether Newton converged, the barrier stiffness and the
    positions; over the run, the seconds of each stage of the Newton
    reports and of the edges' motion (``timer_names``,
    ``timer_seconds``), and the Newton cap and projection the stepper had
    (``newton_cap``: ImplicitEuler's default unless given)."""
    import dataclasses

    import yasps
    from yasps.sim.newton import compile_kernels

    yasps.config.num_threads = threads
    ipctk.set_num_threads(threads)
    scene = SCENES[name]()
    stepper, contact = scene.stepper, scene.contact
    if newton_cap is not None:
        stepper.settings = dataclasses.replace(stepper.settings,
                                               max_iterations=newton_cap)
    # Warm kernels: compiled or loaded before the first frame, untimed.
    compile_kernels(stepper.scene, contact, False)
    warnings.simplefilter("ignore")
    rows: Dict[str, list] = {k: [] for k in ("seconds", "directions", "cg",
                                             "capped", "retries",
                                             "converged", "stiffness",
                                             "residual")}
    positions = [contact.world()]
    stages: Dict[str, float] = {"prescribed motion": 0.0}
    for frame in range(1, frames + 1):
        start = time.perf_counter()
        scene.before_step()
        moved = time.perf_counter()
        report = stepper.step(warn=False)
        rows["seconds"].append(time.perf_counter() - start)
        stages["prescribed motion"] += moved - start
        for stage, seconds in report.seconds.items():
            stages[stage] = stages.get(stage, 0.0) + seconds
        rows["directions"].append(len(report.cg_iterations))
        rows["cg"].append(sum(report.cg_iterations))
        # Directions taken from a PCG stopped at its cap.
        rows["capped"].append(report.inexact_directions)
        # Solves repeated with more projection (progressive projection).
        rows["retries"].append(getattr(report, "projection_retries", 0))
        rows["converged"].append(report.converged)
        rows["stiffness"].append(contact.kappa)
        rows["residual"].append(report.residual)
        positions.append(contact.world())
        print(f"@frame {frame} {rows['seconds'][-1]:.4f} s, "
              f"{rows['directions'][-1]} directions, {rows['cg'][-1]} CG, "
              f"converged {report.converged}", flush=True)
    out = {k: np.asarray(v, dtype=float) for k, v in rows.items()}
    out["solves"] = out["directions"] + out["retries"]
    out["newton_cap"] = np.array(stepper.settings.max_iterations)
    out["projection"] = np.array(stepper.settings.projection)
    out["failed"] = np.zeros(frames)
    out["positions"] = np.asarray(positions)
    out["timer_names"] = np.array(list(stages))
    out["timer_seconds"] = np.array(list(stages.values()))
    if scene.prescribed is not None:
        out["angle"] = np.array([scene.prescribed.angle,
                                 scene.prescribed.wanted])
    return out


# --- STARK's constants ------------------------------------------------------------

def stark_snh(mu: float, lam: float) -> Tuple[float, float]:
    """STARK's (Young's modulus, Poisson's ratio) for yasps' stable
    Neo-Hookean (mu, lam). STARK turns (E, nu) into Lame's (mu_E, lam_E)
    and writes Smith et al.'s energy with mu' = 4/3 mu_E and lam' = lam_E
    + 5/6 mu_E, alpha = 1 + 3 mu' / (4 lam'): the same energy as yasps'
    when mu' = mu and lam' = lam."""
    mu_e = 0.75 * mu
    lam_e = lam - 5.0 / 6.0 * mu_e
    if lam_e <= 0:
        raise ValueError(f"stark_snh: lambda {lam} too small for STARK's "
                         f"parametrisation (needs lambda > 5/8 mu)")
    young = mu_e * (3 * lam_e + 2 * mu_e) / (lam_e + mu_e)
    return young, lam_e / (2 * (lam_e + mu_e))


def stark_membrane(stretch: float) -> Dict[str, float]:
    """STARK's Neo-Hookean membrane for Baraff-Witkin's stretch stiffness
    (N/m): at small strain, its plane-stress Young's modulus times the
    thickness is the stiffness under uniaxial stress, which is
    Baraff-Witkin's ``stretch``; biaxially it is stretch / (1 - nu), equal
    as nu -> 0. Its shear stiffness is then stretch / (2 (1 + nu)), which an
    isotropic material cannot set apart (Baraff-Witkin's ``shear``)."""
    return dict(thickness=MEMBRANE_THICKNESS,
                youngs_modulus=stretch / MEMBRANE_THICKNESS,
                poissons_ratio=MEMBRANE_POISSON)


def hinge_geometry(vertices: np.ndarray, faces: np.ndarray
                   ) -> Tuple[np.ndarray, np.ndarray]:
    """Per interior edge: its rest length and the rest areas of its two
    triangles together."""
    from yasps.sim import hinges_of

    h = hinges_of(faces)
    x0, x1, x2, x3 = (vertices[h[:, k]] for k in range(4))
    length = np.linalg.norm(x1 - x0, axis=1)
    areas = 0.5 * (np.linalg.norm(np.cross(x1 - x0, x2 - x0), axis=1)
                   + np.linalg.norm(np.cross(x3 - x0, x1 - x0), axis=1))
    return length, areas


def stark_bending(bending: float, vertices: np.ndarray, faces: np.ndarray
                  ) -> float:
    """STARK's bending stiffness for yasps' dihedral bending ``bending``.
    At a small hinge angle theta yasps' energy is bending * l * theta^2;
    STARK's flat-rest (Bergou et al. 2006) energy is k * 3 l^2 theta^2 /
    (4 (A0 + A1)). One k cannot match every hinge (the grid's diagonal
    edges weigh differently): this matches them on average over the
    cloth's hinges."""
    length, areas = hinge_geometry(vertices, faces)
    return float(bending * np.mean(4.0 * areas / (3.0 * length)))


def stark_constants(spec: Spec) -> Dict:
    """scene.json for bench/stark_driver.py."""
    cloth_vertices = spec.vertices[:spec.cloth_vertices]
    cloth = dict(stark_membrane(spec.cloth["stretch"]),
                 density=spec.cloth["density"],
                 bending=stark_bending(spec.cloth["bending"], cloth_vertices,
                                       spec.cloth_faces))
    out = dict(name=spec.name, dt=DT, gravity=list(spec.gravity),
               velocity_tolerance=VELOCITY_TOLERANCE,
               cg_tolerance=CG_TOLERANCE, cloth=cloth,
               cloth_vertices=spec.cloth_vertices,
               contact=dict(thickness=DHAT / 2,
                            min_stiffness=CONTACT_STIFFNESS[
                                "twist" if spec.name == "twist" else "bunny"]),
               pin_stiffness=PIN_STIFFNESS, twist_speed=spec.twist_speed)
    if spec.tets is not None:
        young, poisson = stark_snh(spec.bunny["mu"], spec.bunny["lam"])
        out["bunny"] = dict(youngs_modulus=young, poissons_ratio=poisson,
                            density=spec.bunny["density"])
    return out


def export(spec: Spec, folder: Path) -> Dict:
    """Writes scene.npz (arrays) and scene.json (STARK's constants) for
    bench/stark_driver.py; returns the constants."""
    folder.mkdir(parents=True, exist_ok=True)
    arrays = dict(vertices=spec.vertices, cloth_faces=spec.cloth_faces,
                  pinned=spec.pinned, held=spec.held, sides=spec.sides)
    if spec.tets is not None:
        arrays["tets"] = spec.tets
    np.savez(folder / "scene.npz", **arrays)
    constants = stark_constants(spec)
    (folder / "scene.json").write_text(json.dumps(constants, indent=1))
    return constants


# --- checks and physical figures, the same for both sides -------------------

class Checker:
    """ipctk's verdict on a frame, independent of both codes: whether some
    edge crosses some triangle of the contact surface, and the closest
    distance between its primitives (within CHECK_RANGE; inf beyond)."""

    def __init__(self, spec: Spec):
        faces = np.ascontiguousarray(spec.faces, dtype=np.int32)
        self.mesh = ipctk.CollisionMesh(spec.vertices, ipctk.edges(faces),
                                        faces)

    def __call__(self, V: np.ndarray) -> Tuple[bool, float]:
        V = np.ascontiguousarray(V, dtype=float)
        crossing = bool(ipctk.has_intersections(self.mesh, V))
        collisions = ipctk.NormalCollisions()
        collisions.build(self.mesh, V, CHECK_RANGE)
        closest = float("inf") if collisions.empty() else float(np.sqrt(
            collisions.compute_minimum_distance(self.mesh, V)))
        return crossing, closest


def physics(spec: Spec, V: np.ndarray) -> Dict[str, float]:
    """What the scene's motion comes to, to compare both sides' physics:
    the twisted cloth's spread (RMS distance of its vertices from the twist
    axis) and its extent across the axis; the bunny's centroid height and
    the cloth's lowest point."""
    if spec.name == "twist":
        radius = np.linalg.norm(V[:, 1:], axis=1)
        return {"spread (m)": float(np.sqrt(np.mean(radius ** 2))),
                "y-z extent (m)": float(np.max(V[:, 1:].max(0) - V[:, 1:].min(0)))}
    count = spec.cloth_vertices
    return {"bunny centroid z (m)": float(V[count:, 2].mean()),
            "cloth lowest z (m)": float(V[:count, 2].min())}


def trajectory_gap(spec: Spec, a: np.ndarray, b: np.ndarray) -> float:
    """The largest difference over frames between two runs' leading figure
    (the spread; the bunny's centroid height)."""
    key = next(iter(physics(spec, a[0])))
    return float(max(abs(physics(spec, x)[key] - physics(spec, y)[key])
                     for x, y in zip(a, b)))
