"""Reading point clouds and scenes.

A scene is one or several views. Accepted inputs:

- one cloud file (PLY, PCD, XYZ/TXT/CSV, NPY, NPZ): its frame is the world frame;
- one depth image (16-bit PNG or TIFF, float TIFF, ``(h, w)`` NPY) with its
  camera's ``intrinsics`` (CLI ``--intrinsics fx,fy,cx,cy``): its camera's frame is
  the world frame (:mod:`wsgrasp.perception.depth`);
- a scene YAML (``.yaml``/``.yml``) listing views, each a cloud file in its camera
  frame, or a depth image with its intrinsics, and the camera pose
  ``T_world_camera``::

      version: 1
      units: m            # m (default), cm, mm or in: clouds and translations
      views:
        - cloud: view_0.npz
          T_world_camera: [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
        - depth: view_1.png          # millimetres unless depth_scale says
          intrinsics: {fx: 615.0, fy: 615.0, cx: 319.5, cy: 239.5}
          T_world_camera: {translation: [0.4, 0, 0.5], quaternion_xyzw: [1, 0, 0, 0]}

- several cloud files only with ``registered=True`` (CLI ``--registered``): they are
  then taken to be in one world frame already. Several clouds without poses are
  otherwise an error, since merging unregistered views gives a wrong object.

NaN and inf points, and points at ``(0, 0, 0)`` (a pixel without depth), are
dropped and counted; empty, all-NaN, wrongly shaped clouds and
clouds whose extents suggest millimetres raise ``InputError``.
"""

from __future__ import annotations

import tokenize
import warnings
import zipfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from wsgrasp.errors import InputError, SpecError
from wsgrasp.geometry import transform_points
from wsgrasp.perception.depth import (
    DEPTH_SUFFIXES,
    Intrinsics,
    depth_points,
    read_depth_image,
)
from wsgrasp.perception.types import Array, Scene, View

__all__ = [
    "CLOUD_SUFFIXES",
    "CameraPose",
    "MAX_SCENE_EXTENT",
    "METRE_SPACING",
    "NUMPY_READ_ERRORS",
    "check_units",
    "check_views_overlap",
    "units_hint",
    "load_cloud",
    "load_scene",
    "read_npy",
    "robust_extent",
    "refine_views_icp",
    "save_cloud",
    "write_scene_yaml",
    "scene_from_arrays",
]

#: cloud file suffixes load_cloud understands
CLOUD_SUFFIXES = (".ply", ".pcd", ".xyz", ".txt", ".csv", ".npy", ".npz")
SCENE_SUFFIXES = (".yaml", ".yml")
#: a scene wider than this (metres, robust extent) is taken to be in millimetres
MAX_SCENE_EXTENT = 20.0
#: a cloud that nothing could be segmented in, wider than this (m), may not be
#: in metres: a tabletop crop spans a metre or two
WIDE_SCENE_EXTENT = 3.0
_UNIT_SCALE = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254}


# --------------------------------------------------------------------------------
# single clouds
# --------------------------------------------------------------------------------
def load_cloud(path: str | Path) -> Array:
    """Read a point cloud file as it is (NaN/inf kept; see ``load_scene``).

    Parameters
    ----------
    path
        PLY (trimesh) or PCD (pypcd4), properties x, y, z read by name,
        XYZ/TXT/CSV (whitespace or comma separated, first three
        columns, ``#`` comments), NPY (``(n, 3)``) or NPZ (key ``points``, or its only
        array).

    Returns
    -------
    (n, 3) float
    """
    p = Path(path)
    if not p.exists():
        raise InputError(
            f"cloud file {str(p)!r} does not exist",
            hint="check the path (relative paths are from the current directory)",
        )
    if p.is_dir():
        raise InputError(
            f"cloud file {str(p)!r} is a directory, expected a file",
            hint="give a cloud file such as scene.ply or scene.npz",
        )
    suffix = p.suffix.lower()
    _check_format(p, suffix)
    if suffix == ".ply":
        arr = _read_ply(p)
    elif suffix == ".pcd":
        arr = _read_pcd(p)
    elif suffix in (".xyz", ".txt", ".csv"):
        arr = _read_text(p)
    elif suffix == ".npy":
        arr = _read_npy(p)
    elif suffix == ".npz":
        arr = _read_npz(p)
    elif suffix in DEPTH_SUFFIXES:
        raise InputError(
            f"{str(p)!r} is an image, not a point cloud; a depth image is "
            "deprojected with its camera's intrinsics",
            hint="pass --intrinsics fx,fy,cx,cy with it, or list it in a scene "
            "YAML as `depth:` with `intrinsics:` (examples/scenes/README.md)",
        )
    else:
        raise InputError(
            f"cloud file {str(p)!r} has unknown format {suffix or '(no suffix)'!r}; "
            f"expected one of {', '.join(CLOUD_SUFFIXES)}",
            hint="convert it to PLY or NPZ, or give a scene YAML (.yaml)",
        )
    return _check_shape(arr, str(p))


#: a file's first bytes, the format they start, and its suffixes
_MAGIC: tuple[tuple[bytes, str, tuple[str, ...]], ...] = (
    (b"ply\n", "PLY", (".ply",)),
    (b"ply\r\n", "PLY", (".ply",)),
    (b"\x93NUMPY", "NumPy .npy", (".npy",)),
    (b"PK\x03\x04", "zip (NumPy .npz)", (".npz",)),
    (b"\x89PNG", "PNG image", (".png",)),
    (b"II*\x00", "TIFF image", (".tif", ".tiff")),
    (b"MM\x00*", "TIFF image", (".tif", ".tiff")),
    (b"\x89MCAP", "MCAP recording", (".mcap",)),
    (b"SQLite format 3", "SQLite database (a ROS 2 bag's .db3)", (".db3",)),
    (b"# .PCD", "PCD", (".pcd",)),
)


