"""A trial drawn step by step: what the gripper and the objects did.

``execute_grasp(..., film=True)`` keeps a :class:`Frame` at each step of the
protocol (the pre-grasp pose, the grasp pose, a third and two thirds into the
closing, closed, lifted, held, after each disturbance). A frame holds the world
pose of every geom of the gripper and the objects as MuJoCo simulated them, so
:func:`draw_film` draws the world's own collision geometry (meshes as MuJoCo
keeps them, boxes, spheres, capsules, cylinders, ellipsoids), whatever the
gripper and however its URDF was repaired for the simulator. The table is drawn
as its top, the plane z = 0.

The picture shows what numbers cannot: a finger that pushes the object across
the table before the others arrive, fingertips that ride up over a low object
as the hand closes into a fist, an object turning in the grip under a pull.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["Film", "Frame", "FilmGeometry", "draw_film", "film_geometry", "snapshot"]

Array = NDArray[np.float64]

#: colours of the gripper, the target object and any other object
GRIPPER_COLOUR, OBJECT_COLOUR, OTHER_COLOUR = "#8c8c8c", "#d62728", "#1f77b4"
#: icosphere subdivisions of spheres and ellipsoids (80 faces)
_SPHERE_SUBDIVISIONS = 1
#: faces of a cylinder's side
_SECTIONS = 12


@dataclass(frozen=True)
class Frame:
    """The world at one step of a trial.

    Attributes
    ----------
    label : str
        The step (``"pre-grasp"``, ``"closing 33 %"``, ``"pulled +x"``, ...).
    time : float
        Simulated time (s).
    xpos : (g, 3) float
        World position of each drawn geom (:attr:`FilmGeometry.geoms` order).
    xmat : (g, 3, 3) float
        World orientation of each drawn geom.
    """

    label: str
    time: float
    xpos: Array
    xmat: Array


@dataclass(frozen=True)
class FilmGeometry:
    """The drawn geoms of a MuJoCo world: each one's triangles in its own frame
    and its colour.

    Attributes
    ----------
    geoms : (g,) int
        Geom ids: every geom that is not the world's (the table).
    vertices, faces : list of arrays
        Per drawn geom, ``(v, 3)`` float and ``(f, 3)`` int.
    colours : list of str
    target : (t,) int
        The drawn geoms (positions in ``geoms``) of the target object.
    """

    geoms: NDArray[np.int64]
    vertices: list[Array]
    faces: list[NDArray[np.int64]]
    colours: list[str]
    target: NDArray[np.int64]


@dataclass(frozen=True)
class Film:
    """A filmed trial: what is drawn, the world at each step, and the closing
    direction the views are turned by.

    Attributes
    ----------
    geometry : FilmGeometry
    frames : list of Frame
    closing : (3,) float
        The gripper's closing direction (world) at its executed grasp pose.
    """

    geometry: FilmGeometry
    frames: list[Frame]
    closing: Array


def film_geometry(model: Any, object_body: int, gripper_bodies: Any) -> FilmGeometry:
    """The geometry :func:`draw_film` draws for the MuJoCo ``model``: geoms of
    the target ``object_body`` in red, of the gripper's bodies grey, of any
    other body blue; planes and height fields are left out."""
    import mujoco

    T = mujoco.mjtGeom
    grip = np.zeros(model.nbody, dtype=bool)
    grip[np.asarray(gripper_bodies, dtype=np.int64)] = True
    ids: list[int] = []
    target: list[int] = []
    verts: list[Array] = []
    faces: list[NDArray[np.int64]] = []
    colours: list[str] = []
    for i in range(model.ngeom):
        body = int(model.geom_bodyid[i])
        kind = int(model.geom_type[i])
        if body == 0 or kind in (int(T.mjGEOM_PLANE), int(T.mjGEOM_HFIELD)):
            continue
        shape = _geom_mesh(model, i, kind)
        if shape is None:
            continue
        if body == object_body:
            target.append(len(ids))
        ids.append(i)
        verts.append(shape[0])
        faces.append(shape[1])
        colours.append(
            OBJECT_COLOUR
            if body == object_body
            else GRIPPER_COLOUR
            if grip[body]
            else OTHER_COLOUR
        )
    return FilmGeometry(
        np.asarray(ids, dtype=np.int64),
        verts,
        faces,
        colours,
        np.asarray(target, dtype=np.int64),
    )


def _geom_mesh(model: Any, i: int, kind: int) -> tuple[Array, NDArray[np.int64]] | None:
    """Geom ``i``'s triangles in its own frame, or None for a kind not drawn."""
    import mujoco

    from wsgrasp.geometry import primitive_mesh

    T = mujoco.mjtGeom
    size = np.asarray(model.geom_size[i], dtype=np.float64)
    if kind == int(T.mjGEOM_MESH):
        m = int(model.geom_dataid[i])
        v0, nv = int(model.mesh_vertadr[m]), int(model.mesh_vertnum[m])
        f0, nf = int(model.mesh_faceadr[m]), int(model.mesh_facenum[m])
        v = np.asarray(model.mesh_vert[v0 : v0 + nv], dtype=np.float64)
        return v, np.asarray(model.mesh_face[f0 : f0 + nf], dtype=np.int64)
    # MuJoCo gives half sizes: a box's half extents, a capsule's or a
    # cylinder's radius and half length
    shapes: dict[int, tuple[str, Any]] = {
        int(T.mjGEOM_BOX): ("box", 2.0 * size),
        int(T.mjGEOM_SPHERE): ("sphere", size[:1]),
        int(T.mjGEOM_ELLIPSOID): ("ellipsoid", size),
        int(T.mjGEOM_CAPSULE): ("capsule", [size[0], 2.0 * size[1]]),
        int(T.mjGEOM_CYLINDER): ("cylinder", [size[0], 2.0 * size[1]]),
    }
    if kind not in shapes:
        return None
    name, dims = shapes[kind]
    mesh = primitive_mesh(
        name, dims, subdivisions=_SPHERE_SUBDIVISIONS, sections=_SECTIONS
    )
    return (
        np.asarray(mesh.vertices, dtype=np.float64),
        np.asarray(mesh.faces, dtype=np.int64),
    )


