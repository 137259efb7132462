"""The one place MuJoCo is imported: lazily, with an install hint when missing."""

from __future__ import annotations

from typing import Any

from wsgrasp.errors import SimulationError

__all__ = ["require_mujoco"]


def require_mujoco() -> Any:
    """The ``mujoco`` module, or a ``SimulationError`` saying how to install it."""
    try:
        import mujoco
    except ImportError as exc:
        raise SimulationError(
            f"physics trials need MuJoCo, which is not installed ({exc})",
            hint="pip install 'wsgrasp[sim]'",
        ) from None
    return mujoco