def _check_format(p: Path, suffix: str) -> None:
    """Refuse a file whose first bytes say it is another format than its
    suffix (a PLY file named .npy, a PNG named .pcd): read as its suffix says,
    it failed with that reader's puzzling message."""
    try:
        with open(p, "rb") as f:
            head = f.read(16)
    except OSError:
        return  # the reader reports it
    for magic, kind, suffixes in _MAGIC:
        if head.startswith(magic) and suffix not in suffixes:
            raise InputError(
                f"cloud file {str(p)!r} is named {suffix or '(no suffix)'} but its "
                f"first bytes say it is a {kind} file",
                hint=f"rename it to {p.stem}{suffixes[0]}",
            )


def _read_ply(p: Path) -> Array:
    """PLY through trimesh, which reads the vertex properties by name (x, y, z in
    any order, any numeric type) and refuses a binary file shorter than its
    header says; an ASCII file with fewer rows than its header is refused here."""
    import trimesh

    try:
        geometry = trimesh.load(p, file_type="ply", process=False)
    except (ValueError, KeyError, IndexError, TypeError, UnicodeDecodeError) as exc:
        what = str(exc).rstrip("!") or type(exc).__name__
        if isinstance(exc, KeyError):
            what = f"it has no vertex property {exc}"
        elif "not a ply" in what.lower():
            what = "it does not start with a PLY header"
        elif "unexpected length" in what.lower():
            what = "its data is shorter or longer than its header declares (cut short?)"
        raise InputError(
            f"cloud file {str(p)!r} is not a readable PLY point cloud: {what}",
            hint="export it again as PLY with vertex properties x, y, z (metres)",
        ) from None
    arr = np.asarray(getattr(geometry, "vertices", np.zeros((0, 3))), np.float64)
    raw = getattr(geometry, "metadata", {}).get("_ply_raw", {}).get("vertex", {})
    names = list(raw.get("properties", {})) or ["x", "y", "z"]
    _check_declared(p, "vertex properties", names, raw.get("length"), len(arr))
    return arr.reshape(-1, 3)


def _check_declared(
    p: Path, what: str, names: list[str], declared: int | None, found: int
) -> None:
    """A PLY's or PCD's header against what was read: x, y and z among its
    ``names``, and as many points as it ``declared``."""
    fix = f"export it again as {p.suffix.lstrip('.').upper()} with {what} x, y, z"
    if not {"x", "y", "z"} <= set(names):
        raise InputError(
            f"cloud file {str(p)!r} has {what} {names}, not x, y, z",
            hint=f"{fix} (metres)",
        )
    if declared is not None and int(declared) != found:
        raise InputError(
            f"cloud file {str(p)!r} is truncated: its header declares {declared} "
            f"points, the file holds {found}",
            hint="copy or export the file again",
        )


def _read_pcd(p: Path) -> Array:
    """PCD through pypcd4 (ASCII, binary and binary_compressed), fields read by
    name; a file with fewer points than its header says is refused."""
    from pypcd4 import PointCloud

    try:
        cloud = PointCloud.from_path(p)
    except Exception as exc:  # noqa: BLE001 - the reader's failures, reported
        what = f"{type(exc).__name__}: {str(exc)[:200]}"
        if isinstance(exc, UnicodeDecodeError):
            what = "its header is not PCD text"
        raise InputError(
            f"cloud file {str(p)!r} is not a readable PCD file: {what}",
            hint="export it again as PCD with fields x y z (metres)",
        ) from None
    fields = list(cloud.fields)
    _check_declared(p, "fields", fields, None, 0)
    arr = np.asarray(cloud.numpy(("x", "y", "z")), dtype=np.float64)
    _check_declared(p, "fields", fields, int(cloud.metadata.points), len(arr))
    return arr.reshape(-1, 3)


def _read_text(p: Path) -> Array:
    text = p.read_text(errors="replace")
    delimiter = "," if p.suffix.lower() == ".csv" or "," in text[:2000] else None

    def read(skip: int) -> Array:
        with warnings.catch_warnings():  # an empty file is reported below
            warnings.simplefilter("ignore", UserWarning)
            return np.loadtxt(
                p, delimiter=delimiter, comments="#", ndmin=2, skiprows=skip
            )

    try:
        arr = read(0)
    except ValueError as exc:
        # a header row: try once more skipping it
        try:
            arr = read(1)
        except ValueError:
            raise InputError(
                f"cloud file {str(p)!r} is not a table of numbers: {exc}",
                hint="write one point per line as 'x y z' or 'x,y,z' (metres)",
            ) from None
    if arr.size == 0:
        raise InputError(
            f"cloud file {str(p)!r} holds no point",
            hint="check that the export wrote points: one per line as 'x y z'",
        )
    if arr.ndim == 2 and arr.shape[1] > 3:
        arr = arr[:, :3]  # extra columns (colour, intensity) are ignored
    return np.asarray(arr, dtype=np.float64)


def _read_npy(p: Path) -> Array:
    return _as_numeric(read_npy(p, "cloud file", "points is (n, 3)"), str(p))


def read_npy(p: Path, what: str, shape: str) -> np.ndarray:
    """An .npy file's array, or one ``InputError`` naming the ``what`` and how
    to save it (its array ``shape``, as ``"points is (n, 3)"``)."""
    try:
        return np.load(p, allow_pickle=False)  # type: ignore[no-any-return]
    except NUMPY_READ_ERRORS as exc:
        name = shape.split()[0]
        raise InputError(
            f"{what} {str(p)!r} is not a readable .npy array: {_numpy_says(exc)}",
            hint=f"save it with np.save(path, {name}) where {shape}",
        ) from None


#: what ``np.load`` raises on a damaged .npy/.npz (also caught by the mesh
#: decomposition cache): a garbled array header reaches numpy's Python-2 header
#: filter, whose tokenizer raises TokenError (or SyntaxError) instead of numpy's
#: own ValueError
NUMPY_READ_ERRORS = (
    ValueError,
    OSError,
    EOFError,
    zipfile.BadZipFile,
    SyntaxError,
    tokenize.TokenError,
)


def _numpy_says(exc: BaseException) -> str:
    """numpy's reason, without its advice to unpickle (never safe on a file
    from elsewhere, and never needed for a point array)."""
    text = str(exc) or type(exc).__name__
    if "allow_pickle" in text or "pickle" in text.lower():
        return "it holds Python objects, not a numeric array"
    if isinstance(exc, EOFError) or "No data left" in text:
        return "it is empty or cut short"
    if isinstance(exc, zipfile.BadZipFile):
        return "it is not a complete zip archive (cut short, or another format)"
    if isinstance(exc, (SyntaxError, tokenize.TokenError)):
        return "its array header is damaged"
    return text


