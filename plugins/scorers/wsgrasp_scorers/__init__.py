"""Built-in candidate scorers, registered through the ``wsgrasp`` entry-point group.

Each scorer is vectorised over the batch of feasible candidates and returns one
value per candidate, higher is better, within [0, 1] so that weights in a spec
compare like with like.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from wsgrasp.plugins import hookimpl

__all__ = [
    "AntipodalScorer",
    "ApproachDirectionScorer",
    "CentroidDistanceScorer",
    "ClosingCentreScorer",
    "ContactBalanceScorer",
    "JointMarginScorer",
    "MassCenterScorer",
    "PoseMarginScorer",
    "ReachDownScorer",
    "SqueezeInwardScorer",
    "TableClearanceScorer",
]


class _Options(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


def _touching(batch: Any) -> tuple[np.ndarray, np.ndarray]:
    """Which fingers hold object points, ``(F, nf)`` bool, and how many per
    candidate, ``(F,)`` (at least 1): every finger, unless the gripper names
    its ``contact_fingers`` and the others miss the object."""
    touching = batch.contacts > 0
    return touching, np.maximum(touching.sum(axis=1), 1)


def _nearness(d: np.ndarray, batch: Any) -> np.ndarray:
    """``1 / (1 + d / d_ref)`` for distances ``d`` (m), ``d_ref`` half the
    object's diagonal: 1 at no distance, monotone decreasing."""
    d_ref = max(0.5 * float(np.linalg.norm(batch.extents)), 1e-6)
    return 1.0 / (1.0 + d / d_ref)  # type: ignore[no-any-return]


class CentroidDistanceScorer:
    """The paper's criterion: the GWC frame's origin close to the object centroid.

    ``1 / (1 + d / d_ref)`` with ``d`` the distance and ``d_ref`` half the object's
    diagonal: monotone in ``d``, so the best candidate is the paper's. The
    centroid is ``batch.centroid``: that of the points, or behind it where the
    cameras saw one side of the object alone.
    """

    class Options(_Options):
        pass

    def score(self, batch: Any, options: Options) -> np.ndarray:
        d = np.linalg.norm(batch.gwc_origins - batch.centroid, axis=-1)
        return _nearness(d, batch)


class ClosingCentreScorer:
    """The point the fingers close to near the object's centre of mass.

    A hand that closes to its ``closed`` posture (``approach.close_to: closed``)
    grasps around where its pads meet, wherever its workspaces reach: a claw's
    tips converge below its base, a hand's fingertips in front of its palm. ``d``
    is the distance from that point (the pads' centroid at ``closed``, the end of
    their closing paths) to ``batch.mass_center``; the score is
    ``1 / (1 + d / d_ref)``, ``d_ref`` half the object's diagonal. For a jaw the
    point lies between its pads, as the workspace centre does.
    """

    class Options(_Options):
        pass

    def score(self, batch: Any, options: Options) -> np.ndarray:
        from wsgrasp.planning.closing import closing_centre

        c = closing_centre(batch.gripper)  # (3,) gripper frame
        T = batch.T_world_gripper  # (F, 4, 4)
        p = np.einsum("fij,j->fi", T[:, :3, :3], c) + T[:, :3, 3]
        d = np.linalg.norm(p - batch.mass_center, axis=-1)
        return _nearness(d, batch)


class ContactBalanceScorer:
    """Every finger holding a similar share of the object: ``min / max`` of the
    object points held per finger, over the fingers that hold some."""

    class Options(_Options):
        pass

    def score(self, batch: Any, options: Options) -> np.ndarray:
        counts = batch.contacts.astype(np.float64)  # (F, nf)
        touching, _ = _touching(batch)
        least = np.where(touching, counts, np.inf).min(axis=1)
        least = np.where(np.isfinite(least), least, 0.0)
        return least / np.maximum(counts.max(axis=1), 1.0)


