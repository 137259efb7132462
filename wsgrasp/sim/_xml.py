"""Small helpers for writing MJCF: numbers, poses, attributes."""

from __future__ import annotations

from collections.abc import Iterable
from xml.sax.saxutils import quoteattr

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]

__all__ = ["attrs", "fmt", "pose_attrs", "quat_wxyz", "rpy_matrix"]


def fmt(values: float | Iterable[float]) -> str:
    """Numbers as MJCF text: ``"0.1 0 0.2"`` (12 significant digits)."""
    if isinstance(values, (int, float, np.floating, np.integer)):
        return f"{float(values):.12g}"
    return " ".join(f"{float(v):.12g}" for v in values)


def attrs(**kw: object) -> str:
    """``key="value"`` pairs; None values are left out."""
    out = []
    for k, v in kw.items():
        if v is None:
            continue
        text = v if isinstance(v, str) else fmt(v)  # type: ignore[arg-type]
        out.append(f"{k.rstrip('_')}={quoteattr(text)}")
    return " ".join(out)


def rpy_matrix(rpy: ArrayLike) -> Array:
    """URDF roll-pitch-yaw (fixed axes x, y, z) as a rotation matrix ``(3, 3)``."""
    r, p, y = (float(v) for v in np.asarray(rpy, dtype=np.float64).reshape(3))
    cr, sr, cp, sp, cy, sy = (
        np.cos(r),
        np.sin(r),
        np.cos(p),
        np.sin(p),
        np.cos(y),
        np.sin(y),
    )
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def quat_wxyz(R: ArrayLike) -> Array:
    """MuJoCo's quaternion order (w, x, y, z) of a rotation matrix ``(3, 3)``."""
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(np.asarray(R, dtype=np.float64)).as_quat()
    return np.array([w, x, y, z])


def pose_attrs(T: ArrayLike) -> str:
    """``pos`` and ``quat`` attributes of a transform ``(4, 4)``."""
    T = np.asarray(T, dtype=np.float64)
    return attrs(pos=T[:3, 3], quat=quat_wxyz(T[:3, :3]))
