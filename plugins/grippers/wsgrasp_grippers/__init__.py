"""Built-in wsgrasp grippers, registered through the `wsgrasp` entry-point group.

Each gripper is a folder with a URDF and a gripper YAML beside it:

- ``franka_hand``: Franka Emika hand (parallel jaw, two prismatic fingers);
- ``allegro_right``: Wonik Allegro right hand (four fingers, 16 revolute joints).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from wsgrasp.plugins import hookimpl

HERE = Path(__file__).resolve().parent
GRIPPERS = ("franka_hand", "allegro_right")


@hookimpl
def wsgrasp_register_grippers(register: Callable[[str, Any], None]) -> None:
    """Register each built-in gripper by the path of its YAML."""
    for name in GRIPPERS:
        register(name, HERE / name / f"{name}.yaml")