class AntipodalScorer:
    """Contact normals that oppose each other and line up with the closing axis.

    Half of the term is the opposition of the fingers' mean contact normals,
    ``1 - |Σ n_f| / m`` (1 when they cancel), half is their alignment with the
    closing axis, ``mean |n_f · closing|``, over the ``m`` fingers that hold
    object points.
    """

    class Options(_Options):
        pass

    def score(self, batch: Any, options: Options) -> np.ndarray:
        n = batch.contact_normals  # (F, nf, 3), zero for a finger holding none
        _, m = _touching(batch)
        opposition = 1.0 - np.linalg.norm(n.sum(axis=1), axis=-1) / m
        alignment = np.abs(np.einsum("fnj,fj->fn", n, batch.closing)).sum(axis=1) / m
        return 0.5 * np.clip(opposition, 0.0, 1.0) + 0.5 * alignment


class WrenchBalanceScorer:
    """Equal pushes at the contacts that cancel: no net force and no net torque.

    Each finger that holds object points (``m`` of them) pushes with a unit
    force against the mean outward normal ``n_f`` of those points, at their
    centroid ``c_f``. The net force ``|sum n_f| / m`` and the net torque about
    the contacts' middle ``c``, ``|sum (c_f - c) x n_f| / (m r)`` with ``r``
    half the object's diagonal,
    are 0 for fingers that squeeze the object in place and grow as the squeeze
    pushes or twists it out of the hand (two fingers of a three-finger hand on
    one side, a jaw's pads offset along a face); the score is
    ``1 - (force + torque) / 2``, clipped to ``[0, 1]``. Unlike ``antipodal`` it
    does not prefer the closing axis and it sees torques.
    """

    class Options(_Options):
        pass

    def score(self, batch: Any, options: Options) -> np.ndarray:
        n = batch.contact_normals  # (F, nf, 3), zero for a finger holding none
        touching, m = _touching(batch)
        c = np.where(touching[..., None], batch.contact_centroids, 0.0)  # (F, nf, 3)
        force = np.linalg.norm(n.sum(axis=1), axis=-1) / m  # (F,)
        middle = c.sum(axis=1, keepdims=True) / m[:, None, None]  # (F, 1, 3)
        r = np.where(touching[..., None], c - middle, 0.0)  # (F, nf, 3)
        r_ref = max(0.5 * float(np.linalg.norm(batch.extents)), 1e-6)
        torque = np.linalg.norm(np.cross(r, n).sum(axis=1), axis=-1) / (m * r_ref)
        return np.clip(1.0 - 0.5 * (force + torque), 0.0, 1.0)


class ContactDepthScorer:
    """Fingers that reach down the object along the approach, not at its rim.

    ``d`` is how far the middle of the fingers' contacts (the mean of their
    centroids) lies past the object's nearest point along the approach axis, as
    a fraction of the object's length along it; the score is
    ``min(d / depth, 1)``: a grasp on the object's first millimetres scores 0.
    """

    class Options(_Options):
        depth: float = Field(
            0.5,
            gt=0.0,
            le=1.0,
            description="fraction of the object's length along the approach that "
            "earns the full score",
        )

    def score(self, batch: Any, options: Options) -> np.ndarray:
        a = batch.approach  # (F, 3) unit
        centre = np.nanmean(batch.contact_centroids, axis=1)  # (F, 3)
        proj = batch.object_points @ a.T  # (no, F)
        near, far = proj.min(axis=0), proj.max(axis=0)  # (F,)
        reach = np.einsum("fj,fj->f", centre, a) - near
        return np.clip(reach / np.maximum(far - near, 1e-9) / options.depth, 0.0, 1.0)


class TableClearanceScorer:
    """Distance between the gripper and the table, saturating at ``margin``."""

    class Options(_Options):
        margin: float = Field(
            0.03, gt=0.0, description="clearance (m) that earns the full score"
        )

    def score(self, batch: Any, options: Options) -> np.ndarray:
        return np.clip(batch.min_table_height / options.margin, 0.0, 1.0)


