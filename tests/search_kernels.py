"""Route the search's evaluation through one kernel in a test (``monkeypatch``):
numpy's, or the compiled loops (compiled by numba where it can be imported, else
run as their plain Python functions, so that their logic is tested either way),
as a small search runs them or as a dense one does, with the holdings kept or
computed when read."""

from __future__ import annotations

import pytest

from wsgrasp.planning import _compiled, evaluate, fingers
from wsgrasp.planning.kernels import Kernels

#: numpy's kernels; the compiled loops as a small search runs them, and as a
#: dense one does (nearest-point hints, points in space order); each with the
#: holdings kept, or counted and computed when read
KERNELS = (
    "numpy",
    "numpy_count",
    "compiled",
    "compiled_dense",
    "compiled_count",
)


def loops() -> list[tuple[object, object]]:
    """The (count, body) loops to test: the plain Python functions, and the
    compiled ones where numba can be imported."""
    out = [(_compiled._count_loop, _compiled._body_loop)]
    if _compiled.available():
        out.append(_compiled.load())
    return out


def force(monkeypatch: pytest.MonkeyPatch, kernel: str) -> None:
    """Every evaluation from here on runs ``kernel`` (one of :data:`KERNELS`)."""
    compiled = kernel.startswith("compiled")
    if compiled:
        count, body = loops()[-1]
        monkeypatch.setattr(_compiled, "_AVAILABLE", True)
        monkeypatch.setattr(_compiled, "_compiled_count", count)
        monkeypatch.setattr(_compiled, "_compiled_body", body)
    chosen = Kernels(compiled, kernel.endswith("dense"))
    monkeypatch.setattr(evaluate, "choose_kernels", lambda pairs, search=True: chosen)
    if kernel.endswith("count"):
        monkeypatch.setattr(fingers, "_KEEP_ENTRIES", -1)
