"""Bodies for simulations: a soft tet mesh with stable Neo-Hookean
elasticity on its vertices' positions, and an affine body's inertia.

Material parameters and time-step scales are stored values of the body's
mesh (1x1 constants), not numbers in the IR: a scene built again with other
values (a parameter sweep) reuses the compiled kernels, and
``mesh["<name>_mu"].updateValue(...)`` changes one in place."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence, Tuple, Union, cast

import numpy as np

from ..frontend import energies as E
from ..frontend.energies import Number
from ..frontend.attribute import Attribute
from ..frontend.errors import ArgumentError, SceneError
from ..frontend.scene import Mesh, Primitive, PrimitiveUnion
from . import inversion
from .meshes import HEX_CORNERS, hinges_of


def _vertices_of(positions: Attribute) -> Union[Primitive, PrimitiveUnion]:
    """The owner of ``positions``, as the target of a connectivity to the
    vertices: addConnectivity raises SceneError if it is not a primitive."""
    return cast(Union[Primitive, PrimitiveUnion], positions.owner)


def material_constant(mesh: Mesh, name: str, value: Number) -> Attribute:
    """``value`` as a 1x1 constant ``name`` of ``mesh``, visible to all its
    primitives; an attribute is returned as it is (a value shared by
    several bodies, or one per instance)."""
    if isinstance(value, Attribute):
        return value
    constant = mesh.addConstant(name, rows=1)
    constant.updateValue([float(value)])
    return constant


def position_owner(positions: Attribute, where: str, adds: Sequence[str]):
    """The primitive of the 3x1 world positions ``positions``, to which
    ``where`` (a helper's name, for the message) adds attributes named
    ``adds``; raises SceneError if it is not one or has one of them."""
    if positions.shape != (3, 1):
        raise SceneError(f"{where}: world positions must be 3x1, got "
                         f"{positions.describe()}")
    owner = positions.owner
    if owner is None or not hasattr(owner, "numInstances"):
        raise SceneError(f"{where}: {positions.describe()} is not an "
                         f"attribute of a primitive")
    for name in adds:
        if name in owner:
            raise SceneError(f"{where}: {owner.describe()} already has an "
                             f"attribute {name!r}")
    return owner


#: add_elastic_tets' materials: energy densities of (F, mu, lam, volume).
MATERIALS = {"stable_neo_hookean": E.stable_neo_hookean,
             "neo_hookean": E.neo_hookean,
             "fixed_corotated": E.fixed_corotated}

#: The materials whose energy is undefined past J = 0: add_elastic_tets
#: guards their tets against inverting (:mod:`yasps.sim.inversion`).
INVERSION_BARRIERS = frozenset({"neo_hookean"})


def lame(young: float, poisson: float) -> Tuple[float, float]:
    """Lame's (mu, lambda) from Young's modulus and Poisson's ratio (3-D)."""
    if not young > 0 or not -1.0 < poisson < 0.5:
        raise ArgumentError(f"lame: need Young's modulus > 0 and -1 < Poisson's "
                            f"ratio < 0.5, got {young} and {poisson}")
    mu = young / (2.0 * (1.0 + poisson))
    return mu, young * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson))


