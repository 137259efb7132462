"""One exception hierarchy for everything wsgrasp reports to its users.

Every message names the thing at fault, what was expected, what was found and the
fix. The CLI prints these in one line without a traceback and exits with status 2.
"""

from __future__ import annotations

import errno

__all__ = [
    "WsgraspError",
    "SpecError",
    "InputError",
    "PluginError",
    "GripperError",
    "RecordingError",
    "SimulationError",
    "os_error_message",
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


_OS_FIXES = {
    errno.EACCES: "choose a location you may write to, or change its permissions",
    errno.EPERM: "choose a location you may write to, or change its permissions",
    errno.EROFS: "the file system is read-only; choose another location",
    errno.ENOTDIR: "a part of the path is a file, not a folder; choose another path",
    errno.EEXIST: "a file of that name is in the way; choose another path or remove it",
    errno.EISDIR: "the path is a folder; give a file name",
    errno.ENOENT: "check the path (relative paths are from the current directory)",
    errno.ENOSPC: "the disk is full; free space or choose another location",
    errno.ENAMETOOLONG: "choose a shorter path",
}


def os_error_message(exc: OSError) -> str:
    """One line for an operating-system error on a path: the path, what the
    system said, and the fix."""
    path = exc.filename if exc.filename is not None else ""
    what = exc.strerror or type(exc).__name__
    fix = _OS_FIXES.get(exc.errno or -1, "check the path and its permissions")
    where = f"{path}: " if path else ""
    if exc.filename2 is not None:
        where = f"{path} -> {exc.filename2}: "
    return f"{where}{what} (fix: {fix})"
