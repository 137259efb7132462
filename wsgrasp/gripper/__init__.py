"""Gripper models: descriptions turned into spheres, superellipsoids and a cloud."""

from wsgrasp.gripper.model import GripperModel

__all__ = ["GripperModel"]
