"""Synthetic scenes: objects on a table seen by virtual depth cameras.

The world frame of a synthetic scene has z up and the table top at z = 0. Cameras
are pinhole depth sensors in the OpenCV convention (z forward, x right, y down),
rendered by open3d ray casting; depth gets Gaussian noise. ``render_scene`` and
``default_cameras`` are the reusable core (the physics evaluation renders with the
same camera model); ``synth_scene`` builds a whole scene from a primitive's name.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from wsgrasp.errors import InputError
from wsgrasp.geometry import (
    invert_transforms,
    primitive_mesh,
    transform_from,
    transform_points,
)
from wsgrasp.perception.types import Array, Plane, View

if TYPE_CHECKING:
    from wsgrasp.perception.depth import Intrinsics

__all__ = [
    "OBJECTS",
    "Camera",
    "SynthScene",
    "default_cameras",
    "look_at",
    "make_object",
    "object_pose",
    "render_scene",
    "synth_scene",
]

#: primitives make_object knows, with their default sizes (m)
OBJECTS: dict[str, tuple[float, ...]] = {
    "box": (0.06, 0.08, 0.16),  # x, y, z extents
    "cylinder": (0.04, 0.10),  # radius, height
    "cone": (0.04, 0.12),  # base radius, height
    "ring": (0.03, 0.05, 0.02),  # inner radius, outer radius, height
    "sphere": (0.04,),  # radius
}
Pose = Literal["upright", "lying", "random"]


@dataclass
class Camera:
    """A pinhole depth camera (OpenCV axes: z forward, x right, y down).

    Attributes
    ----------
    T_world_camera : (4, 4) float
    width, height : int
        Image size in pixels.
    fx, fy, cx, cy : float
        Intrinsics in pixels.
    """

    T_world_camera: Array
    width: int = 320
    height: int = 240
    fx: float = 277.0
    fy: float = 277.0
    cx: float = 159.5
    cy: float = 119.5

    @classmethod
    def from_fov(
        cls, T_world_camera: ArrayLike, width: int, height: int, fov_deg: float = 60.0
    ) -> Camera:
        """A camera with square pixels and horizontal field of view ``fov_deg``."""
        f = (width / 2.0) / np.tan(np.radians(fov_deg) / 2.0)
        return cls(
            np.asarray(T_world_camera, dtype=np.float64),
            width,
            height,
            f,
            f,
            (width - 1) / 2.0,
            (height - 1) / 2.0,
        )

    def depth_image(self, points: ArrayLike, lens: Intrinsics | None = None) -> Array:
        """The depth image ``(height, width)`` (m) of ``points`` ``(n, 3)`` in this
        camera's frame: each point at its nearest pixel, the nearest point where
        several share one, 0 where none is (as a depth camera writes a pixel
        without depth). With a ``lens`` (its distortion; this camera's ``fx``,
        ``fy``, ``cx``, ``cy``), the raw image that lens bends: each point where
        the lens puts its ray."""
        p = np.asarray(points, dtype=np.float64)
        z = p[:, 2]
        front = z > 0.0
        p, z = p[front], z[front]
        x, y = p[:, 0] / z, p[:, 1] / z
        if lens is not None:
            x, y = lens.distort(x, y)
        u = np.rint(self.fx * x + self.cx).astype(np.int64)
        v = np.rint(self.fy * y + self.cy).astype(np.int64)
        on = (u >= 0) & (u < self.width) & (v >= 0) & (v < self.height)
        image = np.full((self.height, self.width), np.inf)
        np.minimum.at(image, (v[on], u[on]), z[on])
        image[np.isinf(image)] = 0.0
        return image

    def ray_directions(self) -> Array:
        """Ray directions ``(h*w, 3)`` in the camera frame with unit z, so a hit
        distance along them is the depth."""
        u, v = np.meshgrid(np.arange(self.width), np.arange(self.height))
        d = np.stack(
            [(u - self.cx) / self.fx, (v - self.cy) / self.fy, np.ones(u.shape)],
            axis=-1,
        )  # (h, w, 3)
        return d.reshape(-1, 3)  # (h*w, 3)


def look_at(eye: ArrayLike, target: ArrayLike, up: ArrayLike = (0, 0, 1)) -> Array:
    """``T_world_camera`` ``(4, 4)`` of a camera at ``eye`` looking at ``target``
    (OpenCV axes; image "up" towards ``up``)."""
    e = np.asarray(eye, dtype=np.float64)
    z = np.asarray(target, dtype=np.float64) - e
    z /= np.linalg.norm(z)
    u = np.asarray(up, dtype=np.float64)
    if abs(float(u @ z)) > 0.999:
        u = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0, 1.0, 0])
    x = np.cross(z, u)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)  # image y points down, away from `up`
    return transform_from(np.stack([x, y, z], axis=1), e)


def default_cameras(
    n: int,
    target: ArrayLike = (0.0, 0.0, 0.05),
    distance: float = 0.55,
    elevation: float = np.radians(45.0),
    rng: np.random.Generator | None = None,
    *,
    width: int = 320,
    height: int = 240,
    fov_deg: float = 60.0,
) -> list[Camera]:
    """``n`` cameras around ``target`` at ``distance`` (m) and ``elevation`` (rad)
    above the table plane, evenly spread in azimuth; ``rng`` jitters azimuth
    (±15°), elevation (±5°) and distance (±5 %)."""
    if n < 1:
        raise InputError(
            f"views is {n}, expected at least 1", hint="render 1 to 8 views, e.g. 3"
        )
    t = np.asarray(target, dtype=np.float64)
    az = np.arange(n) * (2.0 * np.pi / n) + np.radians(30.0)
    el = np.full(n, float(elevation))
    dist = np.full(n, float(distance))
    if rng is not None:
        az = az + rng.uniform(-1, 1, n) * np.radians(15.0)
        el = el + rng.uniform(-1, 1, n) * np.radians(5.0)
        dist = dist * (1.0 + rng.uniform(-0.05, 0.05, n))
    # (n, 3) camera positions on a sphere around the target
    eyes = t + dist[:, None] * np.stack(
        [np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=1
    )
    return [Camera.from_fov(look_at(e, t), width, height, fov_deg) for e in eyes]


# --------------------------------------------------------------------------------
# objects
# --------------------------------------------------------------------------------
def make_object(kind: str, size: Sequence[float] | None = None) -> Any:
    """A ``trimesh.Trimesh``: a primitive from ``OBJECTS`` (centred, its axis or
    longest side along z) or a mesh file (PLY/STL/OBJ/...)."""
    import trimesh

    if kind not in OBJECTS:
        path = Path(kind)
        if not path.exists():
            raise InputError(
                f"object {kind!r} is neither a primitive ({', '.join(OBJECTS)}) nor "
                "an existing mesh file",
                hint="pass --object box, or a path to an STL/OBJ/PLY mesh in metres",
            )
        mesh = trimesh.load(path, force="mesh")
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            raise InputError(
                f"mesh file {kind!r} has no triangles",
                hint="export the object as a triangle mesh",
            )
        mesh = mesh.copy()
        mesh.apply_translation(-mesh.bounds.mean(axis=0))
        if float(np.max(mesh.extents)) > 2.0:
            raise InputError(
                f"mesh {kind!r} is {np.max(mesh.extents):.4g} units across; "
                "probably millimetres",
                hint="scale the mesh to metres (divide by 1000)",
            )
        return mesh
    dims = tuple(OBJECTS[kind] if not size else size)
    need = len(OBJECTS[kind])
    if len(dims) != need or min(dims) <= 0:
        raise InputError(
            f"--size for {kind} needs {need} positive numbers (m), found {list(dims)}",
            hint=f"e.g. --size {','.join(f'{v:g}' for v in OBJECTS[kind])}",
        )
    if kind in ("box", "cylinder", "sphere"):
        return primitive_mesh(kind, dims, subdivisions=3, sections=48)
    if kind == "cone":
        m = trimesh.creation.cone(radius=dims[0], height=dims[1], sections=48)
        m.apply_translation([0, 0, -dims[1] / 2.0])
        return m
    if kind == "ring":
        if dims[0] >= dims[1]:
            raise InputError(
                f"ring inner radius {dims[0]} must be below outer radius {dims[1]}",
                hint="--size INNER,OUTER,HEIGHT",
            )
        return trimesh.creation.annulus(r_min=dims[0], r_max=dims[1], height=dims[2])
    raise ValueError(f"unknown object kind {kind!r}")  # OBJECTS holds no other


def object_pose(mesh: Any, pose: Pose, rng: np.random.Generator) -> Array:
    """``T_world_mesh`` putting the mesh on the table (z = 0) at the origin:
    upright (its z up), lying (its z along world x, turned about z at random) or a
    random orientation."""
    from scipy.spatial.transform import Rotation

    yaw = rng.uniform(0.0, 2.0 * np.pi)
    Rz = Rotation.from_rotvec([0.0, 0.0, yaw])
    if pose == "upright":
        R = Rz
    elif pose == "lying":
        R = Rz * Rotation.from_rotvec([0.0, np.pi / 2.0, 0.0])
    elif pose == "random":
        R = Rotation.random(random_state=rng)
    else:
        raise InputError(
            f"pose {pose!r} is unknown, expected upright, lying or random",
            hint="pass --pose upright",
        )
    Rm = R.as_matrix()
    v = np.asarray(mesh.vertices) @ Rm.T
    return transform_from(Rm, [0.0, 0.0, -float(v[:, 2].min())])


# --------------------------------------------------------------------------------
# rendering
# --------------------------------------------------------------------------------
def render_scene(
    meshes_with_poses: Sequence[tuple[Any, ArrayLike]],
    table_size: float | None,
    cameras: Sequence[Camera],
    noise: float,
    rng: np.random.Generator,
    flying: float = 0.0,
) -> list[View]:
    """Render depth views of meshes on a table.

    Parameters
    ----------
    meshes_with_poses
        ``(trimesh.Trimesh, T_world_mesh (4, 4))`` pairs.
    table_size
        Side (m) of a square table whose top is the plane z = 0 of the world, 2 cm
        thick; None for no table.
    cameras
        Virtual depth cameras.
    noise
        Standard deviation (m) of the Gaussian depth noise.
    rng
        For the noise and the flying pixels.
    flying
        Share (0-1) of the pixels along depth edges that come back as flying
        pixels (:func:`flying_pixels`), as a time-of-flight or stereo camera's
        raw depth does; 0 for none.

    Returns
    -------
    list of View
        Each view's hit points ``(n_i, 3)`` in its camera frame and its pose.
    """
    from wsgrasp._open3d import load_open3d

    o3d = load_open3d()
    import trimesh

    scene = o3d.t.geometry.RaycastingScene()
    parts = [(m, np.asarray(T, dtype=np.float64)) for m, T in meshes_with_poses]
    if table_size is not None:
        table = trimesh.creation.box(extents=(table_size, table_size, 0.02))
        parts.append((table, transform_from(None, [0.0, 0.0, -0.01])))
    for mesh, T in parts:
        v = transform_points(T, np.asarray(mesh.vertices, dtype=np.float64))
        scene.add_triangles(
            o3d.core.Tensor.from_numpy(v.astype(np.float32)),
            o3d.core.Tensor.from_numpy(np.asarray(mesh.faces, dtype=np.uint32)),
        )
    views = []
    for i, cam in enumerate(cameras):
        d_cam = cam.ray_directions()  # (h*w, 3), unit z
        R = cam.T_world_camera[:3, :3]
        origin = np.broadcast_to(cam.T_world_camera[:3, 3], d_cam.shape)
        rays = np.concatenate([origin, d_cam @ R.T], axis=1)  # (h*w, 6) world
        hit = scene.cast_rays(o3d.core.Tensor.from_numpy(rays.astype(np.float32)))
        depth = hit["t_hit"].numpy().astype(np.float64)  # (h*w,), inf for misses
        if flying > 0:
            depth = flying_pixels(depth.reshape(cam.height, cam.width), flying, rng)
            depth = depth.reshape(-1)
        ok = np.isfinite(depth)
        z = (
            depth[ok] + rng.normal(0.0, noise, int(ok.sum()))
            if noise > 0
            else depth[ok]
        )
        points = d_cam[ok] * z[:, None]  # (n_i, 3) camera frame
        views.append(
            View(
                points=points,
                T_world_camera=cam.T_world_camera.copy(),
                name=f"view_{i}",
            )
        )
    return views


#: neighbouring pixels whose depths differ by more than this (m) straddle a
#: depth edge
EDGE_JUMP = 0.02


def flying_pixels(depth: Array, share: float, rng: np.random.Generator) -> Array:
    """A depth image ``(h, w)`` (inf where nothing was hit) with flying pixels:
    of the pixels on either side of a depth edge (a neighbour, across or down,
    more than :data:`EDGE_JUMP` nearer or farther), ``share`` get a depth drawn
    uniformly between the edge's near and far depths, as the mixed returns of a
    time-of-flight camera or a stereo matcher's smeared edges do. Their points
    hang in the air between an object's outline and the surface behind it."""
    d = depth.copy()
    near = np.full(d.shape, np.inf)
    far = np.full(d.shape, -np.inf)
    for a, b in (
        (np.s_[:, :-1], np.s_[:, 1:]),
        (np.s_[:-1, :], np.s_[1:, :]),
    ):
        da, db = depth[a], depth[b]
        edge = np.isfinite(da) & np.isfinite(db)
        edge[edge] = np.abs(da[edge] - db[edge]) > EDGE_JUMP
        lo, hi = np.minimum(da, db), np.maximum(da, db)
        for s in (a, b):
            near[s] = np.where(edge, np.minimum(near[s], lo), near[s])
            far[s] = np.where(edge, np.maximum(far[s], hi), far[s])
    on_edge = np.flatnonzero(
        (np.isfinite(near) & (rng.random(d.shape) < share)).ravel()
    )
    u = rng.random(len(on_edge))
    n, f = near.ravel()[on_edge], far.ravel()[on_edge]
    d.ravel()[on_edge] = n + u * (f - n)
    return d


