"""Pure numpy kernels: transforms, superellipsoids, spheres. No I/O, no specs."""

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
    rot_x,
    rot_y,
    rot_z,
    transform_from,
    transform_points,
)

__all__ = [
    "check_points",
    "coordinates_in_superellipsoids",
    "check_transforms",
    "invert_transforms",
    "points_in_spheres",
    "points_in_superellipsoids",
    "rot_x",
    "rot_y",
    "rot_z",
    "spheres_hit_by_points",
    "superellipsoid_values",
    "transform_from",
    "transform_points",
]