class ApproachDirectionScorer:
    """Preference for an approach direction: ``(1 + a · d) / 2``.

    ``direction`` is ``against_table`` (straight down onto the table), a vector
    in the world frame, or ``level``: an approach parallel to the table from any
    side, scored ``1 - |a · n|`` (``n`` the table's normal; 1 level, 0 straight
    down).
    """

    class Options(_Options):
        direction: Literal["against_table", "level"] | tuple[float, float, float] = (
            "against_table"
        )

    def score(self, batch: Any, options: Options) -> np.ndarray:
        if options.direction == "level":
            n = np.asarray(batch.table_normal, dtype=np.float64)
            return 1.0 - np.abs(batch.approach @ n)  # type: ignore[no-any-return]
        if options.direction == "against_table":
            d = -np.asarray(batch.table_normal, dtype=np.float64)
        else:
            d = np.asarray(options.direction, dtype=np.float64)
            d = d / max(float(np.linalg.norm(d)), 1e-12)
        return 0.5 * (1.0 + batch.approach @ d)


class JointMarginScorer:
    """Fingers that reach their contacts well inside their joint range.

    Per finger, the configuration whose pad lies nearest the points it holds
    (``batch.contact_configurations``); per joint, ``2 min(u, 1 - u)`` with ``u``
    its place between the limits (1 mid-range, 0 at a limit); the finger's term is
    its worst joint and the candidate's the worst finger. A jaw barely wide enough
    for the object, or closing on a sliver, scores low.
    """

    class Options(_Options):
        pass

    def score(self, batch: Any, options: Options) -> np.ndarray:
        g = batch.gripper
        k = batch.contact_configurations  # (F, nf)
        out = np.ones(len(batch))
        if not g.has_configurations:
            return out
        offsets = g.config_offsets
        for f in range(g.num_fingers):
            lim = np.asarray(g.finger_limits[f], dtype=np.float64)  # (d, 2)
            span = lim[:, 1] - lim[:, 0]
            moving = span > 0
            if not moving.any():
                continue
            rows = np.flatnonzero(k[:, f] >= 0)  # the candidates it holds in
            q = g.finger_configurations(f)[k[rows, f] - offsets[f]]  # (r, d)
            u = (q[:, moving] - lim[moving, 0]) / span[moving]
            margin = (2.0 * np.minimum(u, 1.0 - u)).min(axis=1)  # (r,)
            out[rows] = np.minimum(out[rows], np.clip(margin, 0.0, 1.0))
        return out


class MassCenterScorer:
    """The grasp axis passing near the object's estimated centre of mass.

    ``1 / (1 + d / d_ref)`` with ``d`` the distance from ``batch.mass_center``
    (the object's box middle, at half its height above the table) to the grasp
    axis, the line along the closing direction through the centre of the fingers'
    contacts, and ``d_ref`` half the object's diagonal. Gravity then pulls
    through the grip instead of twisting the object about it.
    """

    class Options(_Options):
        pass

    def score(self, batch: Any, options: Options) -> np.ndarray:
        centre = np.nanmean(batch.contact_centroids, axis=1)  # (F, 3)
        r = batch.mass_center - centre  # (F, 3)
        a = batch.closing  # (F, 3) unit
        across = r - np.einsum("fj,fj->f", r, a)[:, None] * a
        d = np.linalg.norm(across, axis=-1)
        return _nearness(d, batch)


class PoseMarginScorer:
    """A grasp that stays feasible when the gripper arrives a little off its pose.

    A robot reaches the planned pose only to within its hand-eye calibration
    and its own repeatability: millimetres and a degree or two. Each candidate
    is moved by ``offset`` (m) along -x, +x, -y, +y, -z and +z of the world and
    turned by ``angle_deg`` either way about the world's three axes through
    the object's centroid (12 poses, as the trials' execution error moves it);
    the score is the share of those poses at which the search would still find
    it feasible (``batch.feasible_at``: clear of the table and of every object,
    each contact finger holding object points). A grasp whose fingers only just
    reach the object, or whose body only just clears it or a neighbour, scores
    low.
    """

    class Options(_Options):
        offset: float = Field(
            0.005, ge=0.0, description="how far (m) each pose is moved along each axis"
        )
        angle_deg: float = Field(
            3.0,
            ge=0.0,
            description="how far (degrees) each pose is turned about each axis",
        )

    def score(self, batch: Any, options: Options) -> np.ndarray:
        from scipy.spatial.transform import Rotation

        F = len(batch)
        eye = np.eye(3)
        steps = np.concatenate([-eye, eye])  # (6, 3) -x, -y, -z, +x, +y, +z
        moves = np.tile(np.eye(4), (12, 1, 1))  # (12, 4, 4) world motions
        moves[:6, :3, 3] = options.offset * steps
        R = Rotation.from_rotvec(np.radians(options.angle_deg) * steps).as_matrix()
        c = np.asarray(batch.T_world_object[:3, 3], dtype=np.float64)
        moves[6:, :3, :3] = R
        moves[6:, :3, 3] = c - R @ c  # about the centroid
        T = np.einsum("kij,fjl->fkil", moves, batch.T_world_gripper)  # (F, 12, 4, 4)
        ok = batch.feasible_at(T.reshape(F * 12, 4, 4)).reshape(F, 12)
        return ok.mean(axis=1)  # type: ignore[no-any-return]