@dataclass
class SynthScene:
    """A synthetic scene with its ground truth.

    Attributes
    ----------
    views : list of View
    points : (N, 3) float
        Merged views in the scene's world frame.
    T_world_mesh : (4, 4) float
        Object pose.
    table : Plane
        The table top, normal up.
    mesh : trimesh.Trimesh
        The object in its own frame.
    """

    views: list[View]
    points: Array
    T_world_mesh: Array
    table: Plane
    mesh: Any = None
    info: dict[str, Any] = field(default_factory=dict)
    #: the cameras that rendered ``views``, one per view
    cameras: list[Camera] = field(default_factory=list)

    def in_camera_frame(self, index: int = 0) -> SynthScene:
        """The same scene expressed in camera ``index``'s frame (table tilted)."""
        T_cam_world = invert_transforms(self.views[index].T_world_camera)
        views = [
            View(v.points, T_cam_world @ v.T_world_camera, v.name) for v in self.views
        ]
        n = T_cam_world[:3, :3] @ self.table.normal
        o = T_cam_world[:3, 3]
        # plane n·p + d = 0 moved: n' = R n, d' = d - n'·t
        return SynthScene(
            views=views,
            points=transform_points(T_cam_world, self.points),
            T_world_mesh=T_cam_world @ self.T_world_mesh,
            table=Plane(n, float(self.table.offset - n @ o)),
            mesh=self.mesh,
            info={**self.info, "frame": f"camera {index}"},
            cameras=[
                replace(c, T_world_camera=T_cam_world @ c.T_world_camera)
                for c in self.cameras
            ],
        )


