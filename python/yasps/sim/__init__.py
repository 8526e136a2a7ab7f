"""Simulation helpers: time stepping (implicit Euler, Newton with a line
search and a step bound), elastic bodies and meshes."""

from .bodies import add_affine_inertia, add_elastic_tets
from .meshes import box_tet_mesh
from .newton import ImplicitEuler, NewtonReport, newton

__all__ = ["ImplicitEuler", "NewtonReport", "add_affine_inertia",
           "add_elastic_tets",
           "box_tet_mesh", "newton"]