def add_elastic_tets(mesh: Mesh, positions: Attribute, rest: np.ndarray,
                     tets: np.ndarray, mu: Number, lam: Number,
                     scale: Number = 1.0, name: str = "t",
                     projection: str = "clamp",
                     material: str = "stable_neo_hookean",
                     guard_inversion: Optional[bool] = None) -> Attribute:
    """Adds a primitive ``name`` of the tets (M, 4) of the vertices that
    ``positions`` belongs to, with their rest shape (the inverse of the rest
    edge matrix and the volume, from ``rest`` (N, 3)) and registers
    ``scale`` times the ``material`` (one of MATERIALS: stable Neo-Hookean,
    IPC's Neo-Hookean, whose energy never lets a tet invert, or fixed
    corotated; ``mu``, ``lam`` per unit volume, :func:`lame` from E and nu) on them as an
    energy (``scale``: dt^2 for implicit Euler), PSD-projected
    by ``projection`` (as ``addEnergy``). ``mu``, ``lam`` and ``scale``
    are the mesh's constants ``name + "_mu"``, ``"_lam"``, ``"_scale"``
    (:func:`material_constant`). ``guard_inversion`` (by default where
    the material is undefined past J = 0, IPC's Neo-Hookean): steppers
    whose targets include ``positions`` then bound each step so that no
    tet falls below a tenth of its volume (:func:`inversion_bound`), as
    IPC does; a material defined past J = 0 then also gets
    :func:`yasps.energies.inversion_barrier` (zero above a tenth of the
    rest volume), so that it never inverts either. Returns the energy."""
    if material not in MATERIALS:
        raise SceneError(f"add_elastic_tets: material must be one of "
                         f"{', '.join(MATERIALS)}, got {material!r}")
    if material == "stable_neo_hookean" and not isinstance(lam, Attribute) \
            and not float(lam) > 0:
        raise ArgumentError(
            f"add_elastic_tets: stable Neo-Hookean needs lam > 0 (Poisson's "
            f"ratio > 0), got lam = {lam}: its rest offset alpha = 1 + 3 mu / "
            f"(4 lam) is infinite at lam = 0 and the energy NaN. Give a "
            f"Poisson's ratio above 0 (lame(E, nu)), or "
            f"material='fixed_corotated' or 'neo_hookean', which take lam = 0")
    tets = np.asarray(tets, dtype=np.int64).reshape(-1, 4)
    corners = np.asarray(rest, dtype=float)[tets]
    edges = np.stack([corners[:, k] - corners[:, 0] for k in (1, 2, 3)], axis=2)
    t = mesh.addPrimitive(name, numInstances=len(tets))
    t.addConstant("inv", rows=3, cols=3).updateValue(np.linalg.inv(edges))
    t.addConstant("vol", rows=1).updateValue(
        np.abs(np.linalg.det(edges))[:, None] / 6)
    gathered = t.addAttribute("c", through=t.addConnectivity(
        "t2v", _vertices_of(positions), tets, 4), source=positions)
    mu, lam, scale = (material_constant(mesh, f"{name}_{what}", value)
                      for what, value in (("mu", mu), ("lam", lam),
                                          ("scale", scale)))
    F = E.deformation_gradient(gathered, t["inv"])
    density = MATERIALS[material](F, mu, lam, t["vol"])
    guarded = guard_inversion if guard_inversion is not None \
        else material in INVERSION_BARRIERS
    if guarded and material not in INVERSION_BARRIERS:
        # A step bound alone freezes a run whose directions keep pressing a
        # tet that such a material lets collapse: every step then stops at
        # the bound. The barrier makes collapse cost what it costs in IPC's.
        density = density + E.inversion_barrier(F, mu, lam, t["vol"])
    energy = t.addAttribute("elastic", computed_attribute=scale * density)
    mesh.scene.addEnergy(energy, projection=projection)
    if guarded:
        inversion.guard_inversion(positions, tets)
    inversion.watch_inversion(positions, tets, t.describe(), material)
    return energy


def add_affine_inertia(body, A: Attribute, t: Attribute, A_hat: Attribute,
                       t_hat: Attribute, rest: np.ndarray,
                       masses: np.ndarray, name: str = "inertia") -> Attribute:
    """Registers the implicit-Euler inertia of an affine body (one instance
    of ``body``, world positions A r + t of vertices at rest ``rest`` (N, 3)
    with ``masses`` (N,)): the vertices' ``sum m_i/2 |dA r_i + dt|^2`` with
    dA = A - A_hat, dt = t - t_hat, written with the body's mass moments
    (sum m r r^T, sum m r, sum m) so that it costs one instance, not N.
    Returns the energy."""
    rest = np.asarray(rest, dtype=float).reshape(-1, 3)
    masses = np.asarray(masses, dtype=float).reshape(-1)
    if masses.shape != (len(rest),):
        raise ArgumentError(f"add_affine_inertia: {len(masses)} masses for "
                            f"{len(rest)} vertices")
    second = body.addConstant(name + "_second_moment", rows=3, cols=3)
    second.updateValue(np.einsum("i,ij,ik->jk", masses, rest, rest))
    first = body.addConstant(name + "_first_moment", rows=3)
    first.updateValue(masses @ rest)
    total = float(masses.sum())
    dA, dt = A - A_hat, t - t_hat
    energy = body.addAttribute(name, computed_attribute=
                               0.5 * (dA * second * dA.T).trace()
                               + (dA * first).dot(dt)
                               + 0.5 * total * dt.squaredNorm())
    # A convex quadratic: its Hessian, the body's mass matrix, is PSD as it
    # stands, and projecting it compiled a 12x12 eigensolver for nothing
    # (1.4 s of a cold compile).
    body.scene.addEnergy(energy, projection="none")
    return energy


