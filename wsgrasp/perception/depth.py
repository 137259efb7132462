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
from functools import lru_cache
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from wsgrasp.errors import InputError
from wsgrasp.perception.types import Array

__all__ = [
    "DEPTH_SUFFIXES",
    "DISTORTION_MODELS",
    "Intrinsics",
    "depth_points",
    "read_depth_image",
    "rectify_depth",
]

#: files read as depth images (and an NPY of shape (h, w))
DEPTH_SUFFIXES = (".png", ".tif", ".tiff")
#: metres per unit of an integer image when none is given: millimetres
INTEGER_DEPTH_SCALE = 0.001


#: the lens models whose distortion :func:`depth_points` undoes, as ``camera_info``
#: names them, with the numbers of coefficients each takes (OpenCV's order:
#: ``k1, k2, p1, p2[, k3[, k4, k5, k6]]``; the fisheye model's ``k1`` to ``k4``)
DISTORTION_MODELS = {
    "plumb_bob": (4, 5),
    "rational_polynomial": (8,),
    "equidistant": (4,),
}
DistortionModel = Literal["plumb_bob", "rational_polynomial", "equidistant"]
#: which image a ``camera_info`` describes: the camera's raw image (``K`` and its
#: distortion ``D``) or the rectified one (``P``, no distortion)
ImageKind = Literal["raw", "rect"]


