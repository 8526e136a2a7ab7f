"""Collision detection for :class:`yasps.contact.Contact`: the pairs closer
than dhat at some positions, and the largest safe fraction of a straight
step, both over one broad phase per Newton step (:mod:`.sweep`).

Two implementations with one interface:

- :class:`RuntimeDetection`, the default: the runtime's own C++ broad
  phase (a uniform grid of swept boxes), narrow phase and additive CCD,
  which hand the pairs over as arrays per pair type. It builds IPC's
  collision set by ipctk's rules, codimensional points and edges (on no
  face; a tet mesh's inner vertices among them) included, and tests compare
  its sets, distances and bounds with ipctk's.
- :class:`IpctkDetection`: ipctk's own (``Contact(detection="ipctk")``),
  the reference, whose collisions become pair arrays in Python.

Both fall back to ipctk's Tight Inclusion CCD (provably conservative) where
some pair is already closer than twice MIN_SEPARATION.
"""

from __future__ import annotations

from typing import Dict, Optional, Tuple, Type, Union

import ipctk
import numpy as np

from .. import config
from ..runtime.native import native
from .pairs import PAIR_TYPES, PairArrays, collision_pairs
from .sweep import Sweep

#: The narrow phase of ipctk's step bound: IPC's additive CCD (Li et al.
#: 2021), which stops a step where a pair's distance has shrunk to a tenth
#: of what it was (and never below ``min_distance``). The runtime's own
#: additive CCD is the same algorithm.
NARROW_PHASE_CCD = ipctk.AdditiveCCD()

#: The narrow phase where some pair is closer than twice MIN_SEPARATION:
#: Tight Inclusion, provably conservative (and slower).
CLOSE_RANGE_CCD = ipctk.TightInclusionCCD()

#: The closest two surfaces are let come (m): the CCD stops steps there
#: (or at half the distance of a pair that is closer already). Additive
#: CCD alone lets a pair close by 90% per Newton step, so distances could
#: shrink geometrically until rounding decides whether surfaces cross.
MIN_SEPARATION = 1e-9

#: Pairs found, by pair type name, and their smallest squared distance.
Found = Tuple[Dict[str, PairArrays], float]


def _contiguous(V: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(V, dtype=np.float64)


class RuntimeDetection:
    """The runtime's broad phase, narrow phase and additive CCD."""

    def __init__(self, mesh: ipctk.CollisionMesh, dhat: float):
        self.mesh, self.dhat = mesh, dhat
        self.native = native().ContactMesh(
            _contiguous(mesh.rest_positions),
            np.ascontiguousarray(mesh.edges, dtype=np.int32).reshape(-1, 2),
            np.ascontiguousarray(mesh.faces, dtype=np.int32).reshape(-1, 3))

    def candidates(self, V0: np.ndarray, V1: np.ndarray, inflation: float):
        """The pairs whose boxes, swept over V0 -> V1 and grown by
        ``inflation``, overlap."""
        return native().contact_candidates(self.native, _contiguous(V0),
                                           _contiguous(V1), inflation,
                                           threads=config.num_threads)

    def pairs(self, V: np.ndarray, sweep: Optional[Sweep]) -> Found:
        """The collision set at V as pair arrays (from the step's
        candidates where they cover V)."""
        V = _contiguous(V)
        candidates = sweep.candidates if sweep is not None and \
            sweep.holds(V) else self.candidates(V, V, 0.5 * self.dhat)
        kinds, min_distance2 = native().contact_collision_set(
            self.native, candidates, V, self.dhat,
            threads=config.num_threads)
        return ({t.name: PairArrays(*arrays)
                 for t, arrays in zip(PAIR_TYPES, kinds)},
                float(min_distance2))

    def swept_bound(self, sweep: Sweep, V0: np.ndarray,
                    V1: np.ndarray) -> float:
        """The fraction of V0 -> V1 keeping surfaces MIN_SEPARATION apart,
        or half the closest distance where some pair is closer than twice
        that already (then by Tight Inclusion)."""
        V0, V1 = _contiguous(V0), _contiguous(V1)
        # The additive CCD measures every pair's distance at V0 first: the
        # closest comes with the bound, which is dropped in the rare case
        # that it is too close for the additive CCD.
        bound, closest2 = native().contact_step_bound(
            self.native, sweep.candidates, V0, V1, MIN_SEPARATION,
            threads=config.num_threads)
        if closest2 < (2 * MIN_SEPARATION) ** 2:
            candidates = ipctk.Candidates()
            candidates.build(self.mesh, V0, V1,
                             inflation_radius=0.5 * self.dhat)
            return _close_range_bound(self.mesh, candidates, V0, V1,
                                      0.5 * float(np.sqrt(closest2)))
        return float(bound)


class IpctkDetection:
    """ipctk's broad phase, collision set and CCD."""

    def __init__(self, mesh: ipctk.CollisionMesh, dhat: float):
        self.mesh, self.dhat = mesh, dhat
        self.collisions = ipctk.NormalCollisions()

    def candidates(self, V0: np.ndarray, V1: np.ndarray,
                   inflation: float) -> ipctk.Candidates:
        candidates = ipctk.Candidates()
        candidates.build(self.mesh, V0, V1, inflation_radius=inflation)
        return candidates

    def pairs(self, V: np.ndarray, sweep: Optional[Sweep]) -> Found:
        if sweep is not None and sweep.holds(V):
            self.collisions.build(sweep.candidates, self.mesh, V, self.dhat)
        else:
            self.collisions.build(self.mesh, V, self.dhat)
        min_distance2 = float("inf") if self.collisions.empty() else \
            float(self.collisions.compute_minimum_distance(self.mesh, V))
        return (collision_pairs(self.collisions, self.mesh.edges,
                                self.mesh.faces), min_distance2)

    def swept_bound(self, sweep: Sweep, V0: np.ndarray,
                    V1: np.ndarray) -> float:
        close = ipctk.NormalCollisions()
        close.build(sweep.candidates, self.mesh, V0, 2 * MIN_SEPARATION)
        if not close.empty():
            return _close_range_bound(
                self.mesh, sweep.candidates, V0, V1, 0.5 * float(np.sqrt(
                    close.compute_minimum_distance(self.mesh, V0))))
        return float(sweep.candidates.compute_collision_free_stepsize(
            self.mesh, V0, V1, min_distance=MIN_SEPARATION,
            narrow_phase_ccd=NARROW_PHASE_CCD))


def _close_range_bound(mesh: ipctk.CollisionMesh,
                       candidates: ipctk.Candidates, V0: np.ndarray,
                       V1: np.ndarray, separation: float) -> float:
    """Tight Inclusion's bound keeping ``separation`` over ipctk's
    candidates of the motion V0 -> V1."""
    return float(candidates.compute_collision_free_stepsize(
        mesh, V0, V1, min_distance=separation,
        narrow_phase_ccd=CLOSE_RANGE_CCD))


#: Contact's ``detection`` choices.
DETECTIONS: Dict[str, Union[Type[RuntimeDetection], Type[IpctkDetection]]] = {
    "runtime": RuntimeDetection, "ipctk": IpctkDetection}
