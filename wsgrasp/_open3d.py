"""open3d, imported without its plotly viewer.

``import open3d`` imports ``open3d.visualization.draw_plotly``, which imports
plotly and dash: 0.62 s of open3d's 1.04 s import in a fresh ``wsgrasp plan``
process (cProfile; open3d 0.20.0, dash 3, on this project's 2-core machine), for
a viewer wsgrasp never calls. Measured by ``benchmarks/open3d_import.py`` (7
fresh processes each, load 3): the import 0.59 s as ``import open3d`` against
0.30 s without the viewer; a whole ``wsgrasp plan`` on the bundled scene 2.00 s
against 1.51 s (alternating runs of the code before and after).

Before open3d's first import that submodule is stood in for by a module whose
functions import the real one when called, so that a user's
``open3d.visualization.draw_plotly(...)`` in the same process still works; the
stand-in leaves ``sys.modules`` once open3d is in, and any other name asked of
it imports the real module at once.
"""

from __future__ import annotations

import importlib
import sys
import threading
import types
from typing import Any

__all__ = ["load_open3d"]

_VIEWER = "open3d.visualization.draw_plotly"
_LOADING = threading.Lock()


class _Later(types.ModuleType):
    """Stands in for :data:`_VIEWER` while open3d imports."""

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):  # what the import machinery asks (__path__)
            raise AttributeError(name)
        return getattr(_real(), name)


def _real() -> types.ModuleType:
    """The viewer module itself, imported (plotly and dash with it)."""
    if isinstance(sys.modules.get(_VIEWER), _Later):
        del sys.modules[_VIEWER]
    return importlib.import_module(_VIEWER)


def _deferred(name: str) -> Any:
    def call(*args: Any, **kwargs: Any) -> Any:
        return getattr(_real(), name)(*args, **kwargs)

    call.__name__ = call.__qualname__ = name
    call.__doc__ = f"open3d's ``{name}``, imported when first called."
    return call


def load_open3d() -> types.ModuleType:
    """The ``open3d`` module, imported on first use without plotly and dash."""
    if "open3d" in sys.modules:
        return sys.modules["open3d"]
    with _LOADING:
        if "open3d" in sys.modules:
            return sys.modules["open3d"]
        if _VIEWER not in sys.modules:
            stand_in = _Later(_VIEWER)
            for name in ("get_plotly_fig", "draw_plotly", "draw_plotly_server"):
                setattr(stand_in, name, _deferred(name))
            sys.modules[_VIEWER] = stand_in
        try:
            import open3d
        finally:
            if isinstance(sys.modules.get(_VIEWER), _Later):
                del sys.modules[_VIEWER]
        return open3d