def _triangle_rest_frames(rest: np.ndarray, faces: np.ndarray):
    """Per triangle: the inverse of its rest (u, v) edge matrix in a frame
    of its own plane (2x2) and its area."""
    corners = rest[faces]
    e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    normal = np.cross(e1, e2)
    areas = 0.5 * np.linalg.norm(normal, axis=1)
    if (areas <= 0).any():
        raise ArgumentError(f"add_cloth: {int((areas <= 0).sum())} triangles "
                            f"have no area at rest")
    u = e1 / np.linalg.norm(e1, axis=1, keepdims=True)
    v = np.cross(normal / (2 * areas[:, None]), u)
    uv = np.stack([np.stack([(e * u).sum(1), (e * v).sum(1)], axis=1)
                   for e in (e1, e2)], axis=2)
    return np.linalg.inv(uv), areas


def add_cloth(mesh: Mesh, positions: Attribute, rest: np.ndarray,
              faces: np.ndarray, stretch: Number, shear: Number,
              bending: Number, scale: Number = 1.0,
              name: str = "cloth", projection: str = "clamp") -> Attribute:
    """Registers a cloth on the triangles ``faces`` (M, 3) of the vertices
    ``positions`` belongs to, at rest ``rest`` (N, 3): Baraff-Witkin
    stretch and shear per triangle (``stretch``, ``shear`` per unit area,
    the rest (u, v) frame in each triangle's plane) and, if ``bending`` >
    0, dihedral bending on every interior edge (its rest length times
    ``bending``; zero when flat), all times ``scale`` (dt^2 for implicit
    Euler), PSD-projected by ``projection`` (as ``addEnergy``). Primitives
    ``name`` and ``name + "_hinges"``; the four parameters are the mesh's
    constants ``name + "_stretch"``, ``"_shear"``, ``"_bending"``,
    ``"_scale"`` (:func:`material_constant`). Returns the stretch
    energy."""
    rest = np.asarray(rest, dtype=float).reshape(-1, 3)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    bends = isinstance(bending, Attribute) or bending > 0
    stretch, shear, bending, scale = (
        material_constant(mesh, f"{name}_{what}", value) for what, value in
        (("stretch", stretch), ("shear", shear), ("bending", bending),
         ("scale", scale)))
    inverse, areas = _triangle_rest_frames(rest, faces)
    tri = mesh.addPrimitive(name, numInstances=len(faces))
    tri.addConstant("uv_inv", rows=2, cols=2).updateValue(inverse)
    tri.addConstant("area", rows=1).updateValue(areas[:, None])
    corners = tri.addAttribute("c", through=tri.addConnectivity(
        "f2v", _vertices_of(positions), faces, 3), source=positions)
    energy = tri.addAttribute("stretch", computed_attribute=scale *
                              E.baraff_witkin(corners, tri["uv_inv"],
                                              tri["area"], stretch, shear))
    mesh.scene.addEnergy(energy, projection=projection)
    hinges = hinges_of(faces)
    if bends and len(hinges):
        h = mesh.addPrimitive(name + "_hinges", numInstances=len(hinges))
        h.addConstant("length", rows=1).updateValue(np.linalg.norm(
            rest[hinges[:, 1]] - rest[hinges[:, 0]], axis=1)[:, None])
        joined = h.addAttribute("h", through=h.addConnectivity(
            "h2v", _vertices_of(positions), hinges, 4), source=positions)
        mesh.scene.addEnergy(h.addAttribute(
            "bending", computed_attribute=scale * E.dihedral_bending(
                joined, h["length"], bending)), projection=projection)
    return energy


@dataclass
class AffineBody:
    """An affine body's handles: the targets ``A`` (3x3) and ``t`` (3x1),
    their predictions ``A_hat``, ``t_hat`` (for implicit Euler), and the
    primitive ``vertices`` whose ``position`` is ``A rest + t``."""
    A: Attribute
    t: Attribute
    A_hat: Attribute
    t_hat: Attribute
    vertices: Primitive


