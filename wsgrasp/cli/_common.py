"""Shared pieces of the command modules: consoles, state, JSON output."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import typer
from rich.console import Console

console = Console()
err_console = Console(stderr=True)


@dataclass
class _State:
    debug: bool = False


state = _State()


def _default(o: Any) -> Any:
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def print_json(data: Any) -> None:
    """Print ``data`` as JSON on stdout (numpy arrays as nested lists)."""
    print(json.dumps(data, indent=2, default=_default))


def number(
    lo: float | None = None, hi: float | None = None, *, above: bool = False
) -> Callable[[Any], Any]:
    """A typer callback refusing NaN, inf and values outside ``lo``..``hi``
    (``above``: strictly greater than ``lo``), as a usage error."""

    def check(value: Any) -> Any:
        if value is None:
            return value
        v = float(value)
        if not math.isfinite(v):
            raise typer.BadParameter(f"{value} is not a finite number")
        if lo is not None and (v <= lo if above else v < lo):
            least = "above" if above else "of at least"
            raise typer.BadParameter(
                f"{value:g} is too small; give a value {least} {lo:g}"
            )
        if hi is not None and v > hi:
            raise typer.BadParameter(f"{value:g} is too large; give at most {hi:g}")
        return value

    return check


INTRINSICS_HELP = (
    "Depth camera intrinsics of a depth image input (16-bit PNG or TIFF, float "
    "TIFF, (h, w) NPY): fx,fy,cx,cy in pixels, or a camera_info YAML/JSON file "
    "(FILE:raw for the camera's raw image, whose lens distortion is undone; "
    "FILE:rect for the rectified image)."
)
DEPTH_SCALE_HELP = (
    "Metres per unit of a depth image input; default 0.001 for integer images "
    "(millimetres), 1 for float images (metres)."
)


def intrinsics_of(text: str | None) -> Any:
    """``--intrinsics`` parsed (None when not given)."""
    from wsgrasp.perception.depth import Intrinsics

    return None if text is None else Intrinsics.parse(text)
