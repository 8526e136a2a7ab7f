"""IPC contact between bodies of any parameterisation, by ipctk.

:class:`Contact` owns the plumbing between a scene and ipctk (the IPC
toolkit): the world positions of a vertex primitive or UNION, computed by
the scene's own kernels from whatever parameterises them; IPC's collision
set at those positions (by the runtime's narrow phase, or ipctk's,
:mod:`.detection`), as dynamic pair primitives joined to the vertices (one
per closest-feature type, :mod:`.pairs`) that carry IPC's barrier as yasps
energies; and additive CCD for the largest safe step. The
barrier's derivatives and assembly are yasps' own, so free, affine, caged
or new parameterisations need no contact code of their own::

    c = Contact(scene, union, faces=F, dhat=1e-3, average_mass=0.01,
                friction=0.2, halfspaces=[((0, 0, 0), (0, 0, 1))])
    c.update(lag=True, dt=0.01)  # pairs now, friction lagged here
    c.update()                   # pairs at the current positions
    alpha = c.step_bound([-dx for dx in scene.minimizeEnergy()])

Friction is IPC's lagged, smoothed friction (:mod:`.friction`); obstacles
are static members of the UNION (meshes) or half-spaces
(:mod:`.halfspace`). The step bound is exact where world positions are
linear in the targets (free, affine and caged vertices); for non-linear
parameterisations it follows the curved motion in straight pieces.
"""

from __future__ import annotations

from typing import Dict, List, Optional, Sequence, Tuple, Union

import ipctk
import numpy as np

from ..compiler.specs import KernelRequest
from ..deprecation import add_renamed_members
from ..frontend.attribute import Attribute
from ..frontend.errors import SceneError
from ..frontend.scene import Primitive, PrimitiveUnion, Scene
from ..runtime import current
from ..solve import assemble
from .friction import ARITIES, FrictionPairs, tangential_pairs
from .coefficients import FrictionCoefficients
from .relative import Length, Relative, diagonal, resolve
from .forces import FORCE_KINDS, ContactForces, member_sums
from .masses import MASS, average_vertex_mass
from .model import add_contact_energies
from .detection import (DETECTIONS, MIN_SEPARATION, NARROW_PHASE_CCD,
                        IpctkDetection, RuntimeDetection)
from .pairs import PAIR_TYPES
from .stiffness import AdaptiveStiffness
from .surface import edges_of, surface_of
from .sweep import Sweep
from ..frontend.errors import ArgumentError

__all__ = ["Contact", "MIN_SEPARATION", "PAIR_TYPES", "Relative", "edges_of",
           "surface_of"]

#: Straight pieces that follow a curved (non-linear) motion in step_bound.
CURVED_PIECES = 8


