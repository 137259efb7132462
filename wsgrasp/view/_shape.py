"""The gripper as its shape, for pictures: the URDF's collision geometry at a
joint posture as one triangle mesh in the gripper frame, or, where the URDF is
not at hand (a gripper no plugin here registers), the body superellipsoids the
planner checks collisions with."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.gripper.model import GripperModel

__all__ = ["GripperShape", "gripper_shape", "posed"]

Array = NDArray[np.float64]

#: a mesh of more faces is drawn as its convex hull (collision meshes are coarse
#: already; this keeps a page small and matplotlib quick)
MAX_FACES = 800
#: icosphere subdivisions of a URDF sphere (80 faces instead of trimesh's 1,280)
SPHERE_SUBDIVISIONS = 1


@dataclass
class GripperShape:
    """Triangles of the gripper in the gripper frame.

    Attributes
    ----------
    vertices : (V, 3) float
    faces : (F, 3) int
    source : str
        ``"urdf"`` (collision geometry at the posture) or ``"superellipsoids"``
        (the planner's body model; fingers not posed).
    """

    vertices: Array
    faces: NDArray[np.int64]
    source: str


def _urdf_kinematics(
    model: GripperModel, ref: str | None = None
) -> tuple[Any, str] | None:
    """The gripper's URDF kinematics and base link, found through ``ref`` (the
    run's spec's ``gripper``: a registered name or a gripper YAML) or else the
    plugin that registers its name; None where neither finds it."""
    from wsgrasp.errors import WsgraspError
    from wsgrasp.gripper import resolve_gripper
    from wsgrasp.gripper._build import urdf_path
    from wsgrasp.gripper._urdf import load_kinematics

    try:
        found = resolve_gripper(ref or model.name)
    except WsgraspError:
        if ref is None:
            return None
        return _urdf_kinematics(model)
    if isinstance(found, GripperModel):
        return None
    desc, base_dir = found
    if desc.base_link != model.description.get("base_link", desc.base_link):
        return None  # another gripper of the same name
    try:
        kin = load_kinematics(urdf_path(desc, base_dir), desc.name)
    except WsgraspError:
        return None
    return kin, desc.base_link


def _link_mesh(shape: Any) -> Any:
    import trimesh

    from wsgrasp.gripper._urdf import shape_mesh

    if shape.kind == "sphere":
        mesh = trimesh.creation.icosphere(
            subdivisions=SPHERE_SUBDIVISIONS, radius=shape.size[0]
        )
        mesh.apply_transform(shape.T_link_shape)
        return mesh
    mesh = shape_mesh(shape)
    return mesh.convex_hull if len(mesh.faces) > MAX_FACES else mesh


def gripper_shape(
    model: GripperModel,
    posture: dict[str, float] | None = None,
    ref: str | None = None,
) -> GripperShape:
    """The gripper's surface at ``posture`` (actuated joint → position; the
    model's pre-grasp posture by default), in the gripper frame.

    Parameters
    ----------
    model
        The gripper model (from a run, or built).
    posture
        Joint positions; joints left out stay at the pre-grasp posture.
    ref
        The gripper as the run's spec names it (a registered name or a gripper
        YAML), where its URDF is looked for first.

    Returns
    -------
    GripperShape
    """
    found = _urdf_kinematics(model, ref)
    if found is not None:
        kin, base = found
        masters = {**model.pregrasp, **(posture or {})}
        poses = kin.link_poses(base, masters)
        verts, faces, n = [], [], 0
        for link, T in poses.items():
            for shape in kin.shapes.get(link, []):
                mesh = _link_mesh(shape)
                v = np.asarray(mesh.vertices, dtype=np.float64)  # (v, 3) link frame
                verts.append(v @ T[:3, :3].T + T[:3, 3])
                faces.append(np.asarray(mesh.faces, dtype=np.int64) + n)
                n += len(v)
        if verts:
            return GripperShape(np.concatenate(verts), np.concatenate(faces), "urdf")
    return _superellipsoid_shape(model)


def _superellipsoid_shape(model: GripperModel) -> GripperShape:
    """The body superellipsoids as one mesh (a grid of each surface, split
    into triangles)."""
    from wsgrasp.geometry import superellipsoid_surface

    verts, faces, n = [], [], 0
    for c, a in zip(model.se_centers, model.se_semi_axes, strict=True):
        X, Y, Z = superellipsoid_surface(
            c, a, model.se_exponent, n_around=16, n_height=8
        )
        rows, cols = X.shape
        verts.append(np.stack([X, Y, Z], axis=-1).reshape(-1, 3))  # (r*c, 3)
        i, j = np.meshgrid(np.arange(rows - 1), np.arange(cols - 1), indexing="ij")
        k = (i * cols + j).ravel()  # top-left corner of each grid cell
        quads = np.stack([k, k + 1, k + cols + 1, k + cols], axis=1)  # (q, 4)
        tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
        faces.append(tris + n)
        n += rows * cols
    return GripperShape(np.concatenate(verts), np.concatenate(faces), "superellipsoids")


def posed(shape: GripperShape, T_world_gripper: Array) -> Array:
    """``(V, 3)`` vertices of ``shape`` in the world at ``T_world_gripper``."""
    T = np.asarray(T_world_gripper, dtype=np.float64)
    return shape.vertices @ T[:3, :3].T + T[:3, 3]
