"""Simulation helpers: time stepping (implicit Euler, Newton with a line
search and a step bound) and meshes for first simulations."""

from .meshes import box_tet_mesh
from .newton import ImplicitEuler, NewtonReport, newton

__all__ = ["ImplicitEuler", "NewtonReport", "box_tet_mesh", "newton"]
