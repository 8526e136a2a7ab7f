"""A contact without kappa or average_mass reads the bodies' vertex masses
from the scene (yasps.contact.masses): the adaptive stiffness is then IPC's
from their mean, and a drop with friction runs on it without an
intersection."""

import ipctk
import numpy as np
import pytest

import yasps
from yasps.contact import Contact, surface_of
from yasps.contact.masses import average_vertex_mass
from yasps.sim import (ImplicitEuler, add_affine_body, add_elastic_tets,
                       add_free_vertices, box_tet_mesh, lumped_masses)


def soft_box_over_affine_box():
    """A soft tet box 2 mm above an affine tet box, as one union."""
    verts, tets = box_tet_mesh(2, size=0.1)
    faces = surface_of(tets)
    s = yasps.scene("masses")
    soft_mesh, rigid_mesh = s.addMesh("soft"), s.addMesh("rigid")
    soft_masses = lumped_masses(verts, tets, 500.0)
    soft = add_free_vertices(soft_mesh, verts + [0.01, 0.02, 0.102],
                             soft_masses)
    add_elastic_tets(soft_mesh, soft.x, verts, tets, 2e4, 5e4, scale=1e-4)
    rigid_masses = lumped_masses(verts, tets, 2000.0)
    body = add_affine_body(rigid_mesh, verts, rigid_masses, 1e5, scale=1e-4)
    union = s.addMesh("all").addPrimitiveUnion("v", [soft.primitive,
                                                     body.vertices])
    union.addAttribute("position")
    both = np.concatenate([faces, faces + len(verts)])
    return s, soft, body, union, both, np.concatenate([soft_masses,
                                                       rigid_masses])


def test_adaptive_stiffness_reads_the_scenes_masses():
    s, soft, body, union, faces, masses = soft_box_over_affine_box()
    assert average_vertex_mass(union) == pytest.approx(masses.mean(),
                                                       rel=1e-14)
    contact = Contact(s, union, faces=faces, dhat=5e-3, friction=0.2)
    assert contact.adaptive.average_mass == pytest.approx(masses.mean(),
                                                          rel=1e-14)
    s.addMinimizeTarget([soft.x, body.A, body.t])
    stepper = ImplicitEuler(s, targets=[soft.x, body.A, body.t],
                            predicted=[soft.x_hat, body.A_hat, body.t_hat],
                            dt=0.01, gravity=[(0, 0, -9.81), None, None],
                            fixed=[None, np.ones((1, 3, 3), bool),
                                   np.ones((1, 3, 1), bool)],
                            contact=contact)
    mesh = ipctk.CollisionMesh(contact.world(), contact.mesh.edges,
                               contact.mesh.faces)
    before = contact.world()
    for _ in range(6):
        assert stepper.step().converged
        after = contact.world()
        assert ipctk.is_step_collision_free(mesh, before, after)
        before = after
    assert contact.kappa > 0 and contact.adaptive.kappa is not None


def test_without_masses_or_stiffness_the_contact_says_what_to_give():
    verts, tets = box_tet_mesh(1, size=0.1)
    s = yasps.scene("no_masses")
    v = s.addMesh("m").addPrimitive("v", numInstances=len(verts))
    v.addAttribute("position", rows=3).updateValue(verts)
    with pytest.raises(yasps.SceneError,
                       match="no primitive of .* records its vertices' masses"):
        Contact(s, v, faces=surface_of(tets))
