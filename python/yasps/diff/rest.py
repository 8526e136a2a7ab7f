"""Gradients with respect to rest positions, chained through the rest-shape
constants the sim helpers precompute from them.

The helpers do not store rest positions: :func:`yasps.sim.add_elastic_tets`
stores each tet's inverse rest edge matrix ``inv`` = Dm^-1 and its volume
``vol`` = |det Dm| / 6, Dm = [r1 - r0, r2 - r0, r3 - r0]. The adjoint gives
the gradients of those constants (parameters ``t["inv"]``, ``t["vol"]``);
this module chains them back to the vertices.
"""

from __future__ import annotations

import numpy as np

from ..frontend.errors import ArgumentError


def tet_rest_gradient(rest, tets, d_inv, d_vol) -> np.ndarray:
    """dL/d rest (N, 3) from dL/d inv (M, 3, 3) and dL/d vol (M, 1, 1) (or
    (M,)) of the tets (M, 4) at rest positions ``rest`` (N, 3), as
    add_elastic_tets computes inv and vol from them:

        d inv = -B dDm B             (B = Dm^-1)
        d vol = vol tr(B dDm)        (vol = |det Dm| / 6)

    so dL/dDm = -B^T dL/dB B^T + dL/dvol vol B^T, whose columns go to
    vertices 1..3 and, negated and summed, to vertex 0."""
    rest = np.asarray(rest, dtype=float).reshape(-1, 3)
    tets = np.asarray(tets, dtype=np.int64).reshape(-1, 4)
    count = len(tets)
    d_inv = np.asarray(d_inv, dtype=float).reshape(count, 3, 3)
    d_vol = np.asarray(d_vol, dtype=float).reshape(count)
    if tets.min(initial=0) < 0 or tets.max(initial=-1) >= len(rest):
        raise ArgumentError("tet_rest_gradient: a tet names a vertex "
                            f"outside the {len(rest)} rest positions")
    corners = rest[tets]
    edges = np.stack([corners[:, k] - corners[:, 0] for k in (1, 2, 3)],
                     axis=2)
    inverse = np.linalg.inv(edges)
    volume = np.abs(np.linalg.det(edges)) / 6.0
    inverse_t = np.transpose(inverse, (0, 2, 1))
    d_edges = -inverse_t @ d_inv @ inverse_t + \
        (d_vol * volume)[:, None, None] * inverse_t
    out = np.zeros_like(rest)
    for k in (1, 2, 3):
        np.add.at(out, tets[:, k], d_edges[:, :, k - 1])
    np.add.at(out, tets[:, 0], -d_edges.sum(axis=2))
    return out


def cloth_rest_gradient(rest, faces, d_uv_inv, d_area,
                        d_length=None) -> np.ndarray:
    """dL/d rest (N, 3) of a cloth from dL/d ``uv_inv`` (M, 2, 2) and
    dL/d ``area`` (M, 1, 1) of its triangles ``faces`` (M, 3) and, with
    bending, dL/d ``length`` (H, 1, 1) of its hinges (in
    :func:`yasps.sim.hinges_of` order), as :func:`yasps.sim.add_cloth`
    computes them from the rest positions ``rest`` (N, 3).

    In each triangle's own frame the rest edge matrix is [[a, b], [0, c]]
    with a = |e1|, b = e1.e2 / a, c = |e1 x e2| / a, and the area is
    |e1 x e2| / 2 (e1, e2 the edges from corner 0); a hinge's length is
    that of its shared edge."""
    from ..sim.meshes import hinges_of

    rest = np.asarray(rest, dtype=float).reshape(-1, 3)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    count = len(faces)
    d_uv_inv = np.asarray(d_uv_inv, dtype=float).reshape(count, 2, 2)
    d_area = np.asarray(d_area, dtype=float).reshape(count)
    if faces.min(initial=0) < 0 or faces.max(initial=-1) >= len(rest):
        raise ArgumentError("cloth_rest_gradient: a triangle names a vertex "
                            f"outside the {len(rest)} rest positions")
    corners = rest[faces]
    e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    m = np.cross(e1, e2)
    norm_m = np.linalg.norm(m, axis=1)
    a = np.linalg.norm(e1, axis=1)
    b = (e1 * e2).sum(1) / a
    c = norm_m / a
    uv = np.zeros((count, 2, 2))
    uv[:, 0, 0], uv[:, 0, 1], uv[:, 1, 1] = a, b, c
    inverse_t = np.transpose(np.linalg.inv(uv), (0, 2, 1))
    d_uv = -inverse_t @ d_uv_inv @ inverse_t
    d_a, d_b, d_c = d_uv[:, 0, 0], d_uv[:, 0, 1], d_uv[:, 1, 1]
    unit_m = m / norm_m[:, None]
    dm_de1 = np.cross(e2, unit_m)            # d|m|/de1
    dm_de2 = np.cross(unit_m, e1)            # d|m|/de2
    a1, a3 = a[:, None], (a ** 3)[:, None]
    d_e1 = d_a[:, None] * e1 / a1 + \
        d_b[:, None] * (e2 / a1 - ((e1 * e2).sum(1))[:, None] * e1 / a3) + \
        d_c[:, None] * (dm_de1 / a1 - norm_m[:, None] * e1 / a3) + \
        0.5 * d_area[:, None] * dm_de1
    d_e2 = d_b[:, None] * e1 / a1 + d_c[:, None] * dm_de2 / a1 + \
        0.5 * d_area[:, None] * dm_de2
    out = np.zeros_like(rest)
    np.add.at(out, faces[:, 1], d_e1)
    np.add.at(out, faces[:, 2], d_e2)
    np.add.at(out, faces[:, 0], -(d_e1 + d_e2))
    if d_length is not None:
        hinges = hinges_of(faces)
        d_length = np.asarray(d_length, dtype=float).reshape(len(hinges))
        edge = rest[hinges[:, 1]] - rest[hinges[:, 0]]
        unit = edge / np.linalg.norm(edge, axis=1, keepdims=True)
        np.add.at(out, hinges[:, 1], d_length[:, None] * unit)
        np.add.at(out, hinges[:, 0], -d_length[:, None] * unit)
    return out
