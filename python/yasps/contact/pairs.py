"""The pair primitives of IPC contact: one per closest-feature type, each
with the exact squared distance of that type and the barrier on it, the
edge-edge ones with IPC's mollifier against nearly parallel edges.

ipctk's collision set says which vertices are close and by which features;
:func:`classify` turns each of its collisions into a pair type and the
vertex order its distance expects. The energies are yasps attributes on the
pairs, so their derivatives come from the compiler for any
parameterisation of the vertices.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Dict, List, Tuple

import ipctk

from ..frontend import energies as E
from ..frontend.attribute import Attribute, select


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


_PT = ipctk.PointTriangleDistanceType
_PE = ipctk.PointEdgeDistanceType
_EE = ipctk.EdgeEdgeDistanceType


def classify(collision, ids: List[int]) -> Tuple[str, List[int]]:
    """The pair type of one ipctk collision and its vertices in that type's
    order; ``ids`` are the collision's vertex ids. The type is the one ipctk
    evaluates the collision with (``known_dtype``): a point-edge collision's
    distance is always to the line, a face-vertex one's to the plane, an
    edge-edge one's by the type found when the set was built. At the border
    of two types the distances agree but their Hessians do not, so guessing
    the type again from the positions would not give ipctk's potential."""
    if isinstance(collision, ipctk.VertexVertexNormalCollision):
        return "vv", ids[:2]
    dtype = collision.known_dtype()
    if isinstance(collision, ipctk.EdgeVertexNormalCollision):
        v, e0, e1 = ids[:3]
        ends = {_PE.P_E0: [v, e0], _PE.P_E1: [v, e1]}
        return ("vv", ends[dtype]) if dtype in ends else ("ev", [v, e0, e1])
    if isinstance(collision, ipctk.FaceVertexNormalCollision):
        v, t0, t1, t2 = ids
        corners = {_PT.P_T0: t0, _PT.P_T1: t1, _PT.P_T2: t2}
        edges = {_PT.P_E0: (t0, t1), _PT.P_E1: (t1, t2), _PT.P_E2: (t2, t0)}
        if dtype in corners:
            return "vv", [v, corners[dtype]]
        if dtype in edges:
            return "ev", [v, *edges[dtype]]
        return "fv", [v, t0, t1, t2]
    if isinstance(collision, ipctk.EdgeEdgeNormalCollision):
        a0, a1, b0, b1 = ids
        ends = {_EE.EA0_EB0: [a0, a1, b0, b1], _EE.EA0_EB1: [a0, a1, b1, b0],
                _EE.EA1_EB0: [a1, a0, b0, b1], _EE.EA1_EB1: [a1, a0, b1, b0]}
        point_edge = {_EE.EA0_EB: [a0, a1, b0, b1], _EE.EA1_EB: [a1, a0, b0, b1],
                      _EE.EA_EB0: [b0, b1, a0, a1], _EE.EA_EB1: [b1, b0, a0, a1]}
        if dtype in ends:
            return "ee_vv", ends[dtype]
        if dtype in point_edge:
            return "ee_ev", point_edge[dtype]
        return "ee", [a0, a1, b0, b1]
    raise TypeError(f"unsupported ipctk collision {type(collision).__name__}")