def _read_npz(p: Path) -> Array:
    try:
        with np.load(p, allow_pickle=False) as data:
            keys = list(data.keys())
            if "points" in keys:
                arr = data["points"]
            elif len(keys) == 1:
                arr = data[keys[0]]
            else:
                raise InputError(
                    f"cloud file {str(p)!r} holds no array"
                    if not keys
                    else f"cloud file {str(p)!r} holds arrays {keys} and none is "
                    "named 'points'",
                    hint="save the cloud with np.savez(path, points=points)",
                )
    except NUMPY_READ_ERRORS as exc:
        raise InputError(
            f"cloud file {str(p)!r} is not a readable .npz archive: {_numpy_says(exc)}",
            hint="save it with np.savez(path, points=points)",
        ) from None
    return _as_numeric(arr, str(p))


def _xyz_fields(arr: Any, name: str) -> Any:
    """A structured array's ``x``, ``y``, ``z`` fields as an ``(..., 3)`` float
    array (a ROS ``PointCloud2`` as ``sensor_msgs_py.point_cloud2.read_points``
    or ``ros2_numpy`` give it, with its other fields: rgb, intensity); any other
    input as it is."""
    names = getattr(getattr(arr, "dtype", None), "names", None)
    if not names:
        return arr
    by_lower = {n.lower(): n for n in names}
    if not all(k in by_lower for k in ("x", "y", "z")):
        raise InputError(
            f"cloud {name!r} is a structured array with fields {list(names)}, "
            "not all of x, y and z among them",
            hint="give the points as fields named x, y, z (as a PointCloud2 "
            "has them), or as a float (n, 3) array",
        )
    return np.stack(
        [np.asarray(arr[by_lower[k]], dtype=np.float64) for k in ("x", "y", "z")],
        axis=-1,
    )


def _as_numeric(arr: np.ndarray, name: str) -> Array:
    arr = _xyz_fields(arr, name)
    if not (
        np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)
    ):
        raise InputError(
            f"cloud {name!r} has dtype {arr.dtype}, expected real numbers",
            hint="store the points as a float (n, 3) array of x, y, z in metres",
        )
    return np.asarray(arr, dtype=np.float64)


def _check_shape(arr: ArrayLike, name: str) -> Array:
    a = np.asarray(_xyz_fields(arr, name), dtype=np.float64)
    if a.ndim == 3 and a.shape[-1] == 3:
        a = a.reshape(-1, 3)  # an organised cloud (h, w, 3) -> (h*w, 3)
    if a.ndim != 2 or a.shape[1] != 3:
        hint = "give one point per row with x, y, z columns"
        rows, cols = a.shape if a.ndim == 2 else (0, 0)
        if rows == 3 and cols > 3:
            hint += f"; this one has a point per column: pass its transpose ({cols}, 3)"
        elif 3 < cols <= _EXTRA_COLUMNS and rows > 4 * _EXTRA_COLUMNS:
            # x, y, z and more per point: intensity, a homogeneous 1, colour, normal
            hint += (
                f"; if its first three of {cols} columns are x, y, z (then intensity, "
                "colour or normals), pass those alone: points[:, :3]"
            )
        elif min(rows, cols) > _EXTRA_COLUMNS:
            hint += (
                "; an (h, w) array is a depth image: pass --intrinsics "
                "fx,fy,cx,cy with it"
            )
        elif a.ndim == 3 and 3 < a.shape[-1] <= _EXTRA_COLUMNS:
            # an organised cloud with more per pixel (a ZED's XYZRGBA, (h, w, 4))
            hint += (
                f"; if the first three of its {a.shape[-1]} values per pixel are x, "
                "y, z (then colour or intensity), pass those alone: points[..., :3]"
            )
        raise InputError(
            f"cloud {name!r} has shape {a.shape}, expected (n, 3)", hint=hint
        )
    _check_precision(a, name)
    return a


#: float32 steps by more than this (m) at the cloud's coordinates: its points
#: no longer hold the object's shape (a map or UTM frame, millions of metres
#: from its origin, steps by 0.25-0.5 m)
_FLOAT32_STEP = 1e-3