class ReachDownScorer:
    """A gripper that reaches down the object, not one that holds it by its top.

    ``h`` is the gripper cloud's lowest point above the table (the pre-grasp
    posture, as the table test sees it) and ``top`` the object's highest point
    above the table. The score is ``(top - h) / min(top, depth)``, clipped to
    ``[0, 1]``: 1 for a gripper that comes ``depth`` down from the object's top,
    or down to the table where the object is lower than that; 0 for one whose
    lowest point stays level with the top. Without ``depth`` the full score
    needs the table for every object. Without a table every candidate scores 1.
    """

    class Options(_Options):
        depth: float | None = Field(
            None,
            gt=0.0,
            description="how far (m) below the object's top the gripper's lowest "
            "point earns the full score; none: down to the table",
        )

    def score(self, batch: Any, options: Options) -> np.ndarray:
        if batch.T_world_table is None:
            return np.ones(len(batch))
        n = batch.T_world_table[:3, 2]
        origin = batch.T_world_table[:3, 3]
        top = max(float(((batch.object_points - origin) @ n).max()), 1e-6)
        full = top if options.depth is None else min(top, options.depth)
        return np.clip((top - batch.min_table_height) / full, 0.0, 1.0)


class SqueezeInwardScorer:
    """A squeeze that presses the object towards the palm, not out of the hand.

    Each finger that holds object points (``m`` of them) pushes against the
    mean outward normal ``n_f`` of those points. The share of the fingers' summed
    push along the approach direction ``a`` (from the hand into the object),
    ``e = -(sum n_f) . a / m``, is
    positive where the fingers grip a face that turns back towards the hand (a
    rounded top, the upper edge of a flat object, a cone from above): squeezing
    there pushes the object away from the palm, out through the fingertips,
    and once lifted nothing but friction holds it in. The score is
    ``(1 - e) / 2``: 1 for a push straight into the palm, 0.5 for a push
    square across the approach, 0 for a push straight out.
    """

    class Options(_Options):
        pass

    def score(self, batch: Any, options: Options) -> np.ndarray:
        n = batch.contact_normals  # (F, nf, 3), zero for a finger holding none
        _, m = _touching(batch)
        e = -np.einsum("fj,fj->f", n.sum(axis=1), batch.approach) / m
        return np.clip(0.5 * (1.0 - e), 0.0, 1.0)


@hookimpl
def wsgrasp_register_scorers(register: Any) -> None:
    register("centroid_distance", CentroidDistanceScorer)
    register("closing_centre", ClosingCentreScorer)
    register("contact_balance", ContactBalanceScorer)
    register("antipodal", AntipodalScorer)
    register("wrench_balance", WrenchBalanceScorer)
    register("contact_depth", ContactDepthScorer)
    register("table_clearance", TableClearanceScorer)
    register("approach_direction", ApproachDirectionScorer)
    register("joint_margin", JointMarginScorer)
    register("mass_center", MassCenterScorer)
    register("pose_margin", PoseMarginScorer)
    register("reach_down", ReachDownScorer)
    register("squeeze_inward", SqueezeInwardScorer)
