"""Scene processing: cloud I/O, view merging, downsampling, segmentation helpers,
object frame, box sampling, table superellipsoid, synthetic scenes.

Modules: ``io`` (loading and writing clouds and scenes), ``depth`` (depth images
and their intrinsics), ``flying`` (flying pixels), ``process`` (downsampling,
RANSAC plane, DBSCAN, target selection), ``frame`` (object and table frames, box
samples, normals), ``synth`` (rendering objects on a table from virtual depth
cameras), ``touching`` (two objects touching), ``sides`` (an object seen from
one side: its crest, its middle behind its points, its hidden sides), ``bag``
(scenes from ROS 2 bags' PointCloud2 and /tf messages), ``types`` (View, Scene,
Plane, Segmentation, Segmenter).
"""

from wsgrasp.perception.depth import Intrinsics, depth_points
from wsgrasp.perception.frame import (
    ObjectFrame,
    estimate_normals,
    grid_shape,
    object_frame,
    sample_box,
    table_frame,
    table_superellipsoid,
)
from wsgrasp.perception.io import (
    load_cloud,
    load_scene,
    save_cloud,
    scene_from_arrays,
    write_scene_yaml,
)
from wsgrasp.perception.process import crop, downsample, select_target, thin
from wsgrasp.perception.types import Plane, Scene, Segmentation, Segmenter, View

__all__ = [
    "Intrinsics",
    "ObjectFrame",
    "Plane",
    "Scene",
    "Segmentation",
    "Segmenter",
    "View",
    "crop",
    "depth_points",
    "downsample",
    "estimate_normals",
    "grid_shape",
    "load_cloud",
    "load_scene",
    "object_frame",
    "sample_box",
    "save_cloud",
    "scene_from_arrays",
    "select_target",
    "table_frame",
    "table_superellipsoid",
    "thin",
    "write_scene_yaml",
]