class Contact:
    """IPC contact among the surface ``faces`` (and ``edges``, by default
    those of the faces) of ``vertices``, a primitive or primitive union
    whose ``position`` attribute (3x1) gives world positions. Adds a mesh
    ``name`` to the scene with one dynamic pair primitive per pair type and
    its barrier energy ``kappa * b(d, dhat)`` (ipctk's BarrierPotential:
    dhat a distance, d squared distances). ``kappa`` is fixed if given;
    otherwise IPC's adaptive stiffness (:meth:`adapt_stiffness`), which reads
    the bodies' average mass per vertex: ``average_mass`` if given, else the
    mean of the ``mass`` their vertex primitives record (:mod:`.masses`). ``halfspaces``: planes
    (origin, normal) the vertices stay above. ``friction`` > 0 adds IPC's
    lagged friction with coefficient mu = friction and smoothing velocity
    ``eps_v`` (m/s; the displacement threshold is eps_v dt), lagged by
    ``update(lag=True, dt=...)`` once per time step.
    ``friction_pairs`` gives pairs of bodies their own coefficients:
    ``{(member_a, member_b): mu, (member, k): mu}``, members of the
    ``vertices`` UNION and ``k`` the index of a half-space (a member with
    itself for its self-contact); other pairs take ``friction``
    (:mod:`.coefficients`). ``detection``
    ("runtime" or "ipctk", :mod:`.detection`) finds the pairs and bounds
    steps: the runtime's by default, ipctk's for a cross-check. ``dhat``
    and ``eps_v`` may be ``Relative(fraction)``: that fraction of the
    diagonal of the vertices' bounding box now (``contact.size``), as IPC's
    scene files give them (:mod:`.relative`).

    ``points`` says which vertices on no face or edge take part, as IPC's
    codimensional points: all of them (True, the default: particles, and a
    tet mesh's inner vertices), none (False: only the faces' and edges'
    vertices, as ipctk's ``build_from_full_mesh``), or those where a
    boolean mask over the vertices is set. A tet mesh's inner vertices
    cannot touch another body while its surface holds, so dropping them
    costs no guarantee and saves their share of detection; it also keeps
    an inner vertex within dhat of its own surface from being pushed off
    it by the barrier."""

    def __init__(self, scene: Scene,
                 vertices: Union[Primitive, PrimitiveUnion],
                 faces: Optional[np.ndarray] = None,
                 edges: Optional[np.ndarray] = None, dhat: Length = 1e-3,
                 kappa: Optional[float] = None,
                 average_mass: Optional[float] = None,
                 position: str = "position", name: str = "contact",
                 projection: str = "clamp", halfspaces=(),
                 friction: float = 0.0, eps_v: Length = 1e-3,
                 detection: str = "runtime",
                 points: Union[bool, np.ndarray] = True,
                 friction_pairs=None):
        if position not in vertices:
            raise SceneError(f"Contact: {vertices.describe()} has no "
                             f"attribute {position!r} (its world positions)")
        self.positions: Attribute = vertices[position]
        if self.positions.shape != (3, 1):
            raise SceneError(f"Contact: world positions must be 3x1, got "
                             f"{self.positions.describe()}")
        #: the diagonal of the vertices' bounding box at construction, the
        #: size that Relative lengths are fractions of
        self.size = diagonal(self.positions.compute().value)
        dhat, eps_v = resolve(dhat, self.size), resolve(eps_v, self.size)
        if not dhat > 0:
            raise ArgumentError(f"Contact: dhat must be > 0, got {dhat}")
        if detection not in DETECTIONS:
            raise SceneError(f"Contact: detection must be one of "
                             f"{', '.join(DETECTIONS)}, got {detection!r}")
        if not friction >= 0 or not eps_v > 0:
            raise ArgumentError(f"Contact: friction must be >= 0 and eps_v > 0, "
                                f"got friction={friction}, eps_v={eps_v}")
        self.eps_v = float(eps_v)
        halfspaces = list(halfspaces)
        #: the friction coefficient of each pair of bodies
        self.coefficients = FrictionCoefficients(
            vertices, friction, friction_pairs, len(list(halfspaces)))
        #: the largest coefficient in play: > 0 when there is friction
        self.friction = self.coefficients.largest
        self.scene, self.vertices, self.dhat = scene, vertices, float(dhat)
        if kappa is None and average_mass is None:
            average_mass = average_vertex_mass(vertices)
            if average_mass is None:
                raise SceneError(
                    f"Contact: give a fixed barrier stiffness kappa, or the "
                    f"bodies' average vertex mass (average_mass) for IPC's "
                    f"adaptive one: no primitive of {vertices.describe()} "
                    f"records its vertices' masses (a 1x1 stored '{MASS}', "
                    f"as add_free_vertices and add_affine_body keep)")
        self.adaptive: Optional[AdaptiveStiffness] = None
        if kappa is None:
            assert average_mass is not None  # found above, or raised
            self.adaptive = AdaptiveStiffness(self.dhat, average_mass)
        count = vertices.numInstances
        faces = np.zeros((0, 3), dtype=np.int32) if faces is None else \
            np.ascontiguousarray(faces, dtype=np.int32).reshape(-1, 3)
        edges = edges_of(faces) if edges is None else \
            np.ascontiguousarray(edges, dtype=np.int32).reshape(-1, 2)
        for what, indices in (("faces", faces), ("edges", edges)):
            if indices.size and (indices.min() < 0 or indices.max() >= count):
                raise SceneError(f"Contact: {what} index vertices outside "
                                 f"0..{count - 1} of {vertices.describe()}")
        rest = self.world()
        #: the vertices that take part (None: all), ascending: ipctk's
        #: collision mesh and the detection number them 0, 1, ... in order
        self.included: Optional[np.ndarray] = _included(points, count,
                                                         edges, faces)
        if self.included is None:
            self.mesh = ipctk.CollisionMesh(rest, edges, faces)
        else:
            mask = np.zeros(count, dtype=bool)
            mask[self.included] = True
            self.mesh = ipctk.CollisionMesh(mask.tolist(), [False] * count,
                                            rest, edges, faces)
        #: ipctk's collision set, built where friction is lagged (its
        #: tangential set starts from it)
        self.collisions = ipctk.NormalCollisions()
        self.detection: Union[RuntimeDetection, IpctkDetection] = \
            DETECTIONS[detection](self.mesh, self.dhat)
        #: the broad phase of the last straight step bound, reused by the
        #: collision sets of positions inside its swept boxes
        self._sweep: Optional[Sweep] = None
        #: the positions of the last collision set and its smallest
        #: squared distance (the adaptive stiffness reads it)
        self._last_pairs: Optional[Tuple[np.ndarray, float]] = None
        self.model = add_contact_energies(
            scene.addMesh(name), vertices, self.positions, self.dhat,
            halfspaces, self.friction > 0, self.eps_v, projection)
        #: the half-spaces as given: (point, normal) per plane
        self.planes: Tuple[tuple, ...] = tuple(halfspaces)
        self.stiffness = self.model.stiffness
        if kappa is not None:
            self.stiffness.updateValue([float(kappa)])
        self.primitives: Dict[str, Primitive] = self.model.primitives
        self.halfspaces = self.model.halfspaces
        self.friction_primitives: Dict[int, Primitive] = \
            self.model.friction_primitives
        self.eps_u = self.model.eps_u
        #: the scene's energies per unit of physical energy: forces() divides
        #: by it. 1 by default; ImplicitEuler sets dt^2, since beside its
        #: inertia m/2 |x - x_hat|^2 every potential is scaled by dt^2.
        self.energy_scale = 1.0
        #: the world-space copy of the energies that forces() reads (built
        #: at its first call)
        self._forces: Optional[ContactForces] = None

    # ------------------------------------------------------------- geometry

    def world(self) -> np.ndarray:
        """The vertices' world positions now, (N, 3), from the scene's
        kernels."""
        return np.ascontiguousarray(self.positions.compute().value[:, :, 0])

    def colliding(self, V: np.ndarray) -> np.ndarray:
        """The rows of world positions V (N, 3) of the vertices that take
        part (``self.mesh``'s vertices, in its order)."""
        if self.included is None:
            return V
        return np.ascontiguousarray(V[self.included])

    def _full(self, vertices: np.ndarray) -> np.ndarray:
        """Collision-mesh vertex ids as the ``vertices``' own."""
        if self.included is None:
            return vertices
        return self.included[vertices]

    def update(self, lag: bool = False, dt: Optional[float] = None,
               step_start: Optional[np.ndarray] = None) -> Dict[str, int]:
        """Rebuilds the pairs from the collision set (``self.detection``'s;
        and the half-spaces) at the current positions; returns the number of
        pairs of each type. With ``lag`` also the friction pairs: ipctk's
        tangential set here (from ipctk's own collision set), with the normal forces at the current
        stiffness and the threshold eps_v * ``dt``. Tangential motion is
        measured from ``step_start`` (the world positions (N, 3) at the
        time step's start; default: now, the lag at a step's start). A lag
        later in the step, with the step's start given, is one of IPC's
        lagged friction iterations (:class:`yasps.sim.ImplicitEuler`'s
        ``friction_iterations``)."""
        V = self.world()
        if step_start is not None:
            step_start = np.asarray(step_start, dtype=float)
            if step_start.shape != V.shape:
                raise ArgumentError(f"Contact.update: step_start has shape "
                                    f"{step_start.shape}; the world positions "
                                    f"are {V.shape}")
        counts = self._normal_pairs(V)
        counts["plane"] = self.halfspaces.update(V)
        if lag and self.friction > 0:
            if dt is None or not dt > 0:
                raise ArgumentError("Contact.update(lag=True): give the time "
                                    "step dt (friction's threshold is eps_v dt)")
            if self.adaptive is not None and self.adaptive.kappa is None:
                self.adapt_stiffness()
            counts.update(self._lag_friction(
                V, float(dt), V if step_start is None else step_start))
        return counts

    def _lag_friction(self, V: np.ndarray, dt: float,
                      start: np.ndarray) -> Dict[str, int]:
        """The friction pairs at positions V (whose normal pairs are
        built), with tangential motion measured from ``start``."""
        assert self.eps_u is not None  # update() lags only with friction
        self.eps_u.updateValue([self.eps_v * dt])
        barrier = ipctk.BarrierPotential(self.dhat, self.kappa)
        Vc = self.colliding(V)
        self.collisions.build(self.mesh, Vc, self.dhat)
        tangential = ipctk.TangentialCollisions()
        tangential.build(self.mesh, Vc, self.collisions, barrier,
                         self.friction)
        pairs = {arity: FrictionPairs(arity) for arity in ARITIES}
        tangential_pairs(tangential, self.mesh, Vc, self.colliding(start),
                         pairs)
        for found in pairs.values():
            found.vertices = [self._full(np.asarray(ids)).tolist()
                              for ids in found.vertices]
        planes = self.halfspaces.friction_pairs(V, start, barrier,
                                                self.friction, pairs[1])
        self.coefficients.apply(pairs, planes)
        for arity, found in pairs.items():
            found.sort()
            found.store(self.friction_primitives[arity])
        return {f"friction{a}": len(f.vertices) for a, f in pairs.items()}

    def forget_candidates(self) -> None:
        """Drops the last step bound's broad phase and the last collision
        set's closest distance, which later collision sets reuse where they
        can: ImplicitEuler starts every time step without them, so that a
        step depends on the scene's state alone (a restored run continues
        bit for bit; reused candidates would list the same pairs in
        another order)."""
        self._sweep = None
        self._last_pairs = None

    def _normal_pairs(self, V: np.ndarray) -> Dict[str, int]:
        """The barrier pairs of the collision set at positions V (from the
        last step's candidates where they cover V)."""
        found, min_distance2 = self.detection.pairs(self.colliding(V),
                                                    self._sweep)
        self._last_pairs = (V, min_distance2)
        for kind, pairs in found.items():
            p = self.primitives[kind]
            p.updateNumInstances(len(pairs.vertices))
            p.connectivities["v"].updateConnectivity(
                self._full(pairs.vertices))
            p["eps_x"].updateValue(pairs.eps_x.reshape(-1, 1))
            p["weight"].updateValue(pairs.weight.reshape(-1, 1))
        return {kind: len(pairs.vertices) for kind, pairs in found.items()}

    def _min_distance2(self, V: np.ndarray) -> float:
        """The smallest squared distance among the pairs at V (inf if none
        are closer than dhat)."""
        if self._last_pairs is None or \
                not np.array_equal(self._last_pairs[0], V):
            self._normal_pairs(V)
        assert self._last_pairs is not None  # _normal_pairs sets it
        return self._last_pairs[1]

    def step_bound(self, steps: Sequence[np.ndarray],
                  pieces: int = CURVED_PIECES) -> float:
        """The bound of :meth:`step_bound_and_length`, alone."""
        return self.step_bound_and_length(steps, pieces)[0]

    def step_bound_and_length(self, steps: Sequence[np.ndarray],
                           pieces: int = CURVED_PIECES) -> Tuple[float, float]:
        """The step bound, and the largest distance a world position moves
        over the whole step (the size of a Newton direction in world
        space, what IPC's stopping rule measures).

        The bound is the largest fraction in [0, 1] of the step ``steps``
        (one array per minimisation target, as minimizeEnergy returns them,
        negated) along which no surface primitives cross, by ipctk's CCD (and the
        half-spaces' closed form) on the world positions' motion. Where the
        world positions move in a straight line (linear parameterisations:
        free, affine, caged), one CCD from now to the full step is exact.
        Where the midpoint of the step is off that line (angles, other
        non-linear parameterisations), the motion is followed through
        ``pieces`` straight pieces, each checked to keep twice its own
        deviation from the curve (at its midpoint) away from every surface,
        so that the curve itself stays clear: conservative where a piece's
        deviation is largest at its midpoint, as on arcs."""
        targets = self.scene.minimizeTargets
        if len(steps) != len(targets):
            raise ArgumentError(f"step_bound: {len(steps)} steps for "
                                f"{len(targets)} targets")
        before = [t.value for t in targets]
        steps = [np.asarray(p).reshape(x.shape) for x, p in zip(before, steps)]

        def world_at(fraction: float) -> np.ndarray:
            for t, x, p in zip(targets, before, steps):
                t.updateValue(x + fraction * p)
            return self.world()

        try:
            V0 = self.world()
            V1, middle = world_at(1.0), world_at(0.5)
            length = float(np.abs(V1 - V0).max())
            scale = max(length, 1e-300)
            straight = np.abs(middle - 0.5 * (V0 + V1)).max() <= 1e-9 * scale
            if straight:
                C0, C1 = self.colliding(V0), self.colliding(V1)
                self._sweep = Sweep(self.detection.candidates, C0, C1,
                                    self.dhat)
                return min(self.halfspaces.step_bound(V0, V1),
                           self.detection.swept_bound(self._sweep, C0,
                                                      C1)), length
            self._sweep = None
            previous = V0
            for k in range(pieces):
                following = world_at((k + 1) / pieces)
                bend = world_at((k + 0.5) / pieces) - 0.5 * (previous + following)
                margin = 2.0 * float(np.linalg.norm(bend, axis=1).max())
                bound = self._bound(previous, following, margin)
                if bound < 1.0:
                    return (k + bound) / pieces, length
                previous = following
            return 1.0, length
        finally:
            for t, x in zip(targets, before):
                t.updateValue(x)

    def _bound(self, V0: np.ndarray, V1: np.ndarray,
               margin: float = 0.0) -> float:
        """The fraction of the straight motion V0 -> V1 that keeps surfaces
        at least ``margin`` apart (and from the half-spaces)."""
        return min(self.halfspaces.step_bound(V0, V1, margin), float(
            ipctk.compute_collision_free_stepsize(
                self.mesh, self.colliding(V0), self.colliding(V1),
                min_distance=margin,
                narrow_phase_ccd=NARROW_PHASE_CCD)))

    @property
    def kappa(self) -> float:
        """The barrier stiffness now."""
        return float(self.stiffness.value.reshape(-1)[0])

    def _set_kappa(self, kappa: float) -> None:
        self.stiffness.updateValue([float(kappa)])

    def _diagonal(self, V: np.ndarray) -> float:
        return float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))

    def _gradient(self, kappa: float) -> np.ndarray:
        """The scene's assembled gradient with the stiffness set to kappa."""
        self._set_kappa(kappa)
        system = assemble(self.scene, current()).system
        out = np.empty(system.size)
        system.gradient(out)
        return out

    def adapt_stiffness(self) -> float:
        """IPC's adaptive stiffness (ipctk's heuristics): the initial kappa
        at the first call, from the other energies' gradient and the
        barrier's at the current pairs (call update() first); at later
        calls, a doubling when the closest distance keeps shrinking. A
        fixed kappa is returned unchanged. Changing kappa compiles
        nothing: it is a stored value."""
        if self.adaptive is None:
            return self.kappa
        V = self.world()
        diagonal = self._diagonal(V)
        if self.adaptive.kappa is None:
            kappa = self.adaptive.initial(diagonal, self._gradient)
        else:
            kappa = self.adaptive.update(self._min_distance2(V), diagonal)
        self._set_kappa(kappa)
        return kappa

    def forces(self, kind: str = "all", per: str = "vertex") -> np.ndarray:
        """The contact forces at the current positions (after a step: its
        solution), in world space whatever parameterises the vertices:
        minus the gradient of the contact's energies with respect to each
        vertex's world position, from the collision set there and the
        current stiffness, divided by ``energy_scale`` (under
        :class:`yasps.sim.ImplicitEuler`, dt^2: the forces are then in
        newtons for SI scenes). ``kind``: "normal" (the barrier's, pairs and
        half-spaces), "friction" (the lagged friction of the last lag) or
        "all" (their sum). ``per="vertex"`` gives one row per vertex of the
        union (N, 3); ``per="body"`` sums them over each member of the union
        (B, 3), in member order (one row for a single primitive).

        The first call compiles the energies once more on a scene whose
        target is the world positions (:mod:`.forces`); later calls
        evaluate only."""
        if per not in ("vertex", "body"):
            raise ArgumentError(f"Contact.forces: per must be 'vertex' or "
                                f"'body', got {per!r}")
        if kind not in FORCE_KINDS:
            raise ArgumentError(f"Contact.forces: kind must be one of "
                                f"{', '.join(FORCE_KINDS)}, got {kind!r}")
        V = self.world()
        if self._last_pairs is None or \
                not np.array_equal(self._last_pairs[0], V):
            self._normal_pairs(V)
        self.halfspaces.update(V)
        if self._forces is None:
            self._forces = ContactForces(self)
        found = self._forces.forces(kind) / self.energy_scale
        return found if per == "vertex" else \
            member_sums(self.vertices, found)

    def kernel_requests(self) -> List[KernelRequest]:
        """The compiler requests of this contact's own scenes, beyond the
        simulated scene's: the kernels of :meth:`forces`. The stepper
        compiles them with the scene's (``yasps.compile(scene,
        contact=...)``), so that reading forces compiles nothing."""
        if self._forces is None:
            self._forces = ContactForces(self)
        return self._forces.kernel_requests()

    def has_intersections(self) -> bool:
        """Whether some edge crosses some triangle (ipctk), or some vertex
        lies below a half-space, now."""
        V = self.world()
        return (self.halfspaces.intersecting(V)
                or bool(ipctk.has_intersections(self.mesh,
                                                self.colliding(V))))

    def touching(self, surfaces: bool = True) -> Optional[str]:
        """Where surfaces touch or cross now, where the barrier is
        infinite or cannot see them: a sentence naming the lowest vertex
        and its half-space, or the closest primitives' distance, and what
        to do; None where every pair is apart. With ``surfaces`` False only
        the half-spaces are looked at (a test of the vertices alone, cheap
        enough for every step)."""
        if not surfaces and not self.planes:
            return None
        V = self.world()
        if self.halfspaces.lowest_apart(V) and not surfaces:
            return None
        vertex, plane, height = self.halfspaces.lowest(V)
        if height <= 0.0:
            where = "on" if height == 0.0 else f"{-height:.3g} m below"
            return (f"vertex {vertex} lies {where} half-space {plane} "
                    f"(origin {self.planes[plane][0]}, normal "
                    f"{self.planes[plane][1]}), where the barrier is "
                    f"infinite: start the body above it (within dhat = "
                    f"{self.dhat:.3g} m of it the barrier pushes it off)")
        if not surfaces:
            return None
        if self.has_intersections():
            return ("an edge crosses a triangle of the contact surface: "
                    "start the bodies apart")
        distance = self.min_distance()
        if distance <= 0.0:
            return (f"surface primitives touch (distance {distance:.3g} m), "
                    f"where the barrier is infinite: start them apart "
                    f"(within dhat = {self.dhat:.3g} m the barrier pushes "
                    f"them apart)")
        return None

    def min_distance(self) -> float:
        """The smallest distance between surface primitives now, among
        those closer than dhat (inf if none are)."""
        V = self.world()
        C = self.colliding(V)
        collisions = ipctk.NormalCollisions()
        collisions.build(self.mesh, C, self.dhat)
        planes = self.halfspaces.min_distance(V)
        if collisions.empty():
            return planes if planes < self.dhat else float("inf")
        return min(planes, float(np.sqrt(
            collisions.compute_minimum_distance(self.mesh, C))))


