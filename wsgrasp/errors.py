"""One exception hierarchy for everything wsgrasp reports to its users.

Every message names the thing at fault, what was expected, what was found and the
fix. The CLI prints these in one line without a traceback and exits with status 2.
"""

from __future__ import annotations

__all__ = [
    "WsgraspError",
    "SpecError",
    "InputError",
    "PluginError",
    "GripperError",
    "RecordingError",
    "SimulationError",
]


class WsgraspError(Exception):
    """Base class of every error wsgrasp raises on purpose.

    Parameters
    ----------
    message
        What went wrong, naming the thing at fault.
    hint
        What the user can do about it; appended to the message.
    """

    def __init__(self, message: str, *, hint: str | None = None) -> None:
        self.message = message
        self.hint = hint
        super().__init__(self.__str__())

    def __str__(self) -> str:
        if self.hint:
            return f"{self.message} (fix: {self.hint})"
        return self.message


class SpecError(WsgraspError):
    """A pipeline spec or gripper description that does not validate."""


class InputError(WsgraspError):
    """A point cloud, scene or other run-time input that cannot be planned on."""


class PluginError(WsgraspError):
    """A plugin that failed to load, registered a name twice, or raised."""


class GripperError(WsgraspError):
    """A gripper description or URDF that cannot be turned into a gripper model."""


class RecordingError(WsgraspError):
    """An MCAP recording that cannot be written, read or replayed."""


class SimulationError(WsgraspError):
    """A physics trial that cannot be set up."""
