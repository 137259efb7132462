"""Data passed between the perception stages and the segmenter plugins."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol

import numpy as np
import xxhash
from numpy.typing import NDArray
from pydantic import BaseModel

__all__ = ["View", "Scene", "Plane", "Segmentation", "Segmenter"]

Array = NDArray[np.float64]


@dataclass
class View:
    """One depth view: its points in the camera frame and the camera's pose.

    Attributes
    ----------
    points : (n, 3) float
        In the camera frame.
    T_world_camera : (4, 4) float
    """

    points: Array
    T_world_camera: Array = field(default_factory=lambda: np.eye(4))
    name: str = ""

    @property
    def posed(self) -> bool:
        """Whether the view was given a pose (one with the identity pose is a
        cloud given without one, in the world frame)."""
        return not np.array_equal(self.T_world_camera, np.eye(4))


@dataclass
class Scene:
    """The planner's input: one or more views merged into the world frame.

    Attributes
    ----------
    views : list of View
    points : (N, 3) float
        Merged finite points in the world (input) frame.
    dropped_nonfinite : int
        NaN/inf points, and points beyond 1e12 m (a sensor's FLT_MAX for no
        return), removed while merging.
    dropped_no_depth : int
        Points at their own camera's centre, ``(0, 0, 0)`` in their view,
        removed while merging: what depth cameras and their SDKs (RealSense's
        ``get_vertices``, Azure Kinect's point cloud image, ``z = depth`` with
        a depth of 0) give a pixel without a depth.
    """

    views: list[View]
    points: Array
    dropped_nonfinite: int = 0
    dropped_no_depth: int = 0
    #: :meth:`digest` when ``points`` was computed as the merge of ``views`` (set
    #: by the scene loaders). A recorder whose scene still has this digest knows
    #: the points are that merge without merging again.
    merged_digest: int | None = field(default=None, repr=False, compare=False)

    def digest(self) -> int:
        """XXH3 of the views (points and poses) and the merged points: their
        dtypes, shapes and bytes (about 0.03 ms a million values)."""
        h = xxhash.xxh3_64()
        arrays = [a for v in self.views for a in (v.points, v.T_world_camera)]
        seen: dict[int, int] = {}
        for i, a in enumerate([*arrays, self.points]):
            if id(a) in seen:  # the same array again (one view as the merge)
                h.update(f"={seen[id(a)]};".encode())
                continue
            seen[id(a)] = i
            arr = np.ascontiguousarray(a)
            h.update(f"{arr.dtype.str}{arr.shape};".encode())
            h.update(arr.reshape(-1).view(np.uint8).data)
        return h.intdigest()

    def viewpoints(self) -> Array:
        """Camera centres ``(k, 3)`` in the world frame, of the views whose pose
        was given, and of the clouds given without one that are still their
        camera's image (:func:`wsgrasp.perception.flying.pixel_grid`: each
        point on its pixel's ray from the origin), whose camera is the origin.
        Another cloud without a pose tells nothing of where its sensor was."""
        from wsgrasp.perception.flying import pixel_grid

        centres = [
            np.asarray(v.T_world_camera, dtype=np.float64)[:3, 3]
            for v in self.views
            if v.posed or pixel_grid(v.points) is not None
        ]
        return np.array(centres).reshape(-1, 3)

    def view_tables(
        self, plane: Plane, at: Array, band: float = 0.05, sample: int = 2000
    ) -> list[tuple[str, Array, float] | None]:
        """Per view, the table as that view alone sees it: ``(name, normal,
        height)``, the plane fitted to its points within ``band`` of ``plane``
        (at most ``sample`` of them, every k-th) and its height over ``plane``
        along ``plane``'s normal at the point ``at`` ``(3,)``; None for a view
        that sees under 300 such points. Views whose poses disagree see tables
        apart, however well each is fitted."""
        out: list[tuple[str, Array, float] | None] = []
        n0 = np.asarray(plane.normal, dtype=np.float64)
        for i, v in enumerate(self.views):
            pts = np.asarray(v.points)  # every k-th first: views hold 300,000
            pts = np.asarray(pts[:: max(1, len(pts) // sample)], dtype=np.float64)
            T = np.asarray(v.T_world_camera, dtype=np.float64)
            w = pts @ T[:3, :3].T + T[:3, 3]
            q = w[np.abs(plane.signed_distance(w)) < band]
            fit = None
            # the plane, then again without what stands off it, narrower each time
            for keep in (0.01, 0.005, None):
                if len(q) < 300:
                    break
                c = q.mean(axis=0)
                d = q - c
                n = np.linalg.eigh(d.T @ d)[1][:, 0]  # the least spread direction
                n = n if n @ n0 >= 0 else -n
                fit = (c, n)
                if keep is not None:
                    q = q[np.abs((q - c) @ n) < keep]
            if fit is None:
                out.append(None)
                continue
            c, n = fit
            # where the line through `at` along n0 meets this view's plane
            height = float((c - at) @ n / max(float(n @ n0), 1e-9))
            out.append((v.name or f"view {i}", n, height))
        return out

    def table_tilt(self, normal: Array) -> float | None:
        """The angle (degrees) between a plane's ``normal`` and the world's z
        axis where a view was given a pose (the world is then likely a robot's
        or a room's frame, z up); None where none was (the world is a camera's
        frame, in which a table is tilted)."""
        if not any(v.posed for v in self.views):
            return None
        return float(np.degrees(np.arccos(min(1.0, abs(float(normal[2]))))))

    def is_merge(self) -> bool:
        """Whether a loader merged ``points`` from ``views`` and neither changed
        since (:attr:`merged_digest`)."""
        return self.merged_digest is not None and self.digest() == self.merged_digest


@dataclass
class Plane:
    """The table plane ``normal · p + offset = 0``, normal pointing to the objects."""

    normal: Array
    offset: float

    def signed_distance(self, points: Array) -> Array:
        """Heights of points ``(n, 3)`` above the plane, ``(n,)``."""
        return np.asarray(points, dtype=np.float64) @ self.normal + self.offset


@dataclass
class Segmentation:
    """What a segmenter returns.

    Attributes
    ----------
    table : Plane
    table_points : (m, 3) float
        Inliers of the plane (may be empty when the plane was given).
    clusters : list of (n_i, 3) float
        Objects standing on the table, largest first.
    """

    table: Plane
    table_points: Array
    clusters: list[Array]
    info: dict[str, Any] = field(default_factory=dict)


class Segmenter(Protocol):
    """What a segmenter plugin registers: a class with an ``Options`` model."""

    Options: ClassVar[type[BaseModel]]

    def segment(self, points: Array, options: Any, *, seed: int) -> Segmentation:
        """Split a scene ``(N, 3)`` into table plane and object clusters, or raise
        ``InputError`` saying why not.

        A segmenter may also take ``viewpoints``, the camera centres ``(k, 3)``
        where they are known: the table's upper side is the one they look from.
        The pipeline passes it to segmenters whose ``segment`` accepts it."""
        ...