def _check_settings(**settings: tuple[float, float, float, bool]) -> None:
    """Each setting's ``(value, low, high, above)``: finite, within ``low``..
    ``high``, and strictly above ``low`` when ``above``."""
    for name, (value, low, high, above) in settings.items():
        ok = math.isfinite(value) and low <= value <= high
        if ok and above and value == low:
            ok = False
        if not ok:
            bound = f"above {low:g}" if above else f"at least {low:g}"
            raise InputError(
                f"synthetic scene setting {name} is {value}, expected a number "
                f"{bound} and at most {high:g}",
                hint=f"give {name} within that range",
            )


def synth_scene(
    kind: str = "box",
    *,
    size: Sequence[float] | None = None,
    pose: Pose = "upright",
    views: int = 3,
    noise: float = 0.001,
    flying: float = 0.0,
    seed: int = 0,
    table_size: float = 0.6,
    width: int = 320,
    height: int = 240,
    distance: float = 0.55,
    elevation_deg: float = 45.0,
    camera_frame: bool = False,
) -> SynthScene:
    """One object on a table, rendered from ``views`` cameras around it.

    ``camera_frame`` expresses the scene in the first camera's frame instead of the
    z-up world frame (the table is then tilted), to test frame independence.
    ``flying`` is the share of depth-edge pixels rendered as flying pixels
    (:func:`flying_pixels`).
    """
    _check_settings(
        noise=(noise, 0.0, 0.1, False),
        flying=(flying, 0.0, 1.0, False),
        table_size=(table_size, 0.0, 10.0, True),
        distance=(distance, 0.0, 20.0, True),
        elevation_deg=(elevation_deg, 0.0, 90.0, True),
        width=(width, 8, 8192, False),
        height=(height, 8, 8192, False),
    )
    rng = np.random.default_rng(seed)
    mesh = make_object(kind, size)
    T = object_pose(mesh, pose, rng)
    height_obj = float(transform_points(T, mesh.vertices)[:, 2].max())
    cams = default_cameras(
        views,
        target=(0.0, 0.0, height_obj / 2.0),
        distance=distance,
        elevation=np.radians(elevation_deg),
        rng=rng,
        width=width,
        height=height,
    )
    rendered = render_scene([(mesh, T)], table_size, cams, noise, rng, flying)
    points = np.concatenate(
        [transform_points(v.T_world_camera, v.points) for v in rendered], axis=0
    )
    out = SynthScene(
        views=rendered,
        points=points,
        T_world_mesh=T,
        table=Plane(np.array([0.0, 0.0, 1.0]), 0.0),
        mesh=mesh,
        info={"object": kind, "pose": pose, "seed": seed, "noise": noise},
        cameras=list(cams),
    )
    return out.in_camera_frame(0) if camera_frame else out
