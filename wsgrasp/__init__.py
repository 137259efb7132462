"""wsgrasp: grasp planning on unknown objects from point clouds, for any gripper.

Implements Sorour et al., "Grasping Unknown Objects Based on Gripper Workspace
Spheres" (IROS 2019) as a framework: grippers, segmenters and candidate scorers are
plugins, a pipeline spec assembles them, and every run can be recorded to MCAP.
"""

from __future__ import annotations

from wsgrasp._version import __version__
from wsgrasp.errors import (
    GripperError,
    InputError,
    PluginError,
    RecordingError,
    SimulationError,
    SpecError,
    WsgraspError,
)
from wsgrasp.plugins import hookimpl

__all__ = [
    "GripperError",
    "InputError",
    "PluginError",
    "RecordingError",
    "SimulationError",
    "SpecError",
    "WsgraspError",
    "__version__",
    "hookimpl",
]

from wsgrasp.api import Pipeline, plan  # noqa: E402
from wsgrasp.gripper import _cache  # noqa: E402
from wsgrasp.plugins import get_registry  # noqa: E402
from wsgrasp.spec import load_spec  # noqa: E402

# the root wires the layers: a gripper name is looked up in the plugin registry
_cache.default_registry = get_registry
del _cache, get_registry

__all__ += ["Pipeline", "load_spec", "plan"]