def _check_precision(a: Array, name: str) -> None:
    """Refuse a cloud stored as float32 (every value exactly a float32) far
    from its origin compared with its size, where float32 steps by more than
    :data:`_FLOAT32_STEP`: the stored points have lost the shape."""
    rows = a[:: max(1, len(a) // 10_000)]
    rows = rows[np.isfinite(rows).all(axis=1)]
    if not len(rows):
        return
    far = float(np.abs(rows).max())
    if far >= float(np.finfo(np.float32).max):
        return  # not float32's
    step = float(np.spacing(np.float32(far)))
    if step <= _FLOAT32_STEP:
        return
    spread = float(
        (np.percentile(rows, 99, axis=0) - np.percentile(rows, 1, axis=0)).max()
    )
    if far < 100.0 * spread or not np.array_equal(
        rows.astype(np.float32).astype(np.float64), rows
    ):
        return
    raise InputError(
        f"cloud {name!r} holds float32 coordinates as large as {far:.6g} for a "
        f"scene about {spread:.3g} across: float32 steps there by {step:.3g} "
        "(0.001 is a millimetre), and the points no longer hold the objects' "
        "shape",
        hint="store the points in float64, or relative to an origin near them "
        "(subtract it from the points and from the camera poses' translations, "
        "and add it to the planned poses)",
    )


#: an (n, k) array of up to this many columns is points with more per point than
#: x, y, z (XYZI, XYZ1, XYZRGB, XYZ + normals: 4 to 9); wider ones, depth images
_EXTRA_COLUMNS = 16


# --------------------------------------------------------------------------------
# scenes
# --------------------------------------------------------------------------------
class CameraPose(BaseModel):
    """A camera's pose as ROS's tf2 gives it (``ros2 run tf2_ros tf2_echo world
    camera_optical_frame``): a translation and a unit quaternion, x, y, z, w."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    translation: tuple[float, float, float] = Field(
        description="the camera's origin in the world (the scene's units)"
    )
    quaternion_xyzw: tuple[float, float, float, float] = Field(
        description="the rotation, scalar last as ROS gives it"
    )

    def matrix(self, name: str) -> Array:
        """The pose as a 4x4 transform; a quaternion that is not of unit
        length (within ``1e-3``) is refused naming ``name``."""
        from scipy.spatial.transform import Rotation

        q = np.asarray(self.quaternion_xyzw, dtype=np.float64)
        norm = float(np.linalg.norm(q))
        if abs(norm - 1.0) > 1e-3:
            raise InputError(
                f"{name}.quaternion_xyzw {list(self.quaternion_xyzw)} has length "
                f"{norm:.4g}, expected 1",
                hint="give the rotation as a unit quaternion x, y, z, w (tf2's "
                "order: the scalar last), or the pose as a 4x4 matrix",
            )
        T = np.eye(4)
        T[:3, :3] = Rotation.from_quat(q / norm).as_matrix()
        T[:3, 3] = self.translation
        return T


class _ViewEntry(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    cloud: str | None = Field(
        None, description="cloud file in the camera frame, relative to the scene YAML"
    )
    depth: str | None = Field(
        None,
        description="depth image (16-bit PNG or TIFF, float TIFF, (h, w) NPY), "
        "relative to the scene YAML, in place of a cloud",
    )
    intrinsics: Intrinsics | str | None = Field(
        None,
        description="the depth image's camera intrinsics (pixels; with "
        "distortion_model and distortion for a raw image whose lens distortion "
        "is to be undone), or a camera_info YAML/JSON file relative to the "
        "scene YAML (FILE:raw or FILE:rect where its D is not zero: the raw "
        "image, or the rectified one)",
    )
    depth_scale: float | None = Field(
        None,
        gt=0.0,
        description="metres per unit of the depth image; default 0.001 for "
        "integer images (millimetres), 1 for float images (metres)",
    )
    T_world_camera: list[list[float]] | CameraPose = Field(
        default_factory=lambda: np.eye(4).tolist(),
        description="pose of the camera in the world frame: a 4x4 (or 3x4) "
        "matrix, or {translation: [x, y, z], quaternion_xyzw: [x, y, z, w]} as "
        "tf2 prints it",
    )
    name: str = ""

    @model_validator(mode="after")
    def _cloud_or_depth(self) -> _ViewEntry:
        if (self.cloud is None) == (self.depth is None):
            raise ValueError("give each view either `cloud:` or `depth:`")
        if self.depth is not None and self.intrinsics is None:
            raise ValueError(
                "a `depth:` image needs its camera's `intrinsics: {fx, fy, cx, cy}`"
            )
        if self.cloud is not None and (
            self.intrinsics is not None or self.depth_scale is not None
        ):
            raise ValueError(
                "`intrinsics` and `depth_scale` belong to a `depth:` image, not "
                "to a `cloud:`"
            )
        return self


class SceneFile(BaseModel):
    """A scene YAML: views with their camera poses."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    version: Literal[1] = 1
    units: Literal["m", "cm", "mm", "in"] = Field(
        "m", description="unit of the clouds and of the pose translations"
    )
    views: list[_ViewEntry] = Field(min_length=1)
    views_overlap: bool = Field(
        True,
        description="the views see one tabletop from around it, so each shares "
        "some of what another sees; a view that shares nothing is refused as "
        "wrongly posed. false: a rig whose cameras see apart",
    )


def load_scene(
    paths: str | Path | Sequence[str | Path],
    *,
    icp: bool = False,
    registered: bool = False,
    icp_distance: float = 0.01,
    intrinsics: Intrinsics | None = None,
    depth_scale: float | None = None,
) -> Scene:
    """Read a scene from cloud files, depth images or a scene YAML and merge it
    into the world frame.

    Parameters
    ----------
    paths
        One cloud file or depth image, one scene YAML, or several cloud files
        or depth images (with ``registered=True``).
    icp
        Refine the view poses with point-to-plane ICP (views 2.. against view 1).
    registered
        Several cloud files are already in one (world) frame.
    icp_distance
        Largest correspondence distance (m) for ICP.
    intrinsics
        The camera intrinsics of the depth images among ``paths`` (PNG, TIFF,
        or NPY of shape ``(h, w)``; a scene YAML gives them per view).
    depth_scale
        Metres per unit of those depth images (see
        :func:`wsgrasp.perception.depth.depth_points`).

    Returns
    -------
    Scene
        ``points`` (N, 3) finite, world frame; ``dropped_nonfinite`` and
        ``dropped_no_depth`` counted.
    """
    if isinstance(paths, (str, Path)):
        paths = [paths]
    plist = [Path(p) for p in paths]
    if not plist:
        raise InputError(
            "no cloud given, expected a cloud file or a scene YAML",
            hint="pass e.g. examples/scenes/box_upright.npz",
        )
    scene_files = [p for p in plist if p.suffix.lower() in SCENE_SUFFIXES]
    if scene_files:
        if len(plist) > 1:
            raise InputError(
                f"a scene YAML ({scene_files[0]}) must be given alone, found "
                f"{len(plist)} inputs",
                hint="list every view inside the scene YAML",
            )
        if intrinsics is not None or depth_scale is not None:
            raise InputError(
                f"intrinsics or a depth scale were given with a scene YAML "
                f"({plist[0]})",
                hint="give them per view in the scene YAML (`intrinsics:`, "
                "`depth_scale:` beside `depth:`)",
            )
        views, overlap = _read_scene_yaml(plist[0])
    else:
        overlap = True
        if len(plist) > 1 and not registered:
            raise InputError(
                f"{len(plist)} clouds given without camera poses; merging them "
                "as they are assumes they are already registered in one frame",
                hint="write a scene YAML with T_world_camera per view "
                "(see examples/scenes/README.md), or pass --registered "
                "(registered=True) if they already share one frame",
            )
        # each input a depth image or not: an NPY's header says (read once)
        images = [_is_depth(p, intrinsics is not None) for p in plist]
        if intrinsics is not None and not any(images):
            raise InputError(
                "intrinsics were given, but no input is a depth image "
                f"({', '.join(DEPTH_SUFFIXES)}, or an NPY of shape (h, w))",
                hint="drop --intrinsics for point clouds; give it with a depth image",
            )
        if intrinsics is None and depth_scale is not None:
            raise InputError(
                "a depth scale was given without intrinsics",
                hint="give --intrinsics fx,fy,cx,cy with the depth image",
            )
        views = [
            View(
                points=_cloud_or_depth(p, image, intrinsics, depth_scale),
                T_world_camera=np.eye(4),
                name=p.name,
            )
            for p, image in zip(plist, images, strict=True)
        ]
    return _merge(views, icp=icp, icp_distance=icp_distance, overlap=overlap)


def _is_depth(p: Path, intrinsics: bool) -> bool:
    """Whether ``p`` is read as a depth image: an image file, or with
    ``intrinsics`` an NPY holding an ``(h, w)`` array (both sides over 3: an
    ``(n, 3)`` array is a cloud)."""
    suffix = p.suffix.lower()
    if suffix in DEPTH_SUFFIXES:
        return True
    if suffix != ".npy" or not intrinsics or not p.is_file():
        return False
    try:
        shape = np.load(p, mmap_mode="r", allow_pickle=False).shape
    except NUMPY_READ_ERRORS:
        return False
    return len(shape) == 2 and min(shape) > 3


def _cloud_or_depth(
    p: Path, image: bool, intrinsics: Intrinsics | None, depth_scale: float | None
) -> Array:
    """The points of a cloud file, or of a depth ``image`` (:func:`_is_depth`)
    with ``intrinsics``."""
    if not image:
        return load_cloud(p)
    if intrinsics is None:
        raise InputError(
            f"{str(p)!r} is a depth image: deprojecting it needs its camera's "
            "intrinsics",
            hint="pass --intrinsics fx,fy,cx,cy (camera_info's K[0], K[4], K[2], "
            "K[5]; intrinsics=Intrinsics(...) in Python), or list it in a scene "
            "YAML with `intrinsics:` (examples/scenes/README.md)",
        )
    return depth_points(read_depth_image(p), intrinsics, depth_scale, name=str(p))


def _read_scene_yaml(path: Path) -> tuple[list[View], bool]:
    from wsgrasp._loading import load_document, validate_document

    if not path.exists():
        raise InputError(
            f"scene file {str(path)!r} does not exist", hint="check the path"
        )
    try:
        data, lines = load_document(path)
        doc: SceneFile = validate_document(
            SceneFile,
            data,
            lines,
            "scene file",
            hint="a scene YAML has `views:` with `cloud:` and `T_world_camera:` "
            "(4x4) per view; see examples/scenes/README.md",
        )
    except SpecError as exc:
        raise InputError(exc.message, hint=exc.hint) from None
    scale = _UNIT_SCALE[doc.units]
    views = []
    for i, entry in enumerate(doc.views):
        file = entry.cloud or entry.depth or ""
        file_path = Path(file)
        if not file_path.is_absolute():
            file_path = path.parent / file_path
        T = _pose_matrix(entry.T_world_camera, f"{path}: views[{i}].T_world_camera")
        T[:3, 3] *= scale
        if entry.depth is not None and entry.intrinsics is not None:
            k = entry.intrinsics
            if isinstance(k, str):
                found = Intrinsics.from_reference(k, path.parent)
                # a file that is not there: its error, naming it
                k = found or Intrinsics.from_file(path.parent / k)
            # in metres by its depth_scale
            image = read_depth_image(file_path)
            pts = depth_points(image, k, entry.depth_scale, name=file)
        else:
            pts = load_cloud(file_path) * scale
        views.append(View(points=pts, T_world_camera=T, name=entry.name or file))
    return views, doc.views_overlap


#: a pose's rotation whose ``R Rᵀ`` is this near the identity is a rotation
#: written with few decimals (``tf2_echo`` prints 3, calibration files 4 to 6:
#: 3 leave up to about 1e-3): it is taken as the nearest rotation (at most a
#: fraction of a degree from it); farther, it is refused
_ROUNDED_ROTATION = 5e-3


def _check_pose(T: Any, name: str) -> Array:
    from wsgrasp.geometry import check_transforms

    arr = np.array(T, dtype=np.float64)
    if arr.shape == (3, 4):
        arr = np.vstack([arr, [0.0, 0.0, 0.0, 1.0]])
    hint = (
        "give a rigid 4x4 transform [[R, t], [0, 0, 0, 1]] with R a rotation "
        "matrix, row after row"
    )
    if arr.shape == (4, 4):
        if not np.allclose(arr[3], [0.0, 0.0, 0.0, 1.0], atol=1e-9) and np.allclose(
            arr[:, 3], [0.0, 0.0, 0.0, 1.0], atol=1e-9
        ):
            raise InputError(
                f"{name}: its bottom row is {np.round(arr[3], 6).tolist()} and its "
                "last column [0, 0, 0, 1]: the matrix is transposed (column after "
                "column, as Eigen and MATLAB store it)",
                hint="give it row after row (its transpose), the translation in "
                "the last column",
            )
        R = arr[:3, :3]
        off = float(np.abs(R @ R.T - np.eye(3)).max())
        if 1e-6 < off <= _ROUNDED_ROTATION and np.linalg.det(R) > 0.0:
            from scipy.spatial.transform import Rotation

            arr[:3, :3] = Rotation.from_matrix(R).as_matrix()  # the nearest
        elif off > _ROUNDED_ROTATION:
            raise InputError(
                f"{name}: rotation part is not orthonormal (R Rᵀ differs from the "
                f"identity by up to {off:.2g}; a rotation written with few "
                f"decimals is taken up to {_ROUNDED_ROTATION:g})",
                hint=hint,
            )
    try:
        return np.array(check_transforms(arr, name))
    except ValueError as exc:
        raise InputError(f"{exc}", hint=hint) from None


def _pose_matrix(pose: Any, name: str) -> Array:
    """A view's pose as a checked 4x4 transform, from a matrix, a
    :class:`CameraPose` or a mapping of its fields."""
    if isinstance(pose, dict):
        try:
            pose = CameraPose.model_validate(pose)
        except ValidationError as exc:
            raise InputError(
                f"{name} {pose!r} is no pose: {exc.errors()[0]['msg']}",
                hint="give a 4x4 matrix, or translation: [x, y, z] and "
                "quaternion_xyzw: [x, y, z, w]",
            ) from None
    if isinstance(pose, CameraPose):
        pose = pose.matrix(name)
    return _check_pose(pose, name)


def scene_from_arrays(
    views: ArrayLike | Sequence[tuple[ArrayLike, ArrayLike]],
    *,
    icp: bool = False,
    icp_distance: float = 0.01,
    views_overlap: bool = True,
) -> Scene:
    """Build a scene from arrays (the Python API's counterpart of ``load_scene``).

    Parameters
    ----------
    views
        Either one cloud ``(n, 3)`` already in the world frame, or a list of
        ``(points (n_i, 3), T_world_camera)`` pairs, points in camera frame, each
        pose a 4x4 matrix, a :class:`CameraPose` or its data
        (``{"translation": [x, y, z], "quaternion_xyzw": [x, y, z, w]}``, as tf2
        gives it).
    icp
        Refine the poses with ICP.
    views_overlap
        Refuse a view that shares nothing with the others
        (:func:`check_views_overlap`); False for a rig whose cameras see apart.
    """
    if isinstance(views, (list, tuple)) and views and isinstance(views[0], tuple):
        for i, pair in enumerate(views):
            if not isinstance(pair, tuple) or len(pair) != 2:
                raise InputError(
                    f"views[{i}] is not a (points, T_world_camera) pair",
                    hint="give every view as a pair: its points in the camera "
                    "frame, (n, 3), and the camera's pose in the world, a 4x4 "
                    "matrix or a CameraPose; or one (n, 3) cloud in the world",
                )
        vlist = [
            View(
                points=_check_shape(p, f"views[{i}]"),
                T_world_camera=_pose_matrix(T, f"views[{i}].T_world_camera"),
                name=f"view_{i}",
            )
            for i, (p, T) in enumerate(views)  # type: ignore[misc]
        ]
    else:
        vlist = [View(points=_check_shape(views, "points"), name="points")]  # type: ignore[arg-type]
    return _merge(vlist, icp=icp, icp_distance=icp_distance, overlap=views_overlap)


#: a coordinate this large (m) is no measurement: a sensor's marker for a
#: pixel without a return (FLT_MAX, 3.4e38), dropped as NaN and inf are
_INVALID_BEYOND = 1e12


def _merge(
    views: list[View], *, icp: bool, icp_distance: float, overlap: bool = True
) -> Scene:
    dropped = no_depth = 0
    for v in views:
        if v.points.shape[0] == 0:
            raise InputError(
                f"cloud {v.name!r} is empty (0 points)",
                hint="check that the capture or export wrote points",
            )
        # NaN, inf, and a sensor's marker for no return written as a number
        # (FLT_MAX): dropped alike; past 1e12 m the grid arithmetic overflows
        finite = (np.abs(v.points) < _INVALID_BEYOND).all(axis=1)
        n_bad = int(v.points.shape[0] - finite.sum())
        if n_bad == v.points.shape[0]:
            raise InputError(
                f"cloud {v.name!r} has no finite point: all {n_bad} are NaN, inf "
                f"or beyond {_INVALID_BEYOND:g} m",
                hint="the capture produced no valid depth; check the camera and "
                "the export",
            )
        # a pixel without depth comes back at the camera's centre, (0, 0, 0) in
        # its view: no camera measures a point there
        valid = finite & v.points.any(axis=1)
        n_zero = int(finite.sum() - valid.sum())
        if n_zero == finite.sum():
            raise InputError(
                f"cloud {v.name!r} has no point with a depth: all {n_zero} finite "
                "points are (0, 0, 0), what a depth camera gives a pixel it did "
                "not measure",
                hint="the capture produced no valid depth; check the camera's "
                "range and exposure, and the export",
            )
        dropped += n_bad
        no_depth += n_zero
        if n_bad or n_zero:
            v.points = v.points.take(np.flatnonzero(valid), axis=0)  # as rows
    if icp and len(views) > 1:
        refine_views_icp(views, max_distance=icp_distance)
    # (N, 3) world-frame points of every view; one view in the world frame is
    # its own merge (not copied)
    world = [_to_world(v) for v in views]
    if overlap:
        check_views_overlap(views, world)
    merged = world[0] if len(world) == 1 else np.concatenate(world, axis=0)
    check_units(merged, name=" + ".join(v.name for v in views) or "points")
    scene = Scene(
        views=views,
        points=merged,
        dropped_nonfinite=dropped,
        dropped_no_depth=no_depth,
    )
    scene.merged_digest = scene.digest()
    return scene


#: two views of one tabletop agree: one of them has at least this share of its
#: points (``_OVERLAP_POINTS`` of each view) within ``_OVERLAP_DISTANCE`` of
#: any of the other's, for they share the table around the object; a view that
#: agrees with none has a wrong pose. On synthetic three-view scenes of a box
#: (seeds 0-2), views agree at 87-92 %, and a view whose pose is inverted at
#: 1-7 % (camera_link's pose, or a translation in millimetres: 0 %)
_OVERLAP_SHARE = 0.2
_OVERLAP_POINTS = 1000
_OVERLAP_DISTANCE = 0.02


def check_views_overlap(views: Sequence[View], world: Sequence[Array]) -> None:
    """Raise ``InputError`` when a view of several, its points ``world`` in the
    world frame, agrees with none of the others (see ``_OVERLAP_SHARE``): its
    ``T_world_camera`` is then wrong (the world's pose in the camera given for
    the camera's in the world, a pose in other units or of another frame), and
    merging it would put a phantom of the scene beside the scene."""
    from scipy.spatial import cKDTree

    from wsgrasp.perception.process import downsample

    n = len(views)
    if n < 2:
        return
    # every k-th point, about _OVERLAP_POINTS of each view: spread over its
    # image as the view's points are (a camera's, row after row)
    sample = [w[:: max(1, len(w) // _OVERLAP_POINTS)] for w in world]
    # matched against all of the other view's points, one per cell (the
    # cell's mean lies within half a diagonal of each of its points): thinned
    # like the queries, a view of a few square metres left its samples farther
    # apart than the match distance, and two views posed right agreed at 14 %
    cell = 0.5 * _OVERLAP_DISTANCE
    # built unbalanced and uncompacted: the same answers, the build 2.6 times
    # faster (4.5 -> 1.7 ms on a 1 cm grid of a 300,000-point view)
    trees = [
        cKDTree(downsample(w, cell), balanced_tree=False, compact_nodes=False)
        for w in world
    ]
    reach = _OVERLAP_DISTANCE + 0.5 * np.sqrt(3.0) * cell
    share = np.zeros((n, n))  # [i, j]: i's points near j's
    for i, v in enumerate(sample):
        for j, tree in enumerate(trees):
            if j != i:
                d, _ = tree.query(v, distance_upper_bound=reach)
                share[i, j] = float(np.isfinite(d).mean())
    agree = np.maximum(share, share.T).max(axis=1)  # (n,) with its best partner
    apart = np.flatnonzero(agree < _OVERLAP_SHARE)
    if not apart.size:
        return
    name = [repr(v.name or f"view {i}") for i, v in enumerate(views)]
    listing = ", ".join(f"{name[i]} {100 * agree[i]:.0f} %" for i in range(n))
    which = (
        f"views {', '.join(name[i] for i in apart)} share"
        if apart.size > 1
        else f"view {name[apart[0]]} shares"
    )
    raise InputError(
        f"{which} almost nothing with the other views once in the world frame "
        f"(the share of points within {100 * _OVERLAP_DISTANCE:g} cm of the "
        f"best-matching view: {listing}): a T_world_camera is wrong",
        hint="give each camera's pose in the world (the inverse of the world's "
        "pose in the camera), of the frame its points are in (a depth camera's "
        "optical frame, z forward, not ROS's camera_link), in the scene's units, "
        "its quaternion scalar last (x, y, z, w); "
        "clouds that do not share one frame are not --registered; for cameras "
        "that see apart, `views_overlap: false` in the scene YAML",
    )


def _to_world(view: View) -> Array:
    T = np.asarray(view.T_world_camera, dtype=np.float64)
    if not view.posed:
        return view.points
    # p_world = R p + t, (n, 3)
    return view.points @ T[:3, :3].T + T[:3, 3]


def robust_extent(points: Array, tail: float = 0.5) -> float:
    """The largest side of a cloud's ``(n, 3)`` box between the ``tail``-th and
    the ``(100 - tail)``-th percentiles per axis; its plain extent where that is
    at most ``MAX_SCENE_EXTENT`` (no need for percentiles); 0 for no point."""
    if points.shape[0] == 0:
        return 0.0
    extent = float(np.max(points.max(axis=0) - points.min(axis=0)))
    if extent <= MAX_SCENE_EXTENT:
        return extent
    lo, hi = np.percentile(points, [tail, 100.0 - tail], axis=0)
    return float(np.max(hi - lo))


def check_units(points: Array, name: str = "points") -> None:
    """Raise ``InputError`` when a cloud is too large to be in metres.

    The robust extent (0.5th to 99.5th percentile per axis) must stay below
    ``MAX_SCENE_EXTENT``; a larger one usually means millimetres, unless the
    points lie as close together as a depth camera's in metres do (their
    median spacing below :data:`METRE_SPACING`) and the far ones are few (the
    5th to 95th percentiles per axis span under ``MAX_SCENE_EXTENT``): a cloud
    in metres with points strewn far from the rest (5 % of them over 100 m, the
    background of an outdoor view), which the segmenter leaves aside. A whole
    view far from the others (its pose's translation in millimetres) is still
    refused.
    """
    extent = robust_extent(points)
    # the far points many (a view apart), or the points as far apart as in
    # millimetres; the percentiles first, the nearest-neighbour tree if need be
    if extent > MAX_SCENE_EXTENT and (
        robust_extent(points, _FEW_FAR) > MAX_SCENE_EXTENT
        or _spacing(points) >= METRE_SPACING
    ):
        # the unit that makes the scene closest to a metre-sized tabletop
        unit, short, scale = min(
            (("centimetres", "cm", 100.0), ("millimetres", "mm", 1000.0)),
            key=lambda u: abs(np.log10(extent / u[2])),
        )
        raise InputError(
            f"cloud {name!r} spans {extent:.4g} units; a tabletop scene in metres "
            f"spans well under {MAX_SCENE_EXTENT:g} m, so it is probably in "
            f"{unit} ({extent / scale:.3g} m across)",
            hint=f"divide the points by {scale:g}, or set `units: {short}` in a "
            "scene YAML",
        )


#: a cloud whose points lie closer than this to their nearest neighbours (median,
#: in the cloud's units) is in metres whatever its extent: a depth camera's points
#: over a tabletop lie 0.5-10 mm apart, in millimetres 0.5-10 units, in
#: centimetres 0.05-1
METRE_SPACING = 0.02
#: the spacing is the median over this many points, each against the whole cloud
_SPACING_SAMPLES = 2000
#: far points are few when the box between these percentiles (per axis, from
#: each end) stays within ``MAX_SCENE_EXTENT``
_FEW_FAR = 5.0


def _spacing(points: Array) -> float:
    """The median distance from :data:`_SPACING_SAMPLES` of ``points`` ``(n,
    3)``, evenly spaced, to their nearest neighbours among all of them."""
    from scipy.spatial import cKDTree

    if len(points) < 2:
        return float("inf")
    sample = points[:: max(1, len(points) // _SPACING_SAMPLES)]
    d, _ = cKDTree(points).query(sample, k=2)
    return float(np.median(d[:, 1]))


def units_hint(points: Array, image: bool = False) -> str | None:
    """A hint for a cloud that nothing could be segmented in: when it is wider
    than ``WIDE_SCENE_EXTENT`` (plain extent), what it spans and how to give it
    in metres; ``None`` for a narrower one. A cloud in inches passes
    :func:`check_units` (a 50 cm scene spans 20 units) and then finds no object
    (each looks 39 times too large). Where its views are a camera's ``image``
    (a depth image, or the cloud its driver deprojects), a depth image read in
    the wrong unit is named too: TUM RGB-D's, 5,000 to the metre, read as
    millimetres puts its table 5 times too far."""
    if points.shape[0] == 0:
        return None
    extent = float(np.max(points.max(axis=0) - points.min(axis=0)))
    if extent <= WIDE_SCENE_EXTENT:
        return None
    depth = (
        "; a depth image whose values are not millimetres needs its depth scale "
        "in metres per unit (--depth-scale, or `depth_scale:` in a scene YAML: "
        "0.0002 for TUM RGB-D's, 0.0001 for tenths of a millimetre)"
        if image
        else ""
    )
    return (
        f"the cloud spans {extent:.3g} units, wide for a tabletop scene in metres: "
        "if it is in inches, centimetres or millimetres, multiply the points by "
        "0.0254, 0.01 or 0.001 (or set `units: in`, `cm` or `mm` in a scene YAML)"
        + depth
    )


# --------------------------------------------------------------------------------
# ICP
# --------------------------------------------------------------------------------
def refine_views_icp(
    views: list[View], *, max_distance: float = 0.01, voxel: float = 0.004
) -> None:
    """Refine ``T_world_camera`` of views 2.. by point-to-plane ICP (open3d, Tukey
    robust loss) against all the other views merged.

    The first view anchors the world frame. Poses are updated in place; each
    view's points stay in its camera frame.
    """
    from wsgrasp._open3d import load_open3d

    o3d = load_open3d()

    reg = o3d.pipelines.registration

    def cloud(points: Array) -> Any:
        pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
        pcd = pcd.voxel_down_sample(voxel)
        pcd.estimate_normals(
            o3d.geometry.KDTreeSearchParamHybrid(radius=4 * voxel, max_nn=30)
        )
        return pcd

    # the robust loss keeps depth edges and unseen surfaces from dragging the
    # dominant table plane sideways, which plain point-to-plane ICP does
    method = reg.TransformationEstimationPointToPlane(reg.TukeyLoss(k=max_distance / 2))
    criteria = reg.ICPConvergenceCriteria(max_iteration=50)
    for i in range(1, len(views)):
        others = np.concatenate(
            [
                transform_points(v.T_world_camera, v.points)
                for j, v in enumerate(views)
                if j != i
            ]
        )
        v = views[i]
        source = cloud(transform_points(v.T_world_camera, v.points))
        result = reg.registration_icp(
            source, cloud(others), max_distance, np.eye(4), method, criteria
        )
        # correction in the world frame: T_world_camera <- T_fix @ T_world_camera
        v.T_world_camera = np.asarray(result.transformation) @ v.T_world_camera


# --------------------------------------------------------------------------------
# writing
# --------------------------------------------------------------------------------
def save_cloud(path: str | Path, points: ArrayLike) -> Path:
    """Write a cloud ``(n, 3)``: NPZ (float32, key ``points``), NPY, PLY/PCD (open3d)
    or XYZ/TXT/CSV (text, metres)."""
    p = Path(path)
    pts = _check_shape(points, str(p))
    suffix = p.suffix.lower()
    p.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".npz":
        np.savez_compressed(p, points=pts.astype(np.float32))
    elif suffix == ".npy":
        np.save(p, pts.astype(np.float32))
    elif suffix in (".ply", ".pcd"):
        from wsgrasp._open3d import load_open3d

        o3d = load_open3d()

        pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts))
        o3d.io.write_point_cloud(p, pcd)
    elif suffix in (".xyz", ".txt", ".csv"):
        np.savetxt(p, pts, fmt="%.6f", delimiter="," if suffix == ".csv" else " ")
    else:
        raise InputError(
            f"cannot write cloud {str(p)!r}: unknown format {suffix!r}, expected one "
            f"of {', '.join(CLOUD_SUFFIXES)}",
            hint="name the output e.g. scene.npz",
        )
    return p


def write_scene_yaml(
    directory: str | Path,
    views: Sequence[View],
    name: str = "scene.yaml",
    cameras: Sequence[Any] | None = None,
    lens: tuple[str, Sequence[float]] | None = None,
) -> Path:
    """Write each view's points (camera frame) as ``view_<i>.npz`` and a scene YAML
    listing them with their ``T_world_camera``; returns the YAML's path. With
    ``cameras`` (one :class:`wsgrasp.perception.synth.Camera` per view), each view
    is written as the camera's depth image instead, a 16-bit PNG in millimetres,
    listed with its intrinsics; with a ``lens`` (a distortion model and its
    coefficients, :class:`~wsgrasp.perception.depth.Intrinsics`'), as the raw
    image that lens bends, listed with it."""
    import yaml
    from PIL import Image

    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    entries: list[dict[str, Any]] = []
    for i, v in enumerate(views):
        T = np.round(np.asarray(v.T_world_camera, dtype=np.float64), 9)
        if cameras is None:
            fname = f"view_{i}.npz"
            save_cloud(d / fname, v.points)
            entries.append({"cloud": fname, "T_world_camera": T.tolist()})
            continue
        cam = cameras[i]
        model, coefficients = lens or (None, ())
        k = Intrinsics(
            fx=cam.fx,
            fy=cam.fy,
            cx=cam.cx,
            cy=cam.cy,
            distortion_model=model,  # type: ignore[arg-type]
            distortion=[float(c) for c in coefficients],
        )
        mm = np.rint(cam.depth_image(v.points, k) * 1000.0)
        fname = f"view_{i}.png"
        Image.fromarray(np.clip(mm, 0, 65535).astype(np.uint16)).save(d / fname)
        entries.append(
            {
                "depth": fname,
                "intrinsics": k.model_dump(exclude_defaults=True),
                "T_world_camera": T.tolist(),
            }
        )
    doc = {"version": 1, "units": "m", "views": entries}
    out = d / name
    out.write_text(yaml.safe_dump(doc, sort_keys=False, default_flow_style=None))
    return out