class Intrinsics(BaseModel):
    """A camera's intrinsics in pixels (``camera_info``'s ``K``: ``[fx, 0, cx, 0,
    fy, cy, 0, 0, 1]``), the image's pixel centres at integer coordinates, and
    its lens distortion where the image is not rectified (``camera_info``'s
    ``distortion_model`` and ``D``): :func:`depth_points` undoes it."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    fx: float = Field(gt=0.0, description="focal length along x (pixels)")
    fy: float = Field(gt=0.0, description="focal length along y (pixels)")
    cx: float = Field(description="principal point, x (pixels)")
    cy: float = Field(description="principal point, y (pixels)")
    distortion_model: DistortionModel | None = Field(
        None,
        description="lens model of `distortion` (camera_info's distortion_model): "
        "plumb_bob, rational_polynomial or equidistant",
    )
    distortion: list[float] = Field(
        default_factory=list,
        description="lens distortion coefficients of the raw image (camera_info's "
        "D, OpenCV's order); none for a rectified image",
    )

    @model_validator(mode="after")
    def _lens(self) -> Intrinsics:
        if not self.distorted:
            return self
        if self.distortion_model is None:
            raise ValueError(
                "distortion coefficients need their distortion_model: "
                + ", ".join(DISTORTION_MODELS)
            )
        counts = DISTORTION_MODELS[self.distortion_model]
        if len(self.distortion) not in counts:
            raise ValueError(
                f"a {self.distortion_model} distortion has "
                f"{' or '.join(map(str, counts))} coefficients, not "
                f"{len(self.distortion)}"
            )
        return self

    @property
    def distorted(self) -> bool:
        """Whether the image is bent by a lens distortion to undo."""
        return any(v != 0.0 for v in self.distortion)

    def distort(self, x: Array, y: Array) -> tuple[Array, Array]:
        """Where the lens puts the undistorted normalised image points ``(x,
        y)`` (``z = 1``): OpenCV's camera model (``plumb_bob``: ``k1, k2, p1,
        p2[, k3]``; ``rational_polynomial``: and ``k4, k5, k6`` below the
        fraction) or its fisheye model (``equidistant``: ``k1`` to ``k4`` in
        the angle); unchanged without a distortion."""
        c = list(self.distortion)
        if not self.distorted:
            return x, y
        if self.distortion_model == "equidistant":
            k1, k2, k3, k4 = c
            r = np.hypot(x, y)
            t = np.arctan(r)
            t2 = t * t
            td = t * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))
            scale = np.divide(td, r, out=np.ones_like(r), where=r > 0.0)
            return x * scale, y * scale
        k1, k2, p1, p2, k3, k4, k5, k6 = c + [0.0] * (8 - len(c))
        r2 = x * x + y * y
        radial = (1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (
            1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))
        )
        xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
        yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
        return xd, yd

    @classmethod
    def parse(cls, text: str) -> Intrinsics:
        """``"fx,fy,cx,cy"``, or a file :meth:`from_file` reads, with
        ``:raw`` or ``:rect`` after it to say which image a ``camera_info``
        with a lens distortion describes (the CLI's ``--intrinsics``)."""
        ref = cls.from_reference(text)
        if ref is not None:
            return ref
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
    def from_reference(cls, text: str, base: Path | None = None) -> Intrinsics | None:
        """The intrinsics in the file ``text`` names (relative to ``base``),
        ``FILE``, ``FILE:raw`` or ``FILE:rect`` (:meth:`from_file`'s
        ``image``); None when ``text`` names no file."""
        kinds: tuple[ImageKind | None, ...] = (None, "raw", "rect")
        for image in kinds:
            name = text if image is None else text.removesuffix(f":{image}")
            if image is not None and name == text:
                continue
            path = Path(name)
            if base is not None and not path.is_absolute():
                path = base / path
            if path.is_file():
                return cls.from_file(path, image)
        return None

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
    def from_camera_info(
        cls, info: Any, image: ImageKind | None, name: str, hint: str = ""
    ) -> Intrinsics:
        """From a ``CameraInfo`` (a message, or a mapping as ``ros2 topic echo``
        prints one, ROS 1's capitals or a ROS calibration file's
        ``camera_matrix``, ``distortion_coefficients`` and
        ``projection_matrix``) for its ``image``: ``raw``, ``K`` and the lens
        distortion ``D`` to undo; ``rect``, the rectified image's ``P``.
        Without ``image``, a camera_info whose ``D`` is all zeros gives ``K``.
        Either is of the sensor's full resolution, as ``CameraInfo`` keeps
        them: a binned image or a region of interest (``binning_x``,
        ``binning_y``, ``roi``) gets them scaled and shifted to its own pixels.

        Raises
        ------
        InputError
            No camera matrix; a distortion without ``image`` to say whether the
            image is raw or rectified (``hint`` says how to say it); a
            distortion model that is not undone; ``rect`` without a
            projection matrix.
        """
        k, d, p = (_field(info, *keys) for keys in _CAMERA_INFO_FIELDS)
        model = _field(info, "distortion_model")
        try:
            d = [float(v) for v in (d if d is not None else [])]
            p = [float(v) for v in p] if p is not None else None
        except (TypeError, ValueError):
            raise InputError(
                f"{name}: its distortion D ({d}) or projection matrix P ({p}) is "
                "not a list of numbers",
                hint="give the camera's camera_info as its driver publishes it",
            ) from None
        distorted = any(v != 0.0 for v in d)
        has_p = p is not None and len(p) == 12 and p[0] > 0 and p[5] > 0
        if image == "rect" and not has_p and distorted:
            raise InputError(
                f"{name}: has no projection matrix P for its rectified image (P = {p})",
                hint="give the camera_info of the rectified image's camera, or "
                "the raw image with `:raw`",
            )
        try:
            if image == "rect" and p is not None and has_p:
                base = cls(fx=p[0], fy=p[5], cx=p[2], cy=p[6])
            else:
                base = cls.from_k(k)
        except (ValueError, TypeError, ValidationError):
            raise InputError(
                f"{name}: has no camera matrix: expected `k:`/`K:` or "
                "`camera_matrix: {data: ...}` with 9 numbers, or `fx`, `fy`, "
                f"`cx`, `cy` with positive focal lengths (K = {k})",
                hint="give the depth camera's own camera_info (`ros2 topic echo "
                "--once /camera/depth/camera_info > info.yaml`), recorded with "
                "the camera calibrated",
            ) from None
        base = _subsampled(base, info, name)
        if image == "rect" or not distorted:
            return base
        if image is None:
            raise InputError(
                f"{name}: its lens distortion ({model}, D = {d}) is undone for the "
                "camera's raw image, not for a rectified one, and the file does "
                "not say which image it goes with",
                hint=hint,
            )
        if model not in DISTORTION_MODELS or len(d) not in DISTORTION_MODELS[model]:
            raise InputError(
                f"{name}: its lens distortion {model!r} with {len(d)} coefficients "
                "is not undone (plumb_bob with 4 or 5, rational_polynomial with 8 "
                "and equidistant with 4 are)",
                hint="plan on the rectified image (a ROS `image_rect` topic, or "
                "`:rect` after the camera_info file)",
            )
        return base.model_copy(update={"distortion_model": model, "distortion": d})

    @classmethod
    def from_file(cls, path: str | Path, image: ImageKind | None = None) -> Intrinsics:
        """The intrinsics in a YAML or JSON file: ``fx``, ``fy``, ``cx``, ``cy``
        (and ``distortion_model``, ``distortion``); a ROS calibration file's
        ``camera_matrix: {data: [9 values]}``; or a ``CameraInfo`` message as
        ``ros2 topic echo --once`` prints it (``k:``, ROS 1's ``K:``), ``K`` row
        by row. A camera_info with a lens distortion needs ``image``
        (:meth:`from_camera_info`)."""
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
        name = f"intrinsics file {str(p)!r}"
        if _field(doc, *_CAMERA_INFO_FIELDS[0]) is not None:
            return cls.from_camera_info(
                doc,
                image,
                name,
                hint=f"give `{p}:raw` for the camera's raw image (its distortion "
                f"is undone through K) or `{p}:rect` for its rectified image "
                "(ROS's image_rect: its P)",
            )
        try:
            return cls.model_validate(
                {key: doc[key] for key in cls.model_fields if key in doc}
            )
        except (ValueError, TypeError, ValidationError) as exc:
            detail = ""
            if isinstance(exc, ValidationError) and all(
                key in doc for key in ("fx", "fy", "cx", "cy")
            ):
                detail = f": {exc.errors()[0]['msg']}"
            raise InputError(
                f"{name} has no camera matrix: expected "
                "`k:`/`K:` or `camera_matrix: {data: ...}` with 9 numbers, or "
                f"`fx`, `fy`, `cx`, `cy` with positive focal lengths{detail}",
                hint="save the depth camera's camera_info with `ros2 topic echo "
                "--once /camera/depth/camera_info > info.yaml`",
            ) from None


#: a camera_info's K, D and P under the names its forms give them
_CAMERA_INFO_FIELDS = (
    ("k", "K", "camera_matrix"),
    ("d", "D", "distortion_coefficients"),
    ("p", "P", "projection_matrix"),
)


def _subsampled(k: Intrinsics, info: Any, name: str) -> Intrinsics:
    """``k`` (a camera_info's, of the full sensor) for the image the camera_info
    describes: binned ``binning_x`` by ``binning_y`` (0 or 1: not binned) and
    cut to its ``roi`` (offsets in full-resolution pixels), as ``CameraInfo``
    defines them. A binned pixel is the mean of its full pixels, its centre
    theirs: full ``u = b u' + (b - 1) / 2 + x_offset``."""

    try:
        bx, by = (max(int(_get(info, f"binning_{a}") or 0), 1) for a in "xy")
        roi = _get(info, "roi")
        ox, oy = (int(_get(roi, f"{a}_offset") or 0) if roi else 0 for a in "xy")
    except (TypeError, ValueError):
        raise InputError(
            f"{name}: its binning_x, binning_y or roi offsets are not whole numbers",
            hint="give the camera's camera_info as its driver publishes it",
        ) from None
    if bx == by == 1 and ox == oy == 0:
        return k
    return k.model_copy(
        update={
            "fx": k.fx / bx,
            "fy": k.fy / by,
            "cx": (k.cx - ox - (bx - 1) / 2.0) / bx,
            "cy": (k.cy - oy - (by - 1) / 2.0) / by,
        }
    )


def _get(obj: Any, key: str) -> Any:
    """``key`` of a mapping, or attribute of a message; None where it has none."""
    return obj.get(key) if isinstance(obj, dict) else getattr(obj, key, None)


def _field(info: Any, *keys: str) -> Any:
    """The first of ``keys`` that ``info`` (a mapping or a message) has, a
    calibration file's ``{data: [...]}`` unwrapped; None where none is."""
    for key in keys:
        value = _get(info, key)
        if isinstance(value, dict):
            value = value.get("data")
        if value is not None:
            return list(value) if not isinstance(value, str) else value
    return None


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
    deprojected by open3d; ``(0, 0, 0)`` for a pixel without a depth. An image
    whose ``intrinsics`` carry a lens distortion is rectified first
    (:func:`rectify_depth`): its points are those of the rectified image.

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
    from wsgrasp._open3d import load_open3d

    o3d = load_open3d()

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
    _check_principal_point(k, w, h, name)
    if depth_scale is None:
        integer = np.issubdtype(d.dtype, np.integer)
        depth_scale = INTEGER_DEPTH_SCALE if integer else 1.0
    if not (np.isfinite(depth_scale) and depth_scale > 0.0):
        raise InputError(
            f"depth_scale {depth_scale!r} of depth image {name!r} is not a "
            "positive number of metres per unit",
            hint="0.001 for an image in millimetres, 1 for one in metres",
        )
    if k.distorted:
        d = rectify_depth(d, k)
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


#: a depth camera's principal point lies near its image's middle (RealSense,
#: Azure Kinect, Orbbec and Zivid calibrations: within 42-59 % of the width and
#: height); one outside this share of either is not this image's camera
_PRINCIPAL_SPAN = (0.15, 0.85)
#: ...and one off the middle by the same share along both axes, past this, is
#: the camera's at another resolution (a colour stream's, a binned one's)
_RESOLUTION_SHIFT = 0.15


def _check_principal_point(k: Intrinsics, w: int, h: int, name: str) -> None:
    """Refuse intrinsics whose principal point lies far from the middle of the
    ``w`` x ``h`` image: those of another resolution (the point shifted
    alike along both axes, towards a corner for a smaller image, the far corner
    for a larger one), or of another camera or with fx and cx swapped. The
    points would be deprojected along the wrong rays, and a grasp planned on
    them lands centimetres to decimetres from the object."""
    fx, fy = (k.cx + 0.5) / w, (k.cy + 0.5) / h  # shares of the image
    lo, hi = _PRINCIPAL_SPAN
    alike = abs(fx - fy) < 0.5 * _RESOLUTION_SHIFT
    if alike and abs(fx - 0.5) > _RESOLUTION_SHIFT:
        W, H = round(2.0 * k.cx + 1.0), round(2.0 * k.cy + 1.0)
        raise InputError(
            f"depth image {name!r} is {w} x {h} pixels, but its intrinsics' "
            f"principal point ({k.cx:g}, {k.cy:g}) is the middle of a {W} x {H} "
            "image: they are the camera's at another resolution",
            hint=f"give the depth stream's intrinsics at {w} x {h} (camera_info's "
            f"K of the depth topic), or scale fx, fy, cx, cy by {w / W:.3g}",
        )
    if not (lo <= fx <= hi and lo <= fy <= hi):
        raise InputError(
            f"depth image {name!r} is {w} x {h} pixels, but its intrinsics put "
            f"the principal point ({k.cx:g}, {k.cy:g}) at {100 * fx:.0f} % of its "
            f"width and {100 * fy:.0f} % of its height, where a depth camera's "
            "lies near the middle",
            hint="check the order fx,fy,cx,cy (cx and cy are the principal point "
            "in pixels, about half the width and height; fx and fy the focal "
            "lengths) and that they are this camera's; for a crop of a larger "
            "image, give the whole image",
        )


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


def rectify_depth(depth: NDArray[np.generic], intrinsics: Intrinsics) -> NDArray[Any]:
    """The raw depth image ``(h, w)`` of a camera with a lens distortion as the
    pinhole camera of the same ``fx``, ``fy``, ``cx``, ``cy`` sees it: each
    pixel takes the depth of the raw pixel nearest where the lens puts its ray
    (OpenCV's and ROS's models: ``plumb_bob``, ``rational_polynomial``,
    ``equidistant``), as ``cv2.initUndistortRectifyMap`` and a nearest-pixel
    ``remap`` do, so that no depth is mixed across an object's outline; 0 where
    the ray lands off the raw image or past where the model stops growing
    outwards (no depth). The depths are kept: a depth camera's value is the
    distance along the optical axis, which rectification does not turn.

    The rectified image is again a pinhole camera's (every point on its pixel's
    ray through ``K``), which the flying-pixel filter
    (:mod:`wsgrasp.perception.flying`) reads its pixel grid from. A rectified
    pixel sits up to half a raw pixel from the ray it took the depth of:
    0.5 mm across at 1 m for a 600-pixel focal length. The pixel map is
    computed once per image size and camera (29 ms for 640 x 480 on the
    2-core development machine; then 0.6 ms an image).
    """
    d = np.asarray(depth)
    h, w = d.shape
    source = _rectify_map(h, w, intrinsics.model_dump_json())  # (h * w,) or -1
    out = np.zeros(h * w, dtype=d.dtype)
    ok = source >= 0
    out[ok] = d.reshape(-1)[source[ok]]
    return out.reshape(h, w)


@lru_cache(maxsize=8)
def _rectify_map(h: int, w: int, intrinsics_json: str) -> NDArray[np.int64]:
    """Per rectified pixel, row after row, the raw pixel nearest where its ray
    lands, ``(h * w,)`` indices into the raw image, -1 where none."""
    k = Intrinsics.model_validate_json(intrinsics_json)
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    x, y = (u - k.cx) / k.fx, (v - k.cy) / k.fy  # the rays, undistorted
    r = np.hypot(x, y)
    xd, yd = k.distort(x, y)
    # past the radius where the model's image of a ray stops moving outwards,
    # it folds back over the image: those rays see nothing
    grows = np.hypot(*k.distort(x * 1.001, y * 1.001)) > np.hypot(xd, yd)
    grows |= r == 0.0
    ud, vd = np.rint(k.fx * xd + k.cx), np.rint(k.fy * yd + k.cy)
    inside = grows & (ud >= 0) & (ud <= w - 1) & (vd >= 0) & (vd <= h - 1)
    source = np.full(h * w, -1, dtype=np.int64)
    source[inside.reshape(-1)] = (vd * w + ud)[inside].astype(np.int64)
    source.setflags(write=False)
    return source
