"""A soft body and an affine body in one vertex UNION, with dynamic
point-point, point-edge, point-triangle and edge-edge pairs carrying the IPC
barrier: the mixed-parameterisation contact scene of the compile benchmark.

The soft box has stable Neo-Hookean tets and inertia on its vertex
positions; the affine box's vertices are A rest + t of one body, with
inertia on A and t and the ABD orthogonality energy. The pairs here are
index tuples into the union drawn at random (the benchmark measures
compilation and per-call costs, not a collision response).
"""

from __future__ import annotations

from typing import Dict, Tuple

import numpy as np

import yasps
from yasps import energies as E
from yasps.sim import add_elastic_tets, box_tet_mesh

#: Arity and squared-distance function of each pair type.
PAIR_TYPES = {
    "pp": (2, E.point_point_distance2),
    "pe": (3, E.point_edge_distance2),
    "pt": (4, E.point_triangle_distance2),
    "ee": (4, E.edge_edge_distance2),
}


def _squared_distance(points: np.ndarray, arity: int) -> np.ndarray:
    """The squared distances the barriers see (point-point, point-line,
    point-plane, line-line), in NumPy, for tuples of points (k, arity, 3)."""
    p = points
    if arity == 2:
        return ((p[:, 1] - p[:, 0]) ** 2).sum(1)
    if arity == 3:
        e = p[:, 2] - p[:, 1]
        c = np.cross(e, p[:, 0] - p[:, 1])
        return (c ** 2).sum(1) / np.maximum((e ** 2).sum(1), 1e-300)
    plane = np.cross(p[:, 2] - p[:, 1], p[:, 3] - p[:, 1])
    lines = np.cross(p[:, 1] - p[:, 0], p[:, 3] - p[:, 2])
    pt = ((p[:, 0] - p[:, 1]) * plane).sum(1) ** 2 / np.maximum(
        (plane ** 2).sum(1), 1e-300)
    ee = ((p[:, 2] - p[:, 0]) * lines).sum(1) ** 2 / np.maximum(
        (lines ** 2).sum(1), 1e-300)
    return np.minimum(pt, ee)


def random_pairs(count: int, positions: np.ndarray, arity: int,
                 rng: np.random.Generator) -> np.ndarray:
    """``count`` tuples of ``arity`` distinct union vertices
    (``positions``: the union's vertices in order) whose squared distance
    lies in the barrier's active range (0.01, 1): no coplanar or collinear
    tuples, whose barrier is infinite."""
    out = np.zeros((0, arity), dtype=np.int64)
    while len(out) < count:
        keys = rng.random((2 * count + 16, len(positions)))
        tuples = np.argsort(keys, axis=1)[:, :arity]
        d2 = _squared_distance(positions[tuples], arity)
        out = np.concatenate([out, tuples[(d2 > 0.01) & (d2 < 1.0)]])
    return out[:count].astype(np.int64)


def build(pairs: int = 4, cells: int = 1, seed: int = 0,
          pair_types: Tuple[str, ...] = tuple(PAIR_TYPES)
          ) -> Tuple[yasps.Scene, Dict[str, yasps.Primitive],
                     Dict[str, yasps.Connectivity], np.ndarray]:
    """The scene with ``pairs`` pairs of each of ``pair_types``; returns it,
    the pair
    primitives and their connectivities by type, and the union's vertex
    positions at rest (for drawing more pairs)."""
    rng = np.random.default_rng(seed)
    verts, tets = box_tet_mesh(cells, 0.5)
    nv = len(verts)
    s = yasps.scene("contact")

    soft = s.addMesh("soft")
    sv = soft.addPrimitive("v", numInstances=nv)
    x = sv.addAttribute("x", rows=3)
    x.updateValue(verts + rng.normal(scale=1e-3, size=verts.shape))
    sv.addConstant("x_hat", rows=3).updateValue(verts)
    add_elastic_tets(soft, x, verts, tets, 1e4, 4e4, scale=1e-4)
    s.addEnergy(sv.addAttribute("inertia", computed_attribute=E.inertia(
        x, sv["x_hat"], 1e-2)))

    rigid = s.addMesh("rigid")
    body = rigid.addPrimitive("body", numInstances=1)
    A = body.addAttribute("A", rows=3, cols=3)
    A.updateValue(np.eye(3) + rng.normal(scale=1e-3, size=(3, 3)))
    t = body.addAttribute("t", rows=3)
    t.updateValue([0.0, 0.0, 0.6])
    body.addConstant("A_hat", rows=3, cols=3).updateValue(np.eye(3))
    body.addConstant("t_hat", rows=3).updateValue([0.0, 0.0, 0.6])
    s.addEnergy(body.addAttribute("inertia", computed_attribute=E.inertia(
        A, body["A_hat"], 1.0) + E.inertia(t, body["t_hat"], 1.0)))
    s.addEnergy(body.addAttribute("orth", computed_attribute=
                                  E.abd_orthogonality(A, 10.0)))
    rv = rigid.addPrimitive("v", numInstances=nv)
    rv.addConstant("rest", rows=3).updateValue(verts)
    v2b = rv.addConnectivity("v2b", body, [0] * nv, 1)
    rv.addAttribute("x", computed_attribute=rv.addAttribute(
        "A", through=v2b, source=A).resize(3, 3) * rv["rest"] + rv.addAttribute(
        "t", through=v2b, source=t).resize(3, 1))

    world = s.addMesh("world")
    union = world.addPrimitiveUnion("v", [sv, rv])
    union.addAttribute("x")
    primitives, connectivities = {}, {}
    positions = np.concatenate([x.value[:, :, 0], verts + [0.0, 0.0, 0.6]])
    for name in pair_types:
        arity, distance2 = PAIR_TYPES[name]
        p = world.addPrimitive(name, numInstances=pairs, isDynamic=True)
        c = p.addConnectivity("c", union, random_pairs(pairs, positions, arity,
                                                       rng), arity)
        gathered = p.addAttribute("x", through=c, source=union["x"])
        d2 = distance2(*[gathered.row(k).T for k in range(arity)])
        s.addEnergy(p.addAttribute("barrier", computed_attribute=E.ipc_barrier(
            d2, 1.0, 1.0)), dynamic_instances=True)
        primitives[name], connectivities[name] = p, c
    s.addMinimizeTarget([x, A, t])
    return s, primitives, connectivities, positions
