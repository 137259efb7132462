"""The gripper model: plain arrays the planner works on, and their file format."""

from __future__ import annotations

import io
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.errors import GripperError

__all__ = ["GripperModel", "MODEL_FORMAT_VERSION"]

MODEL_FORMAT_VERSION = 1

_ARRAYS = (
    "cloud",
    "sphere_centers",
    "sphere_radii",
    "sphere_finger",
    "se_centers",
    "se_semi_axes",
    "T_gripper_tcp",
    "T_gripper_gwc",
    "approach_axis",
    "closing_axis",
)


@dataclass
class GripperModel:
    """A gripper as the planner sees it. All arrays are in the gripper (URDF base)
    frame, float64, metres.

    Attributes
    ----------
    name : str
    cloud : (ng, 3) float
        Points on the gripper's collision geometry in the pre-grasp posture.
    sphere_centers : (S, 3) float
        Workspace spheres of all fingers, finger after finger.
    sphere_radii : (S,) float
    sphere_finger : (S,) int
        Index into ``finger_names`` of the finger each sphere belongs to.
    finger_names : list of str
    se_centers, se_semi_axes : (ne, 3) float
        Body superellipsoids, axis-aligned in the gripper frame.
    se_exponent : float
        ``l`` of eq. (1).
    T_gripper_tcp : (4, 4) float
        Tool centre point.
    T_gripper_gwc : (4, 4) float
        Gripper-workspace-centroid frame: origin at the centroid of the finger
        workspaces, z = approach axis, y = closing axis, x = y × z.
    approach_axis, closing_axis : (3,) float
    pregrasp, closed : dict of str to float
        Joint positions of the open and closed postures.
    max_opening : float
        Widest object (m) the fingers can span, along the closing axis.
    stats : dict
        Build report: per-finger workspace volume and sphere coverage, cloud
        fraction inside the superellipsoids, build time.
    description : dict
        The gripper description this model was built from.
    source_hash : str
        Hash of description, URDF, meshes and wsgrasp version (the cache key).
    """

    name: str
    cloud: NDArray[np.float64]
    sphere_centers: NDArray[np.float64]
    sphere_radii: NDArray[np.float64]
    sphere_finger: NDArray[np.int64]
    finger_names: list[str]
    se_centers: NDArray[np.float64]
    se_semi_axes: NDArray[np.float64]
    se_exponent: float
    T_gripper_tcp: NDArray[np.float64]
    T_gripper_gwc: NDArray[np.float64]
    approach_axis: NDArray[np.float64]
    closing_axis: NDArray[np.float64]
    pregrasp: dict[str, float]
    closed: dict[str, float]
    max_opening: float
    stats: dict[str, Any] = field(default_factory=dict)
    description: dict[str, Any] = field(default_factory=dict)
    source_hash: str = ""

    # -- derived -----------------------------------------------------------------
    @property
    def num_fingers(self) -> int:
        return len(self.finger_names)

    @property
    def spheres_per_finger(self) -> list[int]:
        counts = np.bincount(self.sphere_finger, minlength=self.num_fingers)
        return [int(c) for c in counts]

    # -- serialisation -----------------------------------------------------------
    def to_bytes(self) -> bytes:
        """Serialise to a compressed ``.npz`` in memory (arrays exact)."""
        meta = {
            "format": MODEL_FORMAT_VERSION,
            "name": self.name,
            "finger_names": self.finger_names,
            "se_exponent": self.se_exponent,
            "pregrasp": self.pregrasp,
            "closed": self.closed,
            "max_opening": self.max_opening,
            "stats": self.stats,
            "description": self.description,
            "source_hash": self.source_hash,
        }
        buf = io.BytesIO()
        arrays = {k: np.asarray(getattr(self, k)) for k in _ARRAYS}
        arrays["meta"] = np.frombuffer(json.dumps(meta).encode(), np.uint8)
        np.savez_compressed(buf, **arrays)  # type: ignore[arg-type]
        return buf.getvalue()

    @classmethod
    def from_bytes(cls, data: bytes) -> GripperModel:
        """Inverse of :meth:`to_bytes`."""
        try:
            with np.load(io.BytesIO(data), allow_pickle=False) as z:
                meta = json.loads(z["meta"].tobytes().decode())
                arrays = {k: z[k] for k in _ARRAYS}
        except Exception as exc:  # noqa: BLE001 - any decoding failure
            raise GripperError(
                f"gripper model data is not readable: {exc}",
                hint="rebuild the model (delete the cache entry)",
            ) from None
        if meta.get("format") != MODEL_FORMAT_VERSION:
            raise GripperError(
                f"gripper model format {meta.get('format')} is not "
                f"{MODEL_FORMAT_VERSION}",
                hint="rebuild the model with this version of wsgrasp",
            )
        arrays["sphere_finger"] = arrays["sphere_finger"].astype(np.int64)
        return cls(
            name=meta["name"],
            finger_names=list(meta["finger_names"]),
            se_exponent=float(meta["se_exponent"]),
            pregrasp={k: float(v) for k, v in meta["pregrasp"].items()},
            closed={k: float(v) for k, v in meta["closed"].items()},
            max_opening=float(meta["max_opening"]),
            stats=meta["stats"],
            description=meta["description"],
            source_hash=meta["source_hash"],
            **arrays,
        )

    def save(self, path: str | Path) -> None:
        """Write the model to ``path`` (``.npz``)."""
        Path(path).write_bytes(self.to_bytes())

    @classmethod
    def load(cls, path: str | Path) -> GripperModel:
        """Read a model written by :meth:`save`."""
        return cls.from_bytes(Path(path).read_bytes())