def add_affine_body(mesh: Mesh, rest: np.ndarray, masses: np.ndarray,
                    stiffness: Number, scale: Number = 1.0,
                    translation=(0.0, 0.0, 0.0)) -> AffineBody:
    """An affine body (ABD) on ``mesh``: one instance ``body`` with A = I and
    t = ``translation``, vertices ``v`` at ``A rest + t`` (``rest`` (N, 3),
    relative to the body's origin), the inertia of their ``masses`` on A
    and t (:func:`add_affine_inertia`) and ``scale`` times the
    orthogonality energy with ``stiffness`` (dt^2 times a stiffness like
    the material's Young's modulus times the volume, as ABD does);
    ``stiffness`` and ``scale`` are the mesh's constants
    ``"orthogonality_stiffness"`` and ``"orthogonality_scale"``
    (:func:`material_constant`)."""
    rest = np.asarray(rest, dtype=float).reshape(-1, 3)
    stiffness = material_constant(mesh, "orthogonality_stiffness", stiffness)
    scale = material_constant(mesh, "orthogonality_scale", scale)
    body = mesh.addPrimitive("body", numInstances=1)
    A = body.addAttribute("A", rows=3, cols=3)
    A.updateValue(np.eye(3)[None])
    t = body.addAttribute("t", rows=3)
    t.updateValue(np.asarray(translation, float).reshape(1, 3))
    A_hat = body.addConstant("A_hat", rows=3, cols=3)
    A_hat.updateValue(A.value)
    t_hat = body.addConstant("t_hat", rows=3)
    t_hat.updateValue(t.value)
    v = mesh.addPrimitive("v", numInstances=len(rest))
    v.addConstant("rest", rows=3).updateValue(rest)
    # Read by a contact's adaptive stiffness (yasps.contact.masses).
    v.addConstant("mass", rows=1).updateValue(
        np.broadcast_to(np.asarray(masses, float).reshape(-1, 1),
                        (len(rest), 1)).copy())
    link = v.addConnectivity("v2b", body, np.zeros((len(rest), 1), np.int64),
                             1)
    v.addAttribute("position", computed_attribute=v.addAttribute(
        "A", through=link, source=A).resize(3, 3) * v["rest"]
        + v.addAttribute("t", through=link, source=t).resize(3, 1))
    add_affine_inertia(body, A, t, A_hat, t_hat, rest, masses)
    mesh.scene.addEnergy(body.addAttribute(
        "orthogonality", computed_attribute=scale * E.abd_orthogonality(
            A, stiffness)))
    return AffineBody(A, t, A_hat, t_hat, v)


def lumped_masses(verts: np.ndarray, cells: np.ndarray,
                  density: float) -> np.ndarray:
    """Vertex masses (N,) lumped from tets (M, 4; density per volume) or
    triangles (M, 3; density per area): each cell's mass split evenly among
    its corners."""
    verts = np.asarray(verts, dtype=float)
    cells = np.asarray(cells, dtype=np.int64)
    c = verts[cells]
    if cells.shape[1] == 4:
        sizes = np.abs(np.linalg.det(np.stack([c[:, k] - c[:, 0]
                                               for k in (1, 2, 3)], 2))) / 6
    elif cells.shape[1] == 3:
        sizes = 0.5 * np.linalg.norm(np.cross(c[:, 1] - c[:, 0],
                                              c[:, 2] - c[:, 0]), axis=1)
    else:
        raise ArgumentError(f"lumped_masses: cells of {cells.shape[1]} vertices; "
                            f"give tets (4) or triangles (3)")
    k = cells.shape[1]
    masses = np.zeros(len(verts))
    np.add.at(masses, cells.reshape(-1), np.repeat(sizes / k, k))
    return density * masses


@dataclass
class FreeVertices:
    """Free vertices with inertia: the primitive, the target ``x`` and its
    prediction ``x_hat``."""
    primitive: Primitive
    x: Attribute
    x_hat: Attribute


def add_free_vertices(mesh: Mesh, start: np.ndarray, masses,
                      name: str = "v",
                      projection: str = "none") -> FreeVertices:
    """A primitive ``name`` of vertices at ``start`` (N, 3) whose positions
    ``position`` are a minimisation target's candidates, with the
    implicit-Euler inertia ``m/2 |x - x_hat|^2`` of their ``masses`` (one
    per vertex, or one for all) registered (PSD-projected by
    ``projection``, as ``addEnergy``; by default none: the Hessian m I of
    this convex energy is PSD as it stands)."""
    start = np.asarray(start, dtype=float).reshape(-1, 3)
    v = mesh.addPrimitive(name, numInstances=len(start))
    x = v.addAttribute("position", rows=3)
    x.updateValue(start)
    x_hat = v.addConstant("x_hat", rows=3)
    x_hat.updateValue(start)
    mass = v.addConstant("mass", rows=1)
    mass.updateValue(np.broadcast_to(np.asarray(masses, float).reshape(-1, 1),
                                     (len(start), 1)).copy())
    mesh.scene.addEnergy(v.addAttribute("inertia", computed_attribute=E.inertia(
        x, x_hat, mass)), projection=projection)
    return FreeVertices(v, x, x_hat)


