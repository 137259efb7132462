"""Built-in wsgrasp segmenters, registered through the `wsgrasp` entry-point group.

- ``ransac_dbscan``: RANSAC table plane, then DBSCAN clusters standing on it.
- ``given_table``: the object is already segmented; the table plane is given.
- ``clutter``: ``ransac_dbscan``'s clusters split into object instances where
  objects touch, lean or stack (concave seams, footprint waists).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from wsgrasp.plugins import hookimpl
from wsgrasp_segmenters.clutter import Clutter
from wsgrasp_segmenters.given_table import GivenTable
from wsgrasp_segmenters.ransac_dbscan import RansacDbscan

__all__ = ["Clutter", "GivenTable", "RansacDbscan"]


@hookimpl
def wsgrasp_register_segmenters(register: Callable[[str, Any], None]) -> None:
    """Register the built-in segmenters."""
    register("ransac_dbscan", RansacDbscan)
    register("given_table", GivenTable)
    register("clutter", Clutter)
