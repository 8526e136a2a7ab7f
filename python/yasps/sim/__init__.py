"""Simulation helpers: time stepping (implicit Euler, Newton with a line
search and step bounds), bodies (soft tets, cloth, affine bodies), meshes,
and output (ParaView series, pictures, videos)."""

from ..contact.relative import Relative
from .bodies import (AffineBody, FreeVertices, add_affine_body,
                     add_affine_inertia, add_caged_surface, add_cloth,
                     add_elastic_tets, add_free_vertices,
                     add_hex8_neo_hookean, hex8_gauss_points, lame,
                     lumped_masses, material_constant)
from .meshes import (HEX_CORNERS, Cage, box_tet_mesh, cage_grid,
                     cloth_corners, cloth_grid, hex_tets, hinges_of,
                     locality_order, orient_tets, polyline_segments,
                     read_surface_mesh, read_tet_mesh, reorder_mesh,
                     signed_tet_volumes, trilinear_weights, tube_mesh,
                     zigzag_spring)
from .inversion import (combined_bound, inversion_bound,
                        inversion_free_fraction)
from .loads import Loads, add_loads
from .parts import CagedBody, add_caged_body, add_obstacle, contact_union
from .shapes import bowl_surface, ring_surface, sphere_surface
from .motion import Motion, affine_motion, affine_velocity, vertex_motion
from .inversion import ElementsInverted
from .newton import (ImplicitEuler, NewtonNotConverged, NewtonReport,
                     iteration_totals, newton)
from .newton_settings import MAX_ITERATIONS, PROJECTIONS, NewtonSettings
from .output import (RecordedFrame, SurfaceRecorder, render_surfaces,
                     render_surfaces_array, write_video)
from .rotation import (RotationBody, add_rotation_vector_body,
                       rotation_matrices, wrap_rotation_vectors)
from .run import Body, RunSummary, simulate
from .world import WorldInertia, add_world_inertia
from .tetrahedralize import tetrahedralize

__all__ = ["AffineBody", "Body", "Cage", "FreeVertices", "HEX_CORNERS",
           "CagedBody", "add_caged_body", "add_obstacle", "contact_union",
           "bowl_surface", "ring_surface", "sphere_surface",
           "Loads", "Relative", "RotationBody", "WorldInertia", "add_loads", "add_rotation_vector_body",
           "add_world_inertia", "rotation_matrices", "wrap_rotation_vectors",
           "Motion", "affine_motion", "affine_velocity", "vertex_motion",
           "combined_bound", "inversion_bound", "inversion_free_fraction",
           "add_caged_surface", "add_free_vertices", "add_hex8_neo_hookean",
           "cage_grid", "hex8_gauss_points", "hex_tets", "lame",
           "lumped_masses",
           "material_constant",
           "trilinear_weights", "tube_mesh", "polyline_segments", "zigzag_spring", "RunSummary", "simulate", "ImplicitEuler", "ElementsInverted", "NewtonNotConverged", "NewtonReport", "NewtonSettings", "MAX_ITERATIONS",
           "PROJECTIONS", "RecordedFrame",
           "SurfaceRecorder", "add_affine_body", "add_affine_inertia",
           "add_cloth", "add_elastic_tets",
           "box_tet_mesh", "cloth_corners", "cloth_grid", "hinges_of",
           "iteration_totals", "locality_order", "newton", "orient_tets",
           "read_surface_mesh", "read_tet_mesh", "reorder_mesh", "render_surfaces",
           "render_surfaces_array", "signed_tet_volumes", "tetrahedralize",
           "write_video"]
