"""Depth images as planner input: a depth camera's image and its intrinsics,
deprojected into the camera's frame (OpenCV axes: z forward, x right, y down).

An image is a 16-bit PNG or TIFF (integer depth in ``depth_scale`` metres per
unit: millimetres unless told, as RealSense, Azure Kinect and most drivers write
them; TUM RGB-D's are 0.2 mm, ``depth_scale: 0.0002``), a 32-bit float TIFF
(metres unless told), or an NPY of shape ``(h, w)``. Every pixel gives one point,
row after row; a pixel without a depth (0, NaN or inf) gives ``(0, 0, 0)``,
which :func:`wsgrasp.perception.io.load_scene` drops and counts as a point
without depth, so the points stay the camera's image
(:mod:`wsgrasp.perception.flying` finds its pixel grid again).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from wsgrasp.errors import InputError
from wsgrasp.perception.types import Array

__all__ = ["DEPTH_SUFFIXES", "Intrinsics", "depth_points", "read_depth_image"]

#: files read as depth images (and an NPY of shape (h, w))
DEPTH_SUFFIXES = (".png", ".tif", ".tiff")
#: metres per unit of an integer image when none is given: millimetres
INTEGER_DEPTH_SCALE = 0.001


class Intrinsics(BaseModel):
    """A pinhole camera's intrinsics in pixels (``camera_info``'s ``K``:
    ``[fx, 0, cx, 0, fy, cy, 0, 0, 1]``), the image's pixel centres at integer
    coordinates."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    fx: float = Field(gt=0.0, description="focal length along x (pixels)")
    fy: float = Field(gt=0.0, description="focal length along y (pixels)")
    cx: float = Field(description="principal point, x (pixels)")
    cy: float = Field(description="principal point, y (pixels)")

    @classmethod
    def parse(cls, text: str) -> Intrinsics:
        """``"fx,fy,cx,cy"``, or a file :meth:`from_file` reads (the CLI's
        ``--intrinsics``)."""
        if Path(text).is_file():
            return cls.from_file(text)
        parts = [p for p in text.replace(" ", "").split(",") if p]
        try:
            values = [float(p) for p in parts]
            if len(values) != 4:
                raise ValueError
            return cls(fx=values[0], fy=values[1], cx=values[2], cy=values[3])
        except (ValueError, ValidationError):
            raise InputError(
                f"--intrinsics {text!r} is not four numbers fx,fy,cx,cy with "
                "positive focal lengths",
                hint="give the depth camera's K as fx,fy,cx,cy in pixels, e.g. "
                "--intrinsics 615.0,615.0,320.0,240.0 (camera_info's K[0], K[4], "
                "K[2], K[5]), or a camera_info YAML file",
            ) from None

    @classmethod
    def from_k(cls, k: Sequence[Any]) -> Intrinsics:
        """From a camera matrix ``K``, its 9 values row by row (``camera_info``'s
        ``k``).

        Raises
        ------
        ValueError
            Not 9 numbers, or focal lengths that are not positive (pydantic's
            ``ValidationError`` is one).
        """
        values = [float(v) for v in k]
        if len(values) != 9:
            raise ValueError(f"a camera matrix has 9 values, not {len(values)}")
        return cls(fx=values[0], fy=values[4], cx=values[2], cy=values[5])

    @classmethod
    def from_file(cls, path: str | Path) -> Intrinsics:
        """The intrinsics in a YAML or JSON file: ``fx``, ``fy``, ``cx``, ``cy``;
        a ROS calibration file's ``camera_matrix: {data: [9 values]}``; or a
        ``CameraInfo`` message as ``ros2 topic echo --once`` prints it (``k:``,
        ROS 1's ``K:``), ``K`` row by row."""
        import yaml

        p = Path(path)
        try:
            docs = [d for d in yaml.safe_load_all(p.read_text("utf-8")) if d]
        except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
            raise InputError(
                f"intrinsics file {str(p)!r} cannot be read: {exc}",
                hint="give a YAML or JSON file (a camera_info echoed by ros2 topic "
                "echo --once, a ROS calibration file, or fx, fy, cx, cy)",
            ) from None
        doc = docs[0] if docs and isinstance(docs[0], dict) else {}
        matrix = doc.get("camera_matrix")
        k = (
            matrix.get("data")
            if isinstance(matrix, dict)
            else doc.get("k", doc.get("K"))
        )
        try:
            if k is not None:
                return cls.from_k(k)
            return cls.model_validate({key: doc.get(key) for key in cls.model_fields})
        except (ValueError, TypeError, ValidationError):
            raise InputError(
                f"intrinsics file {str(p)!r} has no camera matrix: expected "
                "`k:`/`K:` or `camera_matrix: {data: ...}` with 9 numbers, or "
                "`fx`, `fy`, `cx`, `cy` with positive focal lengths",
                hint="save the depth camera's camera_info with `ros2 topic echo "
                "--once /camera/depth/camera_info > info.yaml`",
            ) from None


