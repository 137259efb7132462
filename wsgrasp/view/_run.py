"""A recorded run as a picture a person reads at a glance: the object on its
table, the chosen grasp as the gripper's shape at pre-grasp (open, light) and at
grasp (closed, dark) with the approach between them, the contacts and the
workspace spheres that hold the object, the candidates coloured by outcome, and
for a run without a grasp a few rejected poses of each reason, labelled. Four
viewpoints (matplotlib); every colour drawn is in the legend, once."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from wsgrasp.record import Run

__all__ = ["RunLayers", "run_layers", "REASON_COLOURS", "COLOURS"]

Array = NDArray[np.float64]

#: feasible approach directions drawn at most
MAX_DIRECTIONS = 150
#: rejected poses drawn per reason when a run found no grasp
REJECTED_PER_REASON = 2
#: colour of each candidate outcome: no two alike, none like the table or object
REASON_COLOURS: dict[str, str] = {
    "feasible": "#2ca02c",
    "table_collision": "#8c564b",
    "object_collision": "#d62728",
    "obstacle_collision": "#9467bd",
    "finger_without_contact": "#e6a100",
    "finger_sweeps_table": "#8a8a00",
}
#: colours of everything else that is drawn
COLOURS: dict[str, str] = {
    "scene": "#c7c7c7",
    "table": "#d8cfc0",
    "object": "#1f77b4",
    "obstacles": "#ff7f0e",
    "samples": "#17becf",
    "gripper_grasp": "#3b4252",
    "gripper_pregrasp": "#9fb3c8",
    "approach": "#e377c2",
    "directions": "#98df8a",
    "contacts": "#ffd400",
    "holding": "#00a6a6",
    "other_spheres": "#7fb2e5",
}
#: (elevation, azimuth) in degrees, and the panel titles; the axis each
#: orthographic view looks along (its tick labels would pile up) is hidden
VIEWS = ((25.0, -60.0), (0.0, -90.0), (0.0, 0.0), (89.9, -90.0))
VIEW_NAMES = ("perspective", "front (from -y)", "side (from +x)", "top (from +z)")
DEPTH_AXIS = (None, "y", "x", "z")
#: at most this many scene points are drawn
MAX_SCENE_POINTS = 6000


@dataclass
class RunLayers:
    """What is drawn of a run, world frame.

    Attributes
    ----------
    scene : (n, 3) float
        Downsampled scene (or the inputs), thinned for drawing.
    table, object : (m, 3) float
    obstacles : (k, 3) float
    samples : (ns, 3) float
        Bounding-box sample points.
    candidates : (C, 3) float
        Candidate positions (gripper-workspace centroids).
    reasons : (C,) int
        Code into ``reason_names`` of each candidate.
    gripper : (ng, 3) float
        The gripper cloud at the chosen pose (empty if none).
    spheres, radii : (S, 3), (S,) float
        Workspace spheres at the chosen pose.
    holding : (S,) bool
        Spheres holding object points.
    contacts : (q, 3) float
    T_world_object, T_world_ee : (4, 4) float or None
    approach : (2, 3) float
        Pre-grasp and grasp origins of the chosen pose (empty if none).
    directions : (k, 2, 3) float
        Short strokes along the approach of the feasible candidates.
    shape_grasp, shape_pregrasp : (V, 3) float
        Vertices of the gripper's shape at the grasp (closed posture) and the
        pre-grasp (open posture), world frame; empty if no grasp.
    shape_faces : (F, 3) int
        Triangles of both shapes.
    shape_source : str
        ``"urdf"`` or ``"superellipsoids"`` (see :mod:`wsgrasp.view._shape`).
    T_world_pregrasp : (4, 4) float or None
    rejected : list of (reason, (V, 3) float)
        A few rejected poses of each reason, as the gripper's shape, when no
        grasp was found.
    alternatives : list of (label, (V, 3) float)
        The plan's alternatives (best first), as the open gripper's shape.
    """

    scene: Array
    table: Array
    object: Array
    obstacles: Array
    samples: Array
    candidates: Array
    reasons: NDArray[np.int64]
    reason_names: tuple[str, ...]
    gripper: Array
    spheres: Array
    radii: Array
    holding: NDArray[np.bool_]
    contacts: Array
    T_world_object: Array | None
    T_world_ee: Array | None
    title: str
    notes: list[str] = field(default_factory=list)
    approach: Array = field(default_factory=lambda: np.zeros((0, 3)))
    directions: Array = field(default_factory=lambda: np.zeros((0, 2, 3)))
    shape_grasp: Array = field(default_factory=lambda: np.zeros((0, 3)))
    shape_pregrasp: Array = field(default_factory=lambda: np.zeros((0, 3)))
    shape_faces: NDArray[np.int64] = field(
        default_factory=lambda: np.zeros((0, 3), dtype=np.int64)
    )
    shape_source: str = ""
    T_world_pregrasp: Array | None = None
    rejected: list[tuple[str, Array]] = field(default_factory=list)
    alternatives: list[tuple[str, Array]] = field(default_factory=list)


def _pts(x: Any) -> Array:
    if x is None:
        return np.zeros((0, 3))
    if isinstance(x, list):
        parts = [np.asarray(p, dtype=np.float64).reshape(-1, 3) for p in x]
        return np.concatenate(parts) if parts else np.zeros((0, 3))
    return np.asarray(x, dtype=np.float64).reshape(-1, 3)


def _thin(points: Array, n: int) -> Array:
    if len(points) <= n:
        return points
    idx = np.linspace(0, len(points) - 1, n).astype(np.int64)
    return points[idx]


def run_layers(run: Run) -> RunLayers:
    """Collect the drawable layers of a run (also of a truncated one)."""
    from wsgrasp.errors import RecordingError
    from wsgrasp.planning.result import REASONS

    notes: list[str] = []
    pre = run.stages.get("preprocess", {})
    seg = run.stages.get("segmentation", {})
    frame = run.stages.get("object_frame", {})
    # where the spec's sampling found no grasp, the candidates are its fallback's
    sampled = run.stages.get("fallback") or frame
    if "points" in pre:
        scene = _pts(pre["points"])
    elif run.inputs is not None:
        scene = _pts(run.inputs["points"])
    else:
        scene = np.zeros((0, 3))
    cs = run.candidates
    if cs is not None and len(cs):
        cands = np.asarray(cs.T_world_gwc)[:, :3, 3]  # (C, 3)
        reasons = np.asarray(cs.reason, dtype=np.int64)
    else:
        cands, reasons = np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
    res = run.result
    model = None
    try:
        model = run.gripper
    except RecordingError:
        if res is not None:
            notes.append("no gripper model in the file")
    gripper_pts = np.zeros((0, 3))
    spheres, radii = np.zeros((0, 3)), np.zeros(0)
    holding = np.zeros(0, dtype=bool)
    contacts = np.zeros((0, 3))
    T_ee = None
    if res is not None and res.found and res.T_world_ee is not None:
        T_ee = np.asarray(res.T_world_ee, dtype=np.float64)
        if model is not None:
            g = model
            R, t = T_ee[:3, :3], T_ee[:3, 3]
            gripper_pts = np.asarray(g.cloud) @ R.T + t  # (ng, 3)
            spheres = np.asarray(g.sphere_centers) @ R.T + t  # (S, 3)
            radii = np.asarray(g.sphere_radii, dtype=np.float64)
            holding = np.zeros(len(spheres), dtype=bool)
            for c in res.contacts:
                holding[np.asarray(c.spheres, dtype=np.int64)] = True
        contacts = _pts([c.points for c in res.contacts])
    if run.truncated:
        notes.append("truncated: missing " + (", ".join(run.missing) or "the index"))
    if run.error is not None:
        notes.append(f"failed: {run.error.get('type')}: {run.error.get('message')}")
    status = (
        "grasp found"
        if res is not None and res.found
        else ("no grasp found" if res is not None else run.status)
    )
    T_obj = frame.get("T_world_object")
    approach = np.zeros((0, 3))
    if res is not None and T_ee is not None and res.T_world_pregrasp is not None:
        approach = np.stack([np.asarray(res.T_world_pregrasp)[:3, 3], T_ee[:3, 3]])
    directions = np.zeros((0, 2, 3))
    obj = _pts(seg.get("object_points"))
    if cs is not None and len(cs) and len(obj):
        ok = np.flatnonzero(np.asarray(cs.reason) == 0)
        ok = ok[:: max(1, len(ok) // MAX_DIRECTIONS)]
        T = np.asarray(cs.T_world_gwc)[ok]  # (k, 4, 4)
        stroke = 0.25 * float(np.ptp(obj, axis=0).max())
        directions = np.stack([T[:, :3, 3] - stroke * T[:, :3, 2], T[:, :3, 3]], 1)
    ref = (run.spec_data or {}).get("gripper")
    shapes = _shapes(model, res, cs, T_ee, ref if isinstance(ref, str) else None)
    if shapes.get("source") == "superellipsoids":
        notes.append("gripper drawn as its body superellipsoids (URDF not found)")
    mode = None if res is None else res.info.get("sampling_mode")
    if res is not None and mode:
        notes.append(
            f"sampling {mode}: {res.info.get('orientations')} orientations, "
            f"{len(cands)} candidates"
        )
    if run.stages.get("fallback"):
        notes.append("the spec's sampling found no grasp: sampling.fallback's")
    return RunLayers(
        scene=_thin(scene, MAX_SCENE_POINTS),
        table=_thin(_pts(seg.get("table_points")), MAX_SCENE_POINTS // 2),
        object=obj,
        obstacles=_pts(seg.get("obstacles")),
        samples=_pts(sampled.get("samples_world")),
        candidates=cands,
        reasons=reasons,
        reason_names=tuple(REASONS),
        gripper=gripper_pts,
        spheres=spheres,
        radii=radii,
        holding=holding,
        contacts=contacts,
        T_world_object=None if T_obj is None else np.asarray(T_obj, dtype=np.float64),
        T_world_ee=T_ee,
        title=f"{run.path.name}: {status}",
        notes=notes,
        approach=approach,
        directions=directions,
        shape_grasp=shapes.get("grasp", np.zeros((0, 3))),
        shape_pregrasp=shapes.get("pregrasp", np.zeros((0, 3))),
        shape_faces=shapes.get("faces", np.zeros((0, 3), dtype=np.int64)),
        shape_source=str(shapes.get("source", "")),
        T_world_pregrasp=(
            None
            if res is None or T_ee is None or res.T_world_pregrasp is None
            else np.asarray(res.T_world_pregrasp, dtype=np.float64)
        ),
        rejected=shapes.get("rejected", []),
        alternatives=shapes.get("alternatives", []),
    )


def _shapes(
    model: Any, res: Any, cs: Any, T_ee: Array | None, ref: str | None = None
) -> dict[str, Any]:
    """The gripper's shape at grasp and pre-grasp, at the alternatives, and at a
    few rejected poses of each reason (no grasp), world frame."""
    from wsgrasp.planning.result import REASONS
    from wsgrasp.view._shape import gripper_shape, posed

    if model is None or res is None:
        return {}
    out: dict[str, Any] = {}
    open_shape = gripper_shape(model, res.joints_pregrasp or None, ref)
    out["faces"] = open_shape.faces
    out["source"] = open_shape.source
    if res.found and T_ee is not None:
        closed = gripper_shape(model, res.joints_grasp or model.closed, ref)
        out["grasp"] = posed(closed, T_ee)
        pre = res.T_world_pregrasp if res.T_world_pregrasp is not None else T_ee
        out["pregrasp"] = posed(open_shape, pre)
        out["alternatives"] = [
            (f"#{a.index}: score {a.score:.3f}", posed(open_shape, a.T_world_ee))
            for a in res.alternatives
        ]
    elif cs is not None and len(cs):
        reasons = np.asarray(cs.reason, dtype=np.int64)
        T_all = np.asarray(cs.T_world_ee)  # (C, 4, 4)
        rejected = []
        for code, reason in enumerate(REASONS):
            idx = np.flatnonzero(reasons == code)
            if code == 0 or not len(idx):
                continue
            # spread over the candidates of this reason: first, middle, ...
            pick = idx[np.linspace(0, len(idx) - 1, REJECTED_PER_REASON).astype(int)]
            for i in np.unique(pick):
                rejected.append((reason, posed(open_shape, T_all[i])))
        out["rejected"] = rejected
    return out


def _focus(layers: RunLayers) -> tuple[Array, float]:
    """Centre and half-size of the drawn box: around the object and the gripper
    at grasp and pre-grasp."""
    parts = [
        p
        for p in (
            layers.object,
            layers.gripper,
            layers.samples,
            layers.shape_grasp,
            layers.shape_pregrasp,
            *(verts for _, verts in layers.rejected),
        )
        if len(p)
    ]
    if not parts:
        parts = [layers.scene] if len(layers.scene) else [np.zeros((1, 3))]
    pts = np.concatenate(parts)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    return (lo + hi) / 2.0, max(float((hi - lo).max()) / 2.0 * 1.3, 0.05)


def _sphere_wire(c: Array, r: float, n: int = 10) -> tuple[Array, Array, Array]:
    u = np.linspace(0, 2 * np.pi, n)
    v = np.linspace(0, np.pi, n // 2 + 1)
    x = c[0] + r * np.outer(np.cos(u), np.sin(v))
    y = c[1] + r * np.outer(np.sin(u), np.sin(v))
    z = c[2] + r * np.outer(np.ones_like(u), np.cos(v))
    return x, y, z
