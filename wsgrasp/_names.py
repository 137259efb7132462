"""Rules about what a user types: whether a gripper reference is a file or a
registered name, how either is shown, and the "did you mean" of a name that is
not known.

Every layer (``gripper`` included) uses these, so this module imports nothing of
wsgrasp.
"""

from __future__ import annotations

import difflib
import os
from collections.abc import Iterable
from pathlib import Path

__all__ = [
    "GRIPPER_SUFFIXES",
    "did_you_mean",
    "gripper_label",
    "gripper_ref",
    "is_gripper_path",
]

#: Suffixes of gripper description files.
GRIPPER_SUFFIXES = (".yaml", ".yml", ".json", ".toml")


def is_gripper_path(ref: str | Path) -> bool:
    """Whether ``ref`` is a gripper file rather than a registered name: a
    ``Path``, a name ending in one of :data:`GRIPPER_SUFFIXES`, or one holding a
    path separator."""
    if isinstance(ref, Path):
        return True
    return ref.endswith(GRIPPER_SUFFIXES) or "/" in ref or os.sep in ref


def gripper_label(ref: str) -> str:
    """A gripper as file names, titles and tables show it: a gripper file by its
    stem (``pkg/wsgrasp_x/x.yaml`` is ``x``), a registered name as it is."""
    return Path(ref).stem if is_gripper_path(ref) else ref


def gripper_ref(ref: str, base: str | Path) -> str:
    """``ref`` with a relative gripper path taken from ``base`` (the spec's
    directory, or the working directory); a registered name as it is."""
    if not is_gripper_path(ref):
        return ref
    path = Path(ref)
    return str(path if path.is_absolute() else Path(base) / path)


def did_you_mean(name: str, known: Iterable[str], *, list_known: bool = True) -> str:
    """A suffix for an error about unknown ``name``: ``"; did you mean 'x'?"``
    with the closest of ``known``; else, with ``list_known``, ``"; known: ..."``
    (or ``"; none is registered"``), without it ``""``."""
    names = list(known)
    close = difflib.get_close_matches(name, names, n=3, cutoff=0.5)
    if close:
        return "; did you mean " + " or ".join(repr(c) for c in close) + "?"
    if not list_known:
        return ""
    return "; known: " + ", ".join(sorted(names)) if names else "; none is registered"
