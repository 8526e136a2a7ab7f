"""Simulation helpers: time stepping (implicit Euler, Newton with a line
search and a step bound), elastic bodies and meshes."""

from .bodies import add_affine_inertia, add_elastic_tets
from .meshes import (box_tet_mesh, cloth_corners, cloth_grid, hinges_of,
                     orient_tets, read_tet_mesh, signed_tet_volumes)
from .newton import ImplicitEuler, NewtonReport, newton
from .output import (RecordedFrame, SurfaceRecorder, render_surfaces,
                     render_surfaces_array, write_video)

__all__ = ["ImplicitEuler", "NewtonReport", "RecordedFrame", "SurfaceRecorder",
           "add_affine_inertia", "add_elastic_tets",
           "box_tet_mesh", "cloth_corners", "cloth_grid", "hinges_of",
           "newton", "orient_tets", "read_tet_mesh", "render_surfaces",
           "render_surfaces_array", "signed_tet_volumes", "write_video"]
