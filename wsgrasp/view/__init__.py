"""Pictures: gripper models (and, later, planning runs), drawn with matplotlib."""

from wsgrasp.view._gripper import render_gripper

__all__ = ["render_gripper"]
