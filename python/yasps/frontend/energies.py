"""Energies of IPC-style simulation, written with the symbolic attribute API.

Each function takes per-instance attributes (or numbers) and returns the
per-instance energy expression; register it with ``addAttribute(name,
computed_attribute=...)`` and ``addEnergy``. Derivatives come from the
compiler: nothing here is differentiated by hand.
"""

from __future__ import annotations

from typing import Union

from .attribute import Attribute, hstack, identity, select

Number = Union[Attribute, float]


def inertia(x: Attribute, x_hat: Attribute, mass: Number) -> Attribute:
    """Implicit Euler inertia ``m/2 |x - x_hat|^2`` of a vertex, with
    ``x_hat = x_n + dt v_n + dt^2 g`` the predicted position (gravity goes
    into ``x_hat``; or use :func:`gravity`)."""
    return 0.5 * mass * (x - x_hat).squaredNorm()


def gravity(x: Attribute, mass: Number, g) -> Attribute:
    """Potential energy ``-m g . x`` of a vertex in the field ``g`` (3x1)."""
    return -(mass * x.dot(g))


def mass_spring(ends: Attribute, rest_length: Number,
                stiffness: Number) -> Attribute:
    """``k/2 (|x1 - x0| - l0)^2`` for the 2x3 JOIN of an edge's end points."""
    stretch = (ends.row(1) - ends.row(0)).norm() - rest_length
    return 0.5 * stiffness * stretch * stretch


def edge_vectors(corners: Attribute) -> Attribute:
    """``[x1 - x0, x2 - x0, ...]`` as columns, for the k x 3 JOIN of an
    element's corners."""
    origin = corners.row(0)
    return hstack([(corners.row(i) - origin).T for i in range(1, corners.rows)])


def deformation_gradient(corners: Attribute, rest_inverse: Attribute) -> Attribute:
    """``F = Ds Dm^-1`` of a tet: ``corners`` is the 4x3 JOIN of its vertex
    positions, ``rest_inverse`` the inverse of its rest edge matrix (3x3)."""
    return edge_vectors(corners) * rest_inverse


def stable_neo_hookean(F: Attribute, mu: Number, lam: Number,
                       volume: Number) -> Attribute:
    """Stable Neo-Hookean energy density times rest volume (Smith et al.
    2018, the paper's eq. 10): ``V [mu/2 (I_C - 3) - mu/2 log(I_C + 1) +
    lam/2 (J - alpha)^2]`` with ``I_C = |F|^2``, ``J = det F`` and ``alpha =
    1 + 3 mu / (4 lam)``."""
    ic = F.squaredNorm()
    J = F.determinant()
    alpha = 1.0 + 0.75 * mu / lam
    psi = 0.5 * mu * (ic - 3.0) - 0.5 * mu * (ic + 1.0).log() \
        + 0.5 * lam * (J - alpha) * (J - alpha)
    return volume * psi


def neo_hookean(F: Attribute, mu: Number, lam: Number,
                volume: Number) -> Attribute:
    """IPC's Neo-Hookean energy density times rest volume (Li et al. 2020):
    ``V [mu/2 (I_C - 3) - mu log J + lam/2 (log J)^2]`` with ``I_C =
    |F|^2`` and ``J = det F``. Unlike stable Neo-Hookean it grows without
    bound as J -> 0 and is undefined (NaN) past it, so a line search that
    only accepts a lower energy never inverts a tet."""
    ic = F.squaredNorm()
    log_j = F.determinant().log()
    psi = 0.5 * mu * (ic - 3.0) - mu * log_j + 0.5 * lam * log_j * log_j
    return volume * psi


def inversion_barrier(F: Attribute, mu: Number, lam: Number,
                      volume: Number, start: float = 0.1) -> Attribute:
    """A barrier on a tet's volume ratio J = det F for materials defined
    past J = 0 (stable Neo-Hookean, fixed corotated), so that with a step
    bound they never invert, as IPC's Neo-Hookean does not: with
    ``s = J / start``, ``V (mu + lam) [-(s - 1)^2 log s]`` for ``s < 1``,
    else 0 (IPC's barrier on J instead of a distance; C2 at ``s = 1``).
    Zero wherever a tet keeps ``start`` of its rest volume, so it changes
    nothing there; as J -> 0 it grows without bound, and it is NaN past
    J = 0, which the line search rejects. Its scale, the material's
    ``mu + lam``, makes it a few times the material's own energy density
    by J = start / 10."""
    s = F.determinant() / start
    gap = s - 1.0
    return volume * select(s < 1.0, -((mu + lam) * gap * gap * s.log()),
                           0.0)


