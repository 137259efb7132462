"""wsgrasp: grasp planning on unknown objects from point clouds, for any gripper.

Implements Sorour et al., "Grasping Unknown Objects Based on Gripper Workspace
Spheres" (IROS 2019) as a framework: grippers, segmenters and candidate scorers are
plugins, a pipeline spec assembles them, and every run can be recorded to MCAP.
"""

from __future__ import annotations

from wsgrasp.errors import (
    GripperError,
    InputError,
    PluginError,
    RecordingError,
    SpecError,
    WsgraspError,
)
from wsgrasp.plugins import hookimpl

__version__ = "0.1.0"

__all__ = [
    "GripperError",
    "InputError",
    "PluginError",
    "RecordingError",
    "SpecError",
    "WsgraspError",
    "__version__",
    "hookimpl",
]

from wsgrasp.api import Pipeline, plan  # noqa: E402
from wsgrasp.spec import load_spec  # noqa: E402

__all__ += ["Pipeline", "load_spec", "plan"]