def read_depth_image(path: str | Path) -> NDArray[np.generic]:
    """A depth image file's values ``(h, w)`` as stored (integers or floats).

    Raises
    ------
    InputError
        The file is missing, not an image, a colour or 8-bit image, or not 2-D.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(
            f"depth image {str(p)!r} does not exist",
            hint="check the path (relative paths are from the current directory, "
            "or from the scene YAML's folder)",
        )
    if p.suffix.lower() == ".npy":
        from wsgrasp.perception.io import read_npy

        arr = read_npy(p, "depth image", "depth is (h, w)")
    else:
        from PIL import Image, UnidentifiedImageError

        try:
            with Image.open(p) as img:
                mode = img.mode
                arr = np.asarray(img)
        except (UnidentifiedImageError, OSError, ValueError) as exc:
            raise InputError(
                f"depth image {str(p)!r} cannot be read as an image ({exc})",
                hint="give a 16-bit PNG or TIFF, or a 32-bit float TIFF",
            ) from None
        if mode in ("1", "L", "P", "LA", "RGB", "RGBA", "CMYK", "YCbCr"):
            raise InputError(
                f"depth image {str(p)!r} is an 8-bit image (mode {mode}), not a "
                "depth image: a depth camera writes 16-bit integer or 32-bit "
                "float depth",
                hint="give the depth stream's image (16-bit PNG), not the colour "
                "image or a rendering of the depth for viewing",
            )
    if arr.ndim != 2 or not (
        np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)
    ):
        raise InputError(
            f"depth image {str(p)!r} has shape {arr.shape} and type {arr.dtype}, "
            "expected (h, w) integers or floats",
            hint="give one depth per pixel: a 16-bit PNG, a float TIFF or an "
            "(h, w) NPY",
        )
    return arr


def depth_points(
    depth: NDArray[np.generic],
    intrinsics: Intrinsics,
    depth_scale: float | None = None,
    *,
    name: str = "depth",
) -> Array:
    """The image's points ``(h * w, 3)`` in its camera's frame, row after row,
    deprojected by open3d; ``(0, 0, 0)`` for a pixel without a depth.

    Parameters
    ----------
    depth : (h, w) integers or floats
    intrinsics
        The depth camera's; its principal point must lie on the image.
    depth_scale
        Metres per unit of ``depth``; None: 0.001 for integers (millimetres),
        1 for floats (metres).
    name
        The image, for errors.
    """
    import open3d as o3d

    d = np.asarray(depth)
    h, w = d.shape
    k = intrinsics
    if not (-0.5 <= k.cx <= w - 0.5 and -0.5 <= k.cy <= h - 0.5):
        raise InputError(
            f"depth image {name!r} is {w} x {h} pixels, but the intrinsics put "
            f"its principal point at ({k.cx:g}, {k.cy:g}), off the image",
            hint="give the intrinsics of the depth stream at this resolution "
            "(camera_info's K of the depth topic; cx, cy are in pixels)",
        )
    if depth_scale is None:
        integer = np.issubdtype(d.dtype, np.integer)
        depth_scale = INTEGER_DEPTH_SCALE if integer else 1.0
    if not (np.isfinite(depth_scale) and depth_scale > 0.0):
        raise InputError(
            f"depth_scale {depth_scale!r} of depth image {name!r} is not a "
            "positive number of metres per unit",
            hint="0.001 for an image in millimetres, 1 for one in metres",
        )
    metres = (d.astype(np.float64) * depth_scale).astype(np.float32)
    valid = np.isfinite(metres) & (metres > 0.0)
    if not valid.any():
        raise InputError(
            f"depth image {name!r} has no pixel with a depth: every one of its "
            f"{h * w} is 0, NaN or inf",
            hint="the capture produced no valid depth; check the camera's range "
            "and exposure, and the export",
        )
    camera = o3d.camera.PinholeCameraIntrinsic(w, h, k.fx, k.fy, k.cx, k.cy)
    image = np.ascontiguousarray(np.where(valid, metres, np.float32(0.0)))
    cloud = o3d.geometry.PointCloud.create_from_depth_image(
        o3d.geometry.Image(image),  # type: ignore[call-overload]
        camera,
        depth_scale=1.0,
        depth_trunc=float(np.finfo(np.float32).max),
        project_valid_depth_only=False,
    )
    points = np.asarray(cloud.points, dtype=np.float64)  # (h*w, 3), NaN: no depth
    points[~valid.reshape(-1)] = 0.0
    _check_extent(points[valid.reshape(-1)], name, float(depth_scale), k)
    return points


def _check_extent(points: Array, name: str, depth_scale: float, k: Intrinsics) -> None:
    """Raise ``InputError`` when an image's points span more than a tabletop
    scene can (:func:`wsgrasp.perception.io.check_units`' limit), naming the
    depth scale and the intrinsics that put them there."""
    from wsgrasp.perception.io import MAX_SCENE_EXTENT, robust_extent

    extent = robust_extent(points)
    if extent > MAX_SCENE_EXTENT:
        raise InputError(
            f"depth image {name!r} deprojects to points {extent:.4g} m across at "
            f"a depth scale of {depth_scale:g} m per unit and focal lengths of "
            f"{k.fx:g} x {k.fy:g} pixels; a tabletop scene spans well under "
            f"{MAX_SCENE_EXTENT:g} m",
            hint="give the scale of the image's values (--depth-scale or "
            "`depth_scale:` in metres per unit: 0.001 for millimetres) and the "
            "depth stream's intrinsics in pixels; a sensor's value for no depth "
            "other than 0 (65535) reads as far away",
        )