def fixed_corotated(F: Attribute, mu: Number, lam: Number,
                    volume: Number) -> Attribute:
    """Fixed corotated energy density times rest volume (Stomakhin et al.
    2012, as in IPC): ``V [mu |F - R|^2 + lam/2 (J - 1)^2]`` with ``R`` the
    rotation of F's polar decomposition, ``|F - R|^2 = |F|^2 - 2 tr(S) + 3``
    (:meth:`Attribute.singularValueSum`) and ``J = det F``. Defined for
    inverted elements too; its derivatives are singular only where two
    signed singular values sum to zero."""
    distance = F.squaredNorm() - 2.0 * F.singularValueSum() + 3.0
    J = F.determinant()
    return volume * (mu * distance + 0.5 * lam * (J - 1.0) * (J - 1.0))


def baraff_witkin(corners: Attribute, rest_uv_inverse: Attribute,
                  area: Number, stretch: Number, shear: Number) -> Attribute:
    """Baraff-Witkin cloth stretch and shear of a triangle: with ``W = Dx
    Duv^-1 = [w_u w_v]`` (3x2), ``area [k_s/2 ((|w_u| - 1)^2 + (|w_v| - 1)^2)
    + k_sh/2 (w_u . w_v)^2]``. ``corners`` is the 3x3 JOIN of its vertices,
    ``rest_uv_inverse`` the inverse of its 2x2 rest (u, v) edge matrix."""
    W = edge_vectors(corners) * rest_uv_inverse
    wu, wv = W.col(0), W.col(1)
    su, sv = wu.norm() - 1.0, wv.norm() - 1.0
    c = wu.dot(wv)
    return area * (0.5 * stretch * (su * su + sv * sv) + 0.5 * shear * c * c)


def dihedral_bending(hinge: Attribute, rest_length: Number,
                     stiffness: Number) -> Attribute:
    """Bending of a hinge (the paper's section 9.5): ``k l0 |n1 - n2|^2`` with
    n1, n2 the unit normals of the two triangles. ``hinge`` is the 4x3 JOIN
    (x0, x1 the shared edge, x2 and x3 the opposite vertices)."""
    x0, x1, x2, x3 = (hinge.row(i).T for i in range(4))
    n1 = (x1 - x0).cross(x2 - x0)
    n2 = (x3 - x0).cross(x1 - x0)
    d = n1 / n1.norm() - n2 / n2.norm()
    return stiffness * rest_length * d.squaredNorm()


def point_point_distance2(p: Attribute, q: Attribute) -> Attribute:
    """Squared distance of two points (rows or columns)."""
    return (q - p).squaredNorm()


def point_edge_distance2(p: Attribute, e0: Attribute, e1: Attribute) -> Attribute:
    """Squared distance of a point (3x1) to the line through e0, e1."""
    e = e1 - e0
    return e.cross(p - e0).squaredNorm() / e.squaredNorm()


def point_triangle_distance2(p: Attribute, t0: Attribute, t1: Attribute,
                             t2: Attribute) -> Attribute:
    """Squared distance of a point (3x1) to the plane of a triangle."""
    n = (t1 - t0).cross(t2 - t0)
    d = (p - t0).dot(n)
    return d * d / n.squaredNorm()


def edge_edge_distance2(a0: Attribute, a1: Attribute, b0: Attribute,
                        b1: Attribute) -> Attribute:
    """Squared distance of two non-parallel lines (3x1 points)."""
    n = (a1 - a0).cross(b1 - b0)
    d = (b0 - a0).dot(n)
    return d * d / n.squaredNorm()


def ipc_barrier(d: Attribute, dhat: Number, kappa: Number) -> Attribute:
    """The IPC log barrier on a squared distance ``d`` (the paper's eqs. 8,
    9): ``kappa (d - dhat)^2 log^2(d / dhat)`` for ``d < dhat``, else 0."""
    gap = d - dhat
    log = (d / dhat).log()
    return select(d < dhat, kappa * gap * gap * log * log, 0.0)


def ipc_standard_barrier(d: Attribute, dhat: Number,
                         kappa: Number = 1.0) -> Attribute:
    """The original IPC barrier ``-kappa (d - dhat)^2 log(d / dhat)`` for
    ``d < dhat``, else 0 (Li et al. 2020; ipctk's ``barrier``)."""
    gap = d - dhat
    return select(d < dhat, -(kappa * gap * gap * (d / dhat).log()), 0.0)


def abd_orthogonality(A: Attribute, stiffness: Number = 1.0) -> Attribute:
    """Affine-body orthogonality ``k/2 |A^T A - I|_F^2`` of a 3x3 matrix."""
    return 0.5 * stiffness * (A.T * A - identity(3)).squaredNorm()
