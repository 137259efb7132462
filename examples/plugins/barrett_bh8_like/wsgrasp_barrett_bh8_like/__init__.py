"""wsgrasp gripper plugin.

Registers the gripper 'barrett_bh8_like' by its YAML (beside the URDF). Scaffolded by
`wsgrasp gripper new`.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from wsgrasp.plugins import hookimpl

HERE = Path(__file__).resolve().parent


@hookimpl
def wsgrasp_register_grippers(register: Callable[[str, Any], None]) -> None:
    """Register 'barrett_bh8_like' by the path of its gripper YAML."""
    register("barrett_bh8_like", HERE / "barrett_bh8_like.yaml")