def hex8_gauss_points(rest: np.ndarray, hexes: np.ndarray):
    """The 2x2x2 Gauss rule on trilinear hexahedra (M, 8, HEX_CORNERS
    order) at rest ``rest``: per cell and point (M * 8 of them) the
    gradients of the 8 shape functions with respect to rest positions
    (8x3, so that F = x^T G) and the point's weight times the rest Jacobian's
    determinant (its share of the cell's volume)."""
    rest = np.asarray(rest, dtype=float)
    corners = rest[np.asarray(hexes, dtype=np.int64)]          # (M, 8, 3)
    g = 0.5 / np.sqrt(3.0)
    points = 0.5 + g * (2 * HEX_CORNERS - 1)                   # (8, 3)
    gradients, volumes = [], []
    for xi in points:
        factors = np.where(HEX_CORNERS == 1, xi, 1.0 - xi)     # (8, 3)
        signs = np.where(HEX_CORNERS == 1, 1.0, -1.0)
        dN = np.stack([signs[:, a] * np.prod(np.delete(factors, a, axis=1),
                                              axis=1) for a in range(3)], 1)
        J = np.einsum("mkd,ka->mda", corners, dN)               # dX/dxi
        gradients.append(dN[None] @ np.linalg.inv(J))          # (M, 8, 3)
        volumes.append(np.linalg.det(J) / 8.0)
    G = np.stack(gradients, axis=1).reshape(-1, 8, 3)
    w = np.stack(volumes, axis=1).reshape(-1)
    if (w <= 0).any():
        raise ArgumentError("hex8_gauss_points: inverted cells at rest")
    return G, w


def add_hex8_neo_hookean(mesh: Mesh, positions: Attribute, rest: np.ndarray,
                         hexes: np.ndarray, mu: Number, lam: Number,
                         scale: Number = 1.0,
                         name: str = "gauss") -> Attribute:
    """Stable Neo-Hookean on trilinear hexahedra (paper appendix G, Hex8):
    a primitive ``name`` of their 2x2x2 Gauss points, each joined to its
    cell's 8 corners with F = x^T G and its share of the volume (see
    :func:`hex8_gauss_points`), times ``scale``; ``mu``, ``lam`` and
    ``scale`` are the mesh's constants ``name + "_mu"``, ``"_lam"``,
    ``"_scale"`` (:func:`material_constant`). Returns the energy."""
    G, w = hex8_gauss_points(rest, hexes)
    mu, lam, scale = (material_constant(mesh, f"{name}_{what}", value)
                      for what, value in (("mu", mu), ("lam", lam),
                                          ("scale", scale)))
    corners = np.repeat(np.asarray(hexes, dtype=np.int64), 8, axis=0)
    q = mesh.addPrimitive(name, numInstances=len(w))
    q.addConstant("G", rows=8, cols=3).updateValue(G)
    q.addConstant("vol", rows=1).updateValue(w[:, None])
    x = q.addAttribute("c", through=q.addConnectivity(
        "q2v", _vertices_of(positions), corners, 8), source=positions)
    energy = q.addAttribute("elastic", computed_attribute=scale *
                            E.stable_neo_hookean(x.T * q["G"], mu, lam,
                                                 q["vol"]))
    mesh.scene.addEnergy(energy)
    return energy


def add_caged_surface(mesh: Mesh, cage_positions: Attribute,
                      cage, name: str = "surface") -> Primitive:
    """A primitive ``name`` of points whose ``position`` is trilinear in the
    8 corners of their cage cell (``cage``: a :class:`.meshes.Cage` whose
    vertices ``cage_positions`` belongs to): the points the cage moves."""
    p = mesh.addPrimitive(name, numInstances=len(cage.cell_of))
    p.addConstant("w", rows=8).updateValue(cage.weights[:, :, None])
    corners = p.addAttribute("c", through=p.addConnectivity(
        "p2c", _vertices_of(cage_positions), cage.corners_of_points(), 8),
        source=cage_positions)
    p.addAttribute("position", computed_attribute=corners.T * p["w"])
    return p
