"""Scoring feasible candidates: the batch scorers see, and their weighted sum."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel

from wsgrasp.errors import PluginError
from wsgrasp.geometry import invert_transforms, transform_points
from wsgrasp.gripper.model import GripperModel
from wsgrasp.perception.sides import behind_the_side
from wsgrasp.planning.holdings import HoldingField, Holdings
from wsgrasp.planning.poses import PoseRows
from wsgrasp.planning.result import PoseField
from wsgrasp.planning.targets import config_tree

__all__ = ["CandidateBatch", "Scorer", "combine_scores"]

Array = NDArray[np.float64]


@dataclass
class CandidateBatch:
    """The feasible candidates ``F``, as scorers see them. World frame throughout.

    Attributes
    ----------
    gripper : GripperModel
    T_world_gwc, T_world_gripper : (F, 4, 4) float
        May be given as :class:`~wsgrasp.planning.poses.PoseRows`, built only
        if something reads them (a dense search's feasible poses took 12 ms of
        the Allegro hand's dense search); :attr:`approach`, :attr:`closing` and
        :attr:`gwc_origins` are read without them.
    theta : (F,) float
    holding : (F, no, nf) bool
        Which object points each finger's spheres hold. May be given as a
        :class:`~wsgrasp.planning.holdings.Holdings`, whose mask is built only
        if something reads ``holding``; counts, centroids and normals are
        computed from the held points without it.
    object_points : (no, 3) float
    T_world_object : (4, 4) float
        Origin at the object's centroid, z along its major axis.
    extents : (3,) float
        Object extents along the object axes.
    table_normal : (3,) float
        Unit normal of the table, pointing to the object.
    min_table_height : (F,) float
        Lowest gripper point above the table surface.
    T_world_table : (4, 4) float or None
        The table frame: origin on the surface, z its normal towards the object.
    normals_fn : callable, optional
        ``normals_fn(object_points)``: their outward unit normals, ``(no, 3)``.
    normals_of : callable, optional
        ``normals_of(object_points, rows)``: the normals of the points ``rows``
        ``(r,)`` alone, ``(r, 3)``, each bit for bit the one ``normals_fn``
        gives it. With it, :attr:`contact_normals` estimates only the normals of
        the points some finger holds.
    feasible_fn : callable, optional
        ``feasible_fn(T_world_gripper)``: for poses ``(M, 4, 4)`` of the
        gripper, ``(M,)`` bool, whether each passes the search's checks on this
        scene (table, body against the object and its neighbours, every contact
        finger holding object points), as a candidate at that pose would.
    viewpoints : (k, 3) float, optional
        The centres of the cameras that saw the scene, where their poses were
        given (for :attr:`centroid` and :attr:`mass_center`).
    """

    gripper: GripperModel
    if TYPE_CHECKING:  # read as arrays; set as arrays or PoseRows
        T_world_gwc: Array
        T_world_gripper: Array
    else:
        T_world_gwc: Array = PoseField()
        T_world_gripper: Array = PoseField()
    theta: Array
    if TYPE_CHECKING:  # read as the array; set as the array or Holdings
        holding: NDArray[np.bool_]
    else:
        holding: NDArray[np.bool_] = HoldingField()
    object_points: Array
    T_world_object: Array
    extents: Array
    table_normal: Array
    min_table_height: Array
    normals_fn: Callable[[Array], Array] | None = field(default=None, repr=False)
    T_world_table: Array | None = None
    normals_of: Callable[[Array, NDArray[np.int64]], Array] | None = field(
        default=None, repr=False
    )
    feasible_fn: Callable[[Array], NDArray[np.bool_]] | None = field(
        default=None, repr=False
    )
    viewpoints: Array | None = None

    def __len__(self) -> int:
        return len(self.theta)

    @property
    def holdings(self) -> Holdings:
        """``holding`` as :class:`~wsgrasp.planning.holdings.Holdings` (counts,
        blocks of rows, sums over the held points), without building the mask."""
        return type(self).__dict__["holding"].holdings_of(self)  # type: ignore[no-any-return]

    def feasible_at(self, T_world_gripper: Array) -> NDArray[np.bool_]:
        """Whether the gripper at each pose ``(M, 4, 4)`` passes the search's
        checks on this scene, ``(M,)`` (``feasible_fn``)."""
        if self.feasible_fn is None:
            raise PluginError(
                "this batch cannot test other poses",
                hint="plan through wsgrasp.Pipeline, which provides feasible_fn",
            )
        return self.feasible_fn(T_world_gripper)

    @cached_property
    def contacts(self) -> NDArray[np.int64]:
        """Object points held per finger, ``(F, nf)``."""
        return self.holdings.counts

    @cached_property
    def contact_centroids(self) -> Array:
        """Centroid of the points each finger holds, ``(F, nf, 3)`` (NaN if none)."""
        sums = self.holdings.sums(self.object_points)  # (F, nf, 3)
        with np.errstate(invalid="ignore", divide="ignore"):
            return sums / self.contacts[..., None]

    @cached_property
    def object_normals(self) -> Array:
        """Outward unit surface normals of the object points, ``(no, 3)``."""
        if self.normals_fn is None:
            raise PluginError(
                "this batch has no surface normals",
                hint="plan through wsgrasp.Pipeline, which provides them",
            )
        return self.normals_fn(self.object_points)

    @cached_property
    def contact_normals(self) -> Array:
        """Mean outward normal of the points each finger holds, unit, ``(F, nf, 3)``
        (zero where a finger holds nothing)."""
        n = self.holdings.sums(self._held_normals())  # (F, nf, 3)
        norm = np.linalg.norm(n, axis=-1, keepdims=True)
        return np.divide(n, norm, out=np.zeros_like(n), where=norm > 0)

    def _held_normals(self) -> Array:
        """``object_normals`` where a finger of some candidate holds the point,
        ``(no, 3)``: for those points alone (zero elsewhere) with ``normals_of``,
        dense holdings (else finding the held points builds every row) and no
        normals of every point known yet. The sums over the held points are the
        same either way: an unheld point adds ``0 * n``, a zero."""
        h = self.holdings
        known = "object_normals" in self.__dict__
        if self.normals_of is None or known or not h.is_dense:
            return self.object_normals
        # (F, no, nf) -> (no, nf) -> (no,); one axis at a time: 10x faster
        anyone = np.any(h.dense(), axis=0)  # (no, nf)
        held = np.flatnonzero(np.any(anyone, axis=1))  # (r,) points
        out = np.zeros((h.num_points, 3))
        out[held] = self.normals_of(self.object_points, held)
        return out

    @cached_property
    def contact_centroids_gripper(self) -> Array:
        """``contact_centroids`` in each candidate's gripper frame, ``(F, nf, 3)``."""
        T_gripper_world = invert_transforms(self.T_world_gripper)  # (F, 4, 4)
        return transform_points(T_gripper_world, self.contact_centroids)

    @cached_property
    def contact_configurations(self) -> NDArray[np.int64]:
        """Per candidate and finger, the finger configuration (index into the
        model's ``config_pad``) whose pad centre lies nearest the points the
        finger holds, ``(F, nf)``; -1 where the model keeps no configurations
        or the finger holds nothing (one outside ``contact_fingers``)."""
        g = self.gripper
        out = np.full(self.contacts.shape, -1, dtype=np.int64)
        if not g.has_configurations:
            return out
        for f in range(g.num_fingers):
            rows = np.flatnonzero(self.contacts[:, f] > 0)
            _, k = config_tree(g, f).query(self.contact_centroids_gripper[rows, f])
            out[rows, f] = g.config_offsets[f] + np.asarray(k, dtype=np.int64)
        return out

    @cached_property
    def mass_center(self) -> Array:
        """Estimated centre of mass of the object, world frame, ``(3,)``.

        The middle of the object's box in the object frame, lowered or raised
        along the table normal to half the object's height above the table (a
        resting object reaches down to the table, whatever the camera saw), and
        moved away from cameras that saw one side of it alone
        (:func:`behind_the_side`).
        """
        R = self.T_world_object[:3, :3]
        p = (self.object_points - self.T_world_object[:3, 3]) @ R  # (no, 3) object
        mid = self.T_world_object[:3, 3] + R @ (0.5 * (p.min(axis=0) + p.max(axis=0)))
        if self.T_world_table is None:
            return mid
        n, origin = self.T_world_table[:3, 2], self.T_world_table[:3, 3]
        top = float(((self.object_points - origin) @ n).max())
        mid = mid + (0.5 * top - float((mid - origin) @ n)) * n
        return mid + self._behind_the_side(mid)

    @cached_property
    def centroid(self) -> Array:
        """The object's centroid, world frame, ``(3,)``: the object frame's
        origin (the centroid of the points), moved away from cameras that saw
        one side of it alone (:func:`behind_the_side`)."""
        c = np.asarray(self.T_world_object[:3, 3], dtype=np.float64)
        return c + self._behind_the_side(c)

    def _behind_the_side(self, middle: Array) -> Array:
        """:func:`behind_the_side` of ``middle`` ``(3,)``; zeros without the
        table or the cameras' poses."""
        v = self.viewpoints
        if self.T_world_table is None or v is None or not len(v):
            return np.zeros(3)
        return behind_the_side(self.object_points, middle, self.T_world_table[:3, 2], v)

    @property
    def approach(self) -> Array:
        """Approach direction of each candidate, ``(F, 3)`` (GWC z)."""
        return self._gwc(lambda R, t: R[:, :, 2])

    @property
    def closing(self) -> Array:
        """Closing direction of each candidate, ``(F, 3)`` (GWC y)."""
        return self._gwc(lambda R, t: R[:, :, 1])

    @property
    def gwc_origins(self) -> Array:
        """Origin of each candidate's GWC frame, ``(F, 3)``."""
        return self._gwc(lambda R, t: t)

    def _gwc(self, part: Callable[[Array, Array], Array]) -> Array:
        """``part(R, t)`` of the GWC poses' rotations ``(F, 3, 3)`` and
        translations ``(F, 3)``, without building ``T_world_gwc`` where it is
        kept as :class:`~wsgrasp.planning.poses.PoseRows` (``parts``)."""
        kept = type(self).__dict__["T_world_gwc"].stored(self)
        if isinstance(kept, PoseRows):
            return part(*kept.parts)
        T = kept.whole()
        return part(T[:, :3, :3], T[:, :3, 3])


class Scorer(Protocol):
    """What a scorer plugin registers: a class with an ``Options`` model and a
    vectorised ``score``; higher is better, ideally within [0, 1]."""

    Options: ClassVar[type[BaseModel]]

    def score(self, batch: CandidateBatch, options: Any) -> Array:
        """One score per candidate of ``batch``, ``(F,)``."""
        ...


def combine_scores(
    batch: CandidateBatch,
    scorers: Sequence[tuple[str, Any, Any, float]],
) -> tuple[Array, dict[str, Array]]:
    """Weighted sum of the scorers' terms.

    Parameters
    ----------
    batch : CandidateBatch
    scorers : sequence of (name, scorer, options, weight)

    Returns
    -------
    total : (F,) float
    terms : dict of name to (F,) float
    """
    total = np.zeros(len(batch))
    terms: dict[str, Array] = {}
    for name, scorer, options, weight in scorers:
        try:
            values = np.asarray(scorer.score(batch, options), dtype=np.float64)
        except PluginError:
            raise
        except Exception as exc:  # noqa: BLE001 - a plugin's failure, reported
            raise PluginError(
                f"scorer {name!r} raised {type(exc).__name__}: {exc}",
                hint="fix the scorer plugin or remove it from the spec's scorers",
            ) from exc
        if values.shape != (len(batch),) or not np.all(np.isfinite(values)):
            raise PluginError(
                f"scorer {name!r} returned {values.shape} values (finite: "
                f"{bool(np.all(np.isfinite(values)))}), expected {len(batch)} finite",
                hint="a scorer returns one finite float per candidate",
            )
        terms[name] = values
        total = total + weight * values
    return total, terms
