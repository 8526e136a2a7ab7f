"""The pair primitives of IPC contact: one per closest-feature type, each
with the exact squared distance of that type and the barrier on it, the
edge-edge ones with IPC's mollifier against nearly parallel edges.

ipctk's collision set says which vertices are close and by which features;
:func:`collision_pairs` turns its collisions into arrays of each pair
type, in the vertex order its distance expects. The energies are yasps attributes on the
pairs, so their derivatives come from the compiler for any
parameterisation of the vertices.
"""

from __future__ import annotations

from dataclasses import dataclass
from operator import attrgetter
from typing import Callable, Dict, List, NamedTuple, Tuple

import ipctk
import numpy as np

from ..frontend import energies as E
from ..frontend.attribute import Attribute, select
from ..frontend.errors import ArgumentTypeError


def _points(gathered: Attribute, arity: int) -> List[Attribute]:
    return [gathered.row(k).T for k in range(arity)]


def edge_edge_mollifier(points: List[Attribute], eps: Attribute) -> Attribute:
    """IPC's mollifier of two edges (points 0-1 and 2-3): with x the squared
    norm of their cross product, (2 - x/eps) x/eps below eps, else 1."""
    x = (points[1] - points[0]).cross(points[3] - points[2]).squaredNorm()
    ratio = x / eps
    return select(x < eps, (2.0 - ratio) * ratio, 1.0)


@dataclass(frozen=True)
class PairType:
    """A kind of contact pair: its vertices and squared distance."""
    name: str
    arity: int
    #: whether the barrier is multiplied by the edge-edge mollifier (which
    #: needs the pair's threshold eps_x)
    mollified: bool
    #: the squared distance from the pair's points, in the order below
    distance2: Callable[[List[Attribute]], Attribute]
    #: what the vertices are, for the docs
    layout: str


PAIR_TYPES: Tuple[PairType, ...] = (
    PairType("vv", 2, False, lambda p: E.point_point_distance2(p[0], p[1]),
             "point, point"),
    PairType("ev", 3, False, lambda p: E.point_edge_distance2(p[0], p[1], p[2]),
             "point, edge (closest point inside the edge)"),
    PairType("fv", 4, False,
             lambda p: E.point_triangle_distance2(p[0], p[1], p[2], p[3]),
             "point, triangle (closest point inside it)"),
    PairType("ee", 4, True,
             lambda p: E.edge_edge_distance2(p[0], p[1], p[2], p[3]),
             "edge, edge (closest points inside both)"),
    PairType("ee_ev", 4, True,
             lambda p: E.point_edge_distance2(p[0], p[2], p[3]),
             "edge with the closest end point first, edge"),
    PairType("ee_vv", 4, True,
             lambda p: E.point_point_distance2(p[0], p[2]),
             "edge, edge, each with its closest end point first"),
)

BY_NAME: Dict[str, PairType] = {t.name: t for t in PAIR_TYPES}


def barrier_energy(pair: PairType, gathered: Attribute, eps: Attribute,
                   weight: Attribute, dhat: float,
                   kappa: Attribute) -> Attribute:
    """IPC's barrier -kappa (d - dhat^2)^2 log(d / dhat^2) on the squared
    distance d, times the pair's weight (ipctk's BarrierPotential: the
    multiplicity of a point-edge pair met through several candidates),
    mollified for edge pairs."""
    points = _points(gathered, pair.arity)
    energy = E.ipc_standard_barrier(pair.distance2(points), dhat * dhat,
                                    1.0) * (kappa * weight)
    if pair.mollified:
        energy = edge_edge_mollifier(points, eps) * energy
    return energy


_EE = ipctk.EdgeEdgeDistanceType

