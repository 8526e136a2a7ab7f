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
