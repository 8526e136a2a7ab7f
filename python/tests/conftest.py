"""Shared helpers of the Python tests: small meshes and the paper's scenes."""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "python"))
# Kernels compiled by the tests go to a fresh cache, not the user's.
os.environ.setdefault("YASPS_CACHE_DIR",
                      tempfile.mkdtemp(prefix="yasps-test-cache-"))

import yasps  # noqa: E402
from yasps.sim import box_tet_mesh  # noqa: E402


def ipctk_collisions(contact, V=None):
    """ipctk's own collision set of ``contact``'s mesh at positions V (by
    default its world positions now): the independent reference that
    yasps' collision sets are checked against."""
    import ipctk
    V = contact.world() if V is None else V
    collisions = ipctk.NormalCollisions()
    collisions.build(contact.mesh, V, contact.dhat)
    return collisions


def point_over_triangle(name: str, height: float):
    """A fixed triangle at z = 0 (2 m wide) and a point of 0.01 kg
    ``height`` above it, one primitive with contact (dhat 1e-2, kappa 10):
    (stepper of dt 0.01 without gravity, the point's x, the contact)."""
    from yasps import energies as E
    from yasps.contact import Contact
    from yasps.sim import ImplicitEuler

    V = np.array([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0],
                  [0.05, 0.0, height]])
    s = yasps.scene(name)
    v = s.addMesh("m").addPrimitive("v", numInstances=4)
    x = v.addAttribute("position", rows=3)
    x.updateValue(V[:, :, None])
    x_hat = v.addConstant("x_hat", rows=3)
    x_hat.updateValue(V[:, :, None])
    s.addEnergy(v.addAttribute("inertia",
                               computed_attribute=E.inertia(x, x_hat, 0.01)))
    contact = Contact(s, v, faces=np.array([[0, 1, 2]]), dhat=1e-2,
                      kappa=10.0)
    s.addMinimizeTarget([x])
    stepper = ImplicitEuler(s, x, x_hat, 0.01, contact=contact, gravity=None,
                            fixed=np.array([True, True, True, False]))
    return stepper, x, contact


def box_mesh(n: int = 2):
    """A unit cube of n^3 cells, each split into 6 positively oriented tets."""
    return box_tet_mesh(n)


def running_example(n: int = 2):
    """The paper's section 4 scene: a soft and an affine bunny (boxes here),
    the UNION of their vertices, dynamic point-point pairs with the barrier
    energy, minimised over the soft positions and the affine body."""
    verts, tets = box_mesh(n)
    nv, nt = len(verts), len(tets)
    s = yasps.scene("scene0")
    bunny_affine = s.addMesh("bunny_affine")
    bunny_soft = s.addMesh("bunny_soft")

    bunny_affine.addPrimitive("vertices", numInstances=nv)
    bunny_affine.addPrimitive("affine_body", numInstances=1)
    bunny_affine.addPrimitive("tets", numInstances=nt)
    bunny_affine.affine_body.addAttribute("affine_matrix", rows=3, cols=3)
    bunny_affine.affine_body["affine_matrix"].updateValue(np.eye(3))
    bunny_affine.affine_body.addAttribute("translation", rows=3, cols=1)
    bunny_affine.affine_body["translation"].updateValue(np.array([0.0, 0.0, 0.0]))
    bunny_affine.vertices.addConstant("rest_position", rows=3, cols=1)
    bunny_affine.vertices["rest_position"].updateValue(verts)

    bv2abd = bunny_affine.vertices.addConnectivity(
        "bunny_vertex_to_affine_body", bunny_affine.affine_body, [0] * nv, 1)
    affine_tet2v = bunny_affine.tets.addConnectivity(
        "tet2v", bunny_affine.vertices, tets, 4)
    bva = bunny_affine.vertices.addAttribute(
        "affine_matrix", through=bv2abd,
        source=bunny_affine.affine_body["affine_matrix"])
    bvt = bunny_affine.vertices.addAttribute(
        "translation", through=bv2abd,
        source=bunny_affine.affine_body["translation"])
    current = bva.resize(3, 3) * bunny_affine.vertices["rest_position"] + \
        bvt.resize(3, 1)
    bunny_affine.vertices.addAttribute("position", computed_attribute=current)
    bunny_affine.tets.addAttribute(
        "positions", through=affine_tet2v,
        source=bunny_affine.vertices["position"])

    bunny_soft.addPrimitive("vertices", numInstances=nv)
    bunny_soft.vertices.addAttribute("position", rows=3, cols=1)
    bunny_soft.vertices["position"].updateValue(verts + [2.0, 0.0, 0.0])
    bunny_soft.vertices.addConstant("rest_position", rows=3, cols=1)
    bunny_soft.vertices["rest_position"].updateValue(verts + [2.0, 0.0, 0.0])

    bunnies = s.addMesh("bunnies")
    bunnies.addPrimitiveUnion("vertices", [bunny_affine.vertices,
                                           bunny_soft.vertices])
    bunnies.vertices.addAttribute("rest_position")
    bunnies.vertices.addAttribute("position")
    bunnies.addPrimitive("pp", numInstances=0, isDynamic=True)
    pp2v = bunnies.pp.addConnectivity("pp2v", bunnies.vertices, [], 2)
    pp_positions = bunnies.pp.addAttribute(
        "positions", through=pp2v, source=bunnies.vertices["position"])

    def point_point(position, dHat, kappa):
        p0 = position.row(0)
        p1 = position.row(1)
        d = (p1 - p0).dot(p1 - p0)
        I5 = d / dHat
        lenE = d - dHat
        I5log = I5.log()
        return kappa * lenE * lenE * I5log * I5log

    pp = point_point(pp_positions, 1e-3, 1e4)
    pp_energy = bunnies.pp.addAttribute("point_point", computed_attribute=pp)
    s.addEnergy(pp_energy, dynamic_instances=True)
    s.addMinimizeTarget([bunny_soft.vertices["position"],
                         bunny_affine.affine_body["affine_matrix"],
                         bunny_affine.affine_body["translation"]])
    return s


@pytest.fixture
def one_preconditioner(monkeypatch):
    """Pins PCG's preconditioner to block-Jacobi for a test that compares
    solves bit for bit or by differences of runs. ``"auto"`` carries its
    choice from solve to solve (a trial of the multilevel preconditioner may
    win on the second solve of a scene), so a repeated or perturbed run may
    take the other preconditioner and differ by the solves' tolerance."""
    monkeypatch.setattr(yasps.config, "preconditioner", "block-jacobi")


@pytest.fixture
def example_scene():
    return running_example()


def yasps_opt() -> Path:
    build = Path(os.environ.get("YASPS_BUILD_DIR", REPO / "build"))
    return build / "bin" / "yasps-opt"
