"""Gripper models: descriptions turned into spheres, superellipsoids and a cloud.

``load_gripper(name_or_path)`` resolves a registered gripper or a gripper YAML and
returns its :class:`GripperModel`, built once and cached on disk;
``build_model(desc, base_dir)`` builds one without the cache.
"""

from wsgrasp.gripper._build import BUILDER_VERSION, build_model, sample_workspace
from wsgrasp.gripper._cache import (
    default_cache_dir,
    load_gripper,
    resolve_gripper,
    source_hash,
)
from wsgrasp.gripper.model import GripperModel

__all__ = [
    "BUILDER_VERSION",
    "GripperModel",
    "build_model",
    "default_cache_dir",
    "load_gripper",
    "resolve_gripper",
    "sample_workspace",
    "source_hash",
]