#: Edge-edge collisions by ipctk's known distance type: the pair type and
#: the order of (a0, a1, b0, b1) that type's distance expects (closest end
#: points first). The type is the one ipctk evaluates the collision with:
#: at the border of two types the distances agree but their Hessians do
#: not, so guessing it again from the positions would not give ipctk's
#: potential.
_EDGE_EDGE_ORDERS = {
    _EE.EA_EB: ("ee", (0, 1, 2, 3)),
    _EE.EA0_EB0: ("ee_vv", (0, 1, 2, 3)), _EE.EA0_EB1: ("ee_vv", (0, 1, 3, 2)),
    _EE.EA1_EB0: ("ee_vv", (1, 0, 2, 3)), _EE.EA1_EB1: ("ee_vv", (1, 0, 3, 2)),
    _EE.EA0_EB: ("ee_ev", (0, 1, 2, 3)), _EE.EA1_EB: ("ee_ev", (1, 0, 2, 3)),
    _EE.EA_EB0: ("ee_ev", (2, 3, 0, 1)), _EE.EA_EB1: ("ee_ev", (3, 2, 0, 1)),
}


class PairArrays(NamedTuple):
    """The pairs of one type: vertices (n, arity) in the type's order, the
    edge-edge mollifier thresholds eps_x (n,) (1 where unused) and ipctk's
    weights (n,)."""
    vertices: np.ndarray
    eps_x: np.ndarray
    weight: np.ndarray


def _fields(group, names: Tuple[str, ...]) -> np.ndarray:
    """The named fields of every collision of a group, (n, len(names))."""
    return np.array(list(map(attrgetter(*names), group)),
                    dtype=float).reshape(-1, len(names))


def collision_pairs(collisions: ipctk.NormalCollisions, edges: np.ndarray,
                    faces: np.ndarray) -> Dict[str, PairArrays]:
    """ipctk's collision set as arrays per pair type. ipctk's build knows
    each collision's distance type: a point-edge collision's distance is
    always to the edge's line, a face-vertex one's to the face's plane
    (their end-point cases became point-point or point-edge collisions),
    and an edge-edge collision carries its type (end-point types where the
    mollifier is active)."""
    out: Dict[str, List[PairArrays]] = {t.name: [] for t in PAIR_TYPES}
    vv = _fields(collisions.vv_collisions, ("vertex0_id", "vertex1_id",
                                            "weight"))
    out["vv"].append(PairArrays(vv[:, :2].astype(np.int64),
                                np.ones(len(vv)), vv[:, 2]))
    ev = _fields(collisions.ev_collisions, ("vertex_id", "edge_id", "weight"))
    edge = edges[ev[:, 1].astype(np.int64)]
    out["ev"].append(PairArrays(
        np.column_stack([ev[:, 0].astype(np.int64), edge]).reshape(-1, 3),
        np.ones(len(ev)), ev[:, 2]))
    fv = _fields(collisions.fv_collisions, ("vertex_id", "face_id", "weight"))
    face = faces[fv[:, 1].astype(np.int64)]
    out["fv"].append(PairArrays(
        np.column_stack([fv[:, 0].astype(np.int64), face]).reshape(-1, 4),
        np.ones(len(fv)), fv[:, 2]))
    group = collisions.ee_collisions
    ee = _fields(group, ("edge0_id", "edge1_id", "eps_x", "weight"))
    dtypes = np.fromiter(map(int, map(attrgetter("dtype"), group)),
                         dtype=np.int64, count=len(group))
    ends = np.column_stack([edges[ee[:, 0].astype(np.int64)],
                            edges[ee[:, 1].astype(np.int64)]]).reshape(-1, 4)
    for dtype, (kind, order) in _EDGE_EDGE_ORDERS.items():
        rows = dtypes == int(dtype)
        if rows.any():
            out[kind].append(PairArrays(ends[rows][:, list(order)],
                                        ee[rows, 2], ee[rows, 3]))
    if len(dtypes) and not np.isin(dtypes, [int(d) for d in
                                            _EDGE_EDGE_ORDERS]).all():
        raise ArgumentTypeError("ipctk gave an edge-edge collision of unknown "
                                "distance type")
    return {kind: _joined(parts, BY_NAME[kind].arity)
            for kind, parts in out.items()}


def _joined(parts: List[PairArrays], arity: int) -> PairArrays:
    if not parts:
        return PairArrays(np.zeros((0, arity), np.int64), np.zeros(0),
                          np.zeros(0))
    return PairArrays(np.concatenate([p.vertices for p in parts]),
                      np.concatenate([p.eps_x for p in parts]),
                      np.concatenate([p.weight for p in parts]))
