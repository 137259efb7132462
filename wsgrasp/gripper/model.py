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

MODEL_FORMAT_VERSION = 3
#: formats :meth:`GripperModel.from_bytes` still reads (1: no finger
#: configurations; 2: no finger sweeps)
_READABLE_FORMATS = (1, 2, 3)

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
#: arrays of the finger configurations (format 2); empty in a format-1 model
_CONFIG_ARRAYS = (
    "config_pad",
    "config_finger",
    "sphere_config_ptr",
    "sphere_config_index",
)
#: arrays of the fingers' closing sweeps (format 3); empty before
_SWEEP_ARRAYS = ("finger_sweep",)


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
    finger_joints : list of list of str
        Per finger, the actuated joints its workspace samples (mimics replaced by
        the joints they follow), in grid order.
    finger_limits : list of (d, 2) float
        Per finger, the lower and upper limit of each of those joints.
    joint_samples : int
        Grid points per joint of every finger's configuration grid.
    config_pad : (Q, 3) float
        The pad centre at every configuration of every finger's joint grid,
        finger after finger (finger ``f``'s block is
        ``config_offsets[f]:config_offsets[f + 1]``).
    config_finger : (Q,) int
        The finger of each configuration.
    sphere_config_ptr : (S + 1,) int
    sphere_config_index : (M,) int
        Sphere ``s`` holds a pad sample point of the configurations
        ``sphere_config_index[sphere_config_ptr[s]:sphere_config_ptr[s + 1]]``
        (indices into ``config_pad``): the joint configurations that put the
        fingertip in that sphere.
    finger_sweep : (nf, K, P, 3) float
        Per finger, ``P`` points on the collision geometry of the links its
        joints move, at ``K`` postures evenly spaced (in joint space) from the
        pre-grasp posture to the closed one: the volume the finger sweeps as it
        closes (``(0, 0, 0, 3)`` in a model built before format 3).
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
    finger_joints: list[list[str]] = field(default_factory=list)
    finger_limits: list[NDArray[np.float64]] = field(default_factory=list)
    joint_samples: int = 0
    config_pad: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))
    config_finger: NDArray[np.int64] = field(
        default_factory=lambda: np.zeros(0, dtype=np.int64)
    )
    sphere_config_ptr: NDArray[np.int64] = field(
        default_factory=lambda: np.zeros(1, dtype=np.int64)
    )
    sphere_config_index: NDArray[np.int64] = field(
        default_factory=lambda: np.zeros(0, dtype=np.int64)
    )
    finger_sweep: NDArray[np.float64] = field(
        default_factory=lambda: np.zeros((0, 0, 0, 3))
    )

    # -- derived -----------------------------------------------------------------
    @property
    def num_fingers(self) -> int:
        return len(self.finger_names)

    @property
    def contact_fingers(self) -> NDArray[np.bool_]:
        """``(nf,)``: the fingers that must hold object points for a candidate
        to be feasible (the description's ``contact_fingers``; every finger
        when it names none, as in Algorithm 1)."""
        names = self.description.get("contact_fingers") if self.description else None
        if not names:
            return np.ones(self.num_fingers, dtype=bool)
        return np.isin(np.asarray(self.finger_names, dtype=object), list(names))

    def feasible_contacts(self, counts: NDArray[np.int64]) -> NDArray[np.bool_]:
        """``(..., nf)`` points held per finger -> ``(...)``: whether every
        finger of :attr:`contact_fingers` holds some."""
        return np.all(np.asarray(counts)[..., self.contact_fingers] > 0, axis=-1)  # type: ignore[no-any-return]

    @property
    def spheres_per_finger(self) -> list[int]:
        counts = np.bincount(self.sphere_finger, minlength=self.num_fingers)
        return [int(c) for c in counts]

    @property
    def enclosure(self) -> float:
        """Widest object (m) the fingers' pads can enclose along the closing
        axis, for jaws and hands alike: the greatest span between the workspace
        spheres of two different fingers (of the one finger, for a single
        finger), sphere surfaces included."""
        nf = self.num_fingers
        if nf == 0:
            return 0.0
        y = self.sphere_centers @ self.closing_axis  # (S,)
        hi = np.full(nf, -np.inf)
        lo = np.full(nf, np.inf)
        np.maximum.at(hi, self.sphere_finger, y + self.sphere_radii)
        np.minimum.at(lo, self.sphere_finger, y - self.sphere_radii)
        span = hi[:, None] - lo[None, :]  # (nf, nf): finger i's far side to j's
        if nf > 1:
            np.fill_diagonal(span, -np.inf)
        return float(max(span.max(), 0.0))

    @property
    def has_configurations(self) -> bool:
        """Whether the model keeps its fingers' joint configurations (format 2)."""
        return len(self.config_pad) > 0

    @property
    def has_sweeps(self) -> bool:
        """Whether the model keeps its fingers' closing sweeps (format 3)."""
        return self.finger_sweep.size > 0

    @property
    def config_offsets(self) -> NDArray[np.int64]:
        """Start of each finger's block in ``config_pad``, ``(nf + 1,)`` (computed
        once, kept on the model: the joint targets ask for it per finger)."""
        cached = self.__dict__.get("_config_offsets")
        if cached is None:
            counts = np.bincount(self.config_finger, minlength=self.num_fingers)
            cached = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
            cached.flags.writeable = False
            self.__dict__["_config_offsets"] = cached
        return cached  # type: ignore[no-any-return]

    def finger_configurations(self, finger: int) -> NDArray[np.float64]:
        """The joint grid of one finger, ``(K, d)``, in ``config_pad`` order
        (built once per finger, kept on the model, read-only)."""
        from wsgrasp.geometry import grid_configurations

        grids: dict[int, NDArray[np.float64]] = self.__dict__.setdefault(
            "_finger_grids", {}
        )
        if finger not in grids:
            lim = np.asarray(self.finger_limits[finger], dtype=np.float64)
            q = grid_configurations(lim[:, 0], lim[:, 1], self.joint_samples)
            q.flags.writeable = False
            grids[finger] = q
        return grids[finger]

    def sphere_configurations(self, spheres: NDArray[np.int64]) -> NDArray[np.int64]:
        """Indices into ``config_pad`` of the configurations that put a pad sample
        point inside any of ``spheres`` (sorted, unique)."""
        ptr = self.sphere_config_ptr
        mask = np.zeros(len(self.config_pad), dtype=bool)
        for s in np.asarray(spheres, dtype=np.int64):
            mask[self.sphere_config_index[ptr[s] : ptr[s + 1]]] = True
        return np.flatnonzero(mask)

    @property
    def actuated_joints(self) -> list[str]:
        """Every actuated joint the model knows: the pre-grasp posture's joints,
        then the fingers' sampled joints, each once."""
        names = list(self.pregrasp)
        for joints in self.finger_joints:
            names.extend(j for j in joints if j not in names)
        return names

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
            "finger_joints": self.finger_joints,
            "finger_limits": [np.asarray(x).tolist() for x in self.finger_limits],
            "joint_samples": self.joint_samples,
        }
        buf = io.BytesIO()
        arrays = {
            k: np.asarray(getattr(self, k))
            for k in _ARRAYS + _CONFIG_ARRAYS + _SWEEP_ARRAYS
        }
        # the configuration tables are most of an Allegro model: pad centres as
        # float32 (exact to well under a micrometre) and the sorted per-sphere
        # lists as differences shrink it from 3.1 MB to 0.95 MB compressed
        arrays["config_pad"] = arrays["config_pad"].astype(np.float32)
        arrays["finger_sweep"] = arrays["finger_sweep"].astype(np.float32)
        arrays["sphere_config_index"] = np.diff(
            arrays["sphere_config_index"], prepend=0
        ).astype(np.int32)
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
                arrays.update(
                    {k: z[k] for k in _CONFIG_ARRAYS + _SWEEP_ARRAYS if k in z.files}
                )
        except Exception as exc:  # noqa: BLE001 - any decoding failure
            raise GripperError(
                f"gripper model data is not readable: {exc}",
                hint="rebuild the model (delete the cache entry)",
            ) from None
        if meta.get("format") not in _READABLE_FORMATS:
            raise GripperError(
                f"gripper model format {meta.get('format')} is not "
                f"{MODEL_FORMAT_VERSION}",
                hint="rebuild the model with this version of wsgrasp",
            )
        for k in ("sphere_finger", "config_finger"):
            if k in arrays:
                arrays[k] = arrays[k].astype(np.int64)
        if "sphere_config_index" in arrays:
            arrays["sphere_config_ptr"] = arrays["sphere_config_ptr"].astype(np.int64)
            arrays["sphere_config_index"] = np.cumsum(
                arrays["sphere_config_index"], dtype=np.int64
            )
            arrays["config_pad"] = arrays["config_pad"].astype(np.float64)
        if "finger_sweep" in arrays:
            arrays["finger_sweep"] = arrays["finger_sweep"].astype(np.float64)
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
            finger_joints=[list(j) for j in meta.get("finger_joints", [])],
            finger_limits=[
                np.asarray(x, dtype=np.float64).reshape(-1, 2)
                for x in meta.get("finger_limits", [])
            ],
            joint_samples=int(meta.get("joint_samples", 0)),
            **arrays,
        )

    def save(self, path: str | Path) -> None:
        """Write the model to ``path`` (``.npz``)."""
        Path(path).write_bytes(self.to_bytes())

    @classmethod
    def load(cls, path: str | Path) -> GripperModel:
        """Read a model written by :meth:`save`."""
        return cls.from_bytes(Path(path).read_bytes())