def snapshot(data: Any, geometry: FilmGeometry, label: str) -> Frame:
    """The drawn geoms' world poses in MuJoCo's ``data`` now."""
    g = geometry.geoms
    return Frame(
        label,
        float(data.time),
        np.array(data.geom_xpos[g], dtype=np.float64),
        np.array(data.geom_xmat[g], dtype=np.float64).reshape(-1, 3, 3),
    )


def draw_film(film: Film, path: str | Path, *, title: str = "", dpi: int = 80) -> Path:
    """Draw a filmed trial into a PNG: a column per frame, two rows of views.
    The top row looks across the gripper's closing direction, so the fingers
    close left and right; the bottom row looks along it.

    Parameters
    ----------
    film
        From a filmed :func:`~wsgrasp.sim.trial.execute_grasp`
        (``Execution.film``).
    path
        Output ``.png``.
    title
        Printed above the frames (the trial and its outcome).
    dpi
        Resolution.

    Returns
    -------
    Path
        The file written.
    """
    from wsgrasp.view._png import pyplot

    plt = pyplot()
    frames, geometry = film.frames, film.geometry
    c = np.array(film.closing, dtype=np.float64)
    c[2] = 0.0
    if np.linalg.norm(c) < 1e-6:
        c = np.array([1.0, 0.0, 0.0])
    # the azimuth of a camera looking across the closing direction, then along it
    across = float(np.degrees(np.arctan2(c[1], c[0]))) - 90.0
    views = ((across, 12.0), (across + 90.0, 12.0))
    half = _half_edge(geometry)
    n = max(len(frames), 1)
    fig = plt.figure(figsize=(2.4 * n, 5.2))
    for k, frame in enumerate(frames):
        world = _posed(frame, geometry)
        # the object a little below the middle: the gripper comes from above
        centre = _centre(frame, geometry) + np.array([0.0, 0.0, 0.4 * half])
        for row, (azim, elev) in enumerate(views):
            ax = fig.add_subplot(2, n, row * n + k + 1, projection="3d")
            _panel(ax, world, geometry, centre, half, azim, elev)
            if row == 0:
                ax.set_title(f"{frame.label}\n{frame.time:.2f} s", fontsize=9)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.subplots_adjust(left=0.0, right=1.0, bottom=0.0, top=0.86, wspace=0, hspace=0)
    out = Path(path)
    fig.savefig(out, dpi=dpi)
    plt.close(fig)
    return out


def _posed(frame: Frame, geometry: FilmGeometry) -> list[Array]:
    """Each drawn geom's vertices in the world at ``frame``."""
    return [
        v @ R.T + t
        for v, R, t in zip(geometry.vertices, frame.xmat, frame.xpos, strict=True)
    ]


#: the least half edge (m) of the cube each frame shows
_MIN_HALF = 0.1


def _target(geometry: FilmGeometry) -> NDArray[np.int64]:
    """The drawn geoms of the target object (all of them without one)."""
    if len(geometry.target):
        return geometry.target
    return np.arange(len(geometry.geoms))


def _centre(frame: Frame, geometry: FilmGeometry) -> Array:
    """Where a frame looks: at the target object, wherever it is then."""
    if not len(frame.xpos):
        return np.zeros(3)
    return np.asarray(frame.xpos[_target(geometry)].mean(axis=0))


def _half_edge(geometry: FilmGeometry) -> float:
    """Half the edge (m) of the cube every frame shows: the target object with
    room around it for the fingers, at least :data:`_MIN_HALF`."""
    reach = [float(np.abs(geometry.vertices[i]).max()) for i in _target(geometry)]
    reach = reach or [0.0]
    return max(_MIN_HALF, 2.0 * max(reach))


def _panel(
    ax: Any,
    world: list[Array],
    geometry: FilmGeometry,
    centre: Array,
    half: float,
    azim: float,
    elev: float,
) -> None:
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from wsgrasp.view._png import _shaded

    # the table's top around the scene
    x0, y0 = centre[0] - half, centre[1] - half
    x1, y1 = centre[0] + half, centre[1] + half
    top = np.array([[[x0, y0, 0.0], [x1, y0, 0.0], [x1, y1, 0.0], [x0, y1, 0.0]]])
    # the table first, under everything; the geoms' faces sorted by depth together
    ax.computed_zorder = False
    ax.add_collection3d(
        Poly3DCollection(top, facecolors=(0.78, 0.82, 0.9, 1.0), edgecolors="none")
    )
    tris = [v[f] for v, f in zip(world, geometry.faces, strict=True)]
    rgba = [
        _shaded(v, f, colour)
        for v, f, colour in zip(world, geometry.faces, geometry.colours, strict=True)
    ]
    if tris:
        faces = Poly3DCollection(
            np.concatenate(tris), facecolors=np.concatenate(rgba), edgecolors="none"
        )
        try:  # what lies outside the frame's cube is cut off (matplotlib 3.10+)
            ax.add_collection3d(faces, axlim_clip=True)
        except TypeError:
            ax.add_collection3d(faces)
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=elev, azim=azim)
    ax.set_axis_off()
