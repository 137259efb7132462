"""Triangle meshes of primitive shapes (trimesh, imported when first used)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["PRIMITIVES", "primitive_mesh"]

PRIMITIVES = ("box", "cylinder", "sphere", "capsule", "ellipsoid")


def primitive_mesh(
    kind: str, size: ArrayLike, *, subdivisions: int = 3, sections: int = 32
) -> Any:
    """A ``trimesh.Trimesh`` of a primitive centred at its frame's origin.

    Parameters
    ----------
    kind
        ``box`` (size: full extents), ``cylinder`` (radius, height) and
        ``capsule`` (radius, length of the straight part), both along z,
        ``sphere`` (radius) or ``ellipsoid`` (semi-axes).
    size : (k,) float
    subdivisions
        Of the icosphere of a sphere or an ellipsoid.
    sections
        Around a cylinder.
    """
    import trimesh

    s = np.asarray(size, dtype=np.float64).reshape(-1).tolist()
    if kind == "box":
        return trimesh.creation.box(extents=s[:3])
    if kind == "cylinder":
        return trimesh.creation.cylinder(radius=s[0], height=s[1], sections=sections)
    if kind == "capsule":
        return trimesh.creation.capsule(radius=s[0], height=s[1], count=[16, 16])
    if kind == "sphere":
        return trimesh.creation.icosphere(subdivisions=subdivisions, radius=s[0])
    if kind == "ellipsoid":
        mesh = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
        mesh.apply_scale(s[:3])
        return mesh
    raise ValueError(f"unknown primitive {kind!r}; expected one of {PRIMITIVES}")