# The camelCase spellings before the naming rule (docs/python.md, "Naming").
add_renamed_members(Contact, {
    "stepBound": "step_bound", "stepBoundAndLength": "step_bound_and_length",
    "adaptStiffness": "adapt_stiffness",
    "hasIntersections": "has_intersections", "minDistance": "min_distance",
    "forgetCandidates": "forget_candidates"})


def _included(points: Union[bool, np.ndarray], count: int,
              edges: np.ndarray, faces: np.ndarray) -> Optional[np.ndarray]:
    """The ascending ids of the vertices that take part, by Contact's
    ``points`` (None: all of them)."""
    if isinstance(points, (bool, np.bool_)) and points:
        return None
    on_surface = np.zeros(count, dtype=bool)
    on_surface[edges.reshape(-1)] = True
    on_surface[faces.reshape(-1)] = True
    if isinstance(points, (bool, np.bool_)):
        extra = np.zeros(count, dtype=bool)
    else:
        extra = np.asarray(points)
        if extra.dtype != bool or extra.shape != (count,):
            raise SceneError(f"Contact: points must be True, False or a "
                             f"boolean mask of {count} vertices, got "
                             f"{extra.dtype} of shape {extra.shape}")
    keep = on_surface | extra
    return None if keep.all() else np.flatnonzero(keep)
