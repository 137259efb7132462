"""Pure numpy kernels: transforms, superellipsoids, spheres; meshes of primitives
(trimesh). No I/O, no specs."""

from wsgrasp.geometry._fitting import box_corner_se_factors, enclosing_scale
from wsgrasp.geometry._kinematics import (
    JOINT_FIXED,
    JOINT_PRISMATIC,
    JOINT_REVOLUTE,
    axis_angle_matrices,
    chain_forward_kinematics,
    grid_configurations,
    joint_motion_transforms,
)
from wsgrasp.geometry._meshes import PRIMITIVES, primitive_mesh
from wsgrasp.geometry._sampling import (
    box_grid_points,
    farthest_point_indices,
    superellipsoid_surface,
)
from wsgrasp.geometry._spheres import points_in_spheres, spheres_hit_by_points
from wsgrasp.geometry._superellipsoid import (
    coordinates_in_superellipsoids,
    points_in_superellipsoids,
    superellipsoid_values,
)
from wsgrasp.geometry._transforms import (
    check_points,
    check_transforms,
    invert_transforms,
    plane_basis,
    rot_x,
    rot_y,
    rot_z,
    rotation_angle_deg,
    transform_from,
    transform_points,
)

__all__ = [
    "JOINT_FIXED",
    "JOINT_PRISMATIC",
    "JOINT_REVOLUTE",
    "PRIMITIVES",
    "axis_angle_matrices",
    "box_corner_se_factors",
    "box_grid_points",
    "chain_forward_kinematics",
    "check_points",
    "check_transforms",
    "coordinates_in_superellipsoids",
    "enclosing_scale",
    "farthest_point_indices",
    "grid_configurations",
    "invert_transforms",
    "joint_motion_transforms",
    "plane_basis",
    "points_in_spheres",
    "points_in_superellipsoids",
    "primitive_mesh",
    "rot_x",
    "rot_y",
    "rot_z",
    "rotation_angle_deg",
    "spheres_hit_by_points",
    "superellipsoid_surface",
    "superellipsoid_values",
    "transform_from",
    "transform_points",
]
