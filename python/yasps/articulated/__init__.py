"""Articulated bodies in joint coordinates: kinematic trees of rigid links
(revolute, continuous, prismatic and fixed joints, a fixed or floating
base), built as scene structure whose links' positions are computed from
the joint coordinates through JOINs (:mod:`.build`), read from URDF
(:mod:`.urdf`), with their inertia exact for rigid links
(:mod:`.inertia_points`) and their joint-space quantities
(:mod:`.dynamics`); joint limits as barriers never crossed (:mod:`.limits`)
and PD drives with their torques (:mod:`.drives`).

Owns: the tree's description and its translation into a scene. Imports
the frontend and :mod:`yasps.sim` (world inertia, rotations, meshes), never
the layers after it.
"""

from .build import ArticulatedBody, Depth, add_articulated_body
from .drives import JointDrives, add_joint_drives
from .dynamics import mass_matrix, point_jacobians
from .inertia_points import inertia_points
from .limits import JointLimits, add_joint_limits
from .tree import (JOINT_KINDS, MOVING_KINDS, Joint, KinematicTree, Link,
                   MovingBody, Surface, moving_bodies, transform)
from .urdf import box_surface, cylinder_surface, read_urdf

__all__ = ["ArticulatedBody", "Depth", "JOINT_KINDS", "Joint", "JointDrives",
           "JointLimits", "KinematicTree", "Link", "MOVING_KINDS",
           "MovingBody", "Surface", "add_articulated_body",
           "add_joint_drives", "add_joint_limits", "box_surface",
           "cylinder_surface",
           "inertia_points", "mass_matrix", "moving_bodies",
           "point_jacobians", "read_urdf", "transform"]
