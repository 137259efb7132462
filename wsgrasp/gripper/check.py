"""``wsgrasp gripper check``: what an engineer needs to trust a gripper model.

:func:`check_gripper` builds (or loads) the model and reports, per finger, the
workspace volume and how much of it the spheres cover; whether the pads close
towards and face the other fingers; the fraction of the gripper cloud inside the
body superellipsoids; superellipsoids that swallow part of a finger's workspace;
joints that move nothing; fingers whose workspace stays away from every other
finger's; an implausible overall size. Each problem names the YAML field to change.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from wsgrasp.geometry import points_in_superellipsoids
from wsgrasp.gripper.model import GripperModel

__all__ = ["CheckReport", "Problem", "check_gripper"]

Array = NDArray[np.float64]

#: sphere coverage of a finger's workspace below this is reported
MIN_COVERAGE = 0.3
#: cloud fraction inside the body superellipsoids below this is an error
MIN_CLOUD_INSIDE = 0.98
#: a superellipsoid holding more than this fraction of a finger workspace: warning
INTRUSION_WARN = 0.10
#: ... and more than this: error (object points there reject every grasp); for
#: the superellipsoids round a finger's own links open, their union's fraction
INTRUSION_ERROR = 0.35
#: a superellipsoid is round a finger's own links where more than this share of
#: the body surface inside it lies on links the finger's joints move
OWN_SHARE = 0.5
#: a joint that moves no geometry by more than this (m) moves nothing
MIN_MOTION = 1e-4
#: a pad normal within this cosine of the direction to the others faces them
FACING_COS = 0.3
#: a finger whose workspace stays farther (m) from every other finger's is reported
MAX_FINGER_GAP = 0.01
#: plausible gripper sizes (m)
SIZE_RANGE = (0.01, 1.0)


@dataclass(frozen=True)
class Problem:
    """One thing wrong (``error``) or suspicious (``warning``) with a gripper."""

    severity: Literal["error", "warning"]
    field: str
    message: str
    fix: str


@dataclass
class CheckReport:
    """The result of :func:`check_gripper`.

    Attributes
    ----------
    fingers : list of dict
        Per finger: name, workspace_volume_m3, covered_fraction, spheres,
        pad_closes_mm (how much nearer the others the pad gets when closing),
        pad_facing_deg (angle between pad normal and the direction to the others),
        on_table ("slides" or "sticks": what the search takes the tip to do where
        its closing sweep meets the table) and on_table_given (the description
        says so, rather than the search's guess).
    intrusions : list of dict
        Superellipsoid index, finger, fraction of that finger's workspace inside.
    """

    name: str
    model: GripperModel
    size_m: float
    fingers: list[dict[str, Any]] = field(default_factory=list)
    cloud_inside_se: float = 1.0
    intrusions: list[dict[str, Any]] = field(default_factory=list)
    idle_joints: list[str] = field(default_factory=list)
    problems: list[Problem] = field(default_factory=list)

    @property
    def errors(self) -> list[Problem]:
        return [p for p in self.problems if p.severity == "error"]

    @property
    def warnings(self) -> list[Problem]:
        return [p for p in self.problems if p.severity == "warning"]

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "size_m": self.size_m,
            "max_opening_m": self.model.max_opening,
            "fingers": self.fingers,
            "cloud_inside_se": self.cloud_inside_se,
            "intrusions": self.intrusions,
            "idle_joints": self.idle_joints,
            "problems": [p.__dict__ for p in self.problems],
        }

    def format(self) -> str:
        """The report as plain text, one finger or problem a line."""
        m = self.model
        lines = [
            f"gripper {self.name}: {m.num_fingers} finger(s), "
            f"{len(m.se_centers)} superellipsoids, {len(m.cloud)} cloud points, "
            f"{self.size_m * 1000:.0f} mm across, max opening "
            f"{m.max_opening * 1000:.0f} mm"
        ]
        for f in self.fingers:
            facing = (
                f", pad faces the others at {f['pad_facing_deg']:.0f} deg"
                if f.get("pad_facing_deg") is not None
                else ""
            )
            closes = (
                f", closing brings the pad {f['pad_closes_mm']:+.1f} mm nearer"
                if f.get("pad_closes_mm") is not None
                else ""
            )
            table = (
                f", tip {f['on_table']} on the table"
                + ("" if f.get("on_table_given") else " (guessed)")
                if f.get("on_table")
                else ""
            )
            lines.append(
                f"  finger {f['name']}: workspace {f['workspace_volume_m3'] * 1e6:.1f}"
                f" cm3, {f['spheres']} spheres cover {f['covered_fraction']:.0%}"
                f"{closes}{facing}{table}"
            )
        needed = [
            n for n, c in zip(m.finger_names, m.contact_fingers, strict=True) if c
        ]
        if len(needed) < m.num_fingers:
            free = [n for n in m.finger_names if n not in needed]
            lines.append(
                f"  a grasp needs {', '.join(needed)} on the object "
                f"(contact_fingers); {', '.join(free)} may miss it"
            )
        lines.append(
            f"  cloud inside the body superellipsoids: {self.cloud_inside_se:.1%}"
        )
        for s in self.intrusions:
            lines.append(
                f"  superellipsoid {s['ellipsoid']} holds {s['fraction']:.0%} of "
                f"finger {s['finger']}'s workspace"
                + (" (its own links, open)" if s.get("own_link") else "")
            )
        if not self.problems:
            lines.append("no problems found")
        for p in self.problems:
            lines.append(f"{p.severity}: {p.message} [field: {p.field}] fix: {p.fix}")
        return "\n".join(lines)


def _pad_frame(
    kin: Any, base: str, link: str, posture: dict[str, float]
) -> NDArray[np.float64]:
    return np.asarray(kin.chain_poses(base, link, posture))


def check_gripper(
    name_or_path: str | Path,
    *,
    registry: Any | None = None,
    cache_dir: str | Path | None = None,
    rebuild: bool = False,
    progress: Any | None = None,
) -> CheckReport:
    """Build (or load from the cache) a gripper and check it.

    Parameters
    ----------
    name_or_path
        A registered gripper name or a gripper YAML.
    registry, cache_dir, rebuild, progress
        As for :func:`wsgrasp.gripper.load_gripper`.

    Raises
    ------
    WsgraspError
        When the model cannot be built at all (the error names the field).
    """
    from wsgrasp.gripper import load_gripper, resolve_gripper

    model = load_gripper(
        name_or_path,
        registry=registry,
        cache_dir=cache_dir,
        rebuild=rebuild,
        progress=progress,
    )
    resolved = resolve_gripper(name_or_path, registry)
    extent = model.cloud.max(axis=0) - model.cloud.min(axis=0)
    report = CheckReport(model.name, model, float(np.max(extent)))
    report.cloud_inside_se = float(model.stats.get("cloud_inside_se", 1.0))
    on_table = _on_table(model)
    for f, stats in zip(
        model.finger_names, model.stats.get("fingers", []), strict=False
    ):
        report.fingers.append(
            {
                "name": f,
                "workspace_volume_m3": float(stats.get("workspace_volume_m3", 0.0)),
                "covered_fraction": float(stats.get("covered_fraction", 0.0)),
                "spheres": int(np.sum(model.sphere_finger == len(report.fingers))),
                **on_table[len(report.fingers)],
            }
        )
    _check_size(report)
    _check_cloud(report)
    if isinstance(resolved, GripperModel):
        return report  # registered as a built model: no URDF to look into
    desc, base_dir = resolved
    _check_kinematics(report, desc, base_dir)
    return report


def _on_table(model: GripperModel) -> list[dict[str, Any]]:
    """Per finger, whether the search takes its tip to slide along the table or
    to stick there (``on_table``), and whether the description says so or it is
    guessed (``on_table_given``)."""
    from wsgrasp.planning.sweeps import declared_on_table, slides

    if not model.has_configurations:
        return [{} for _ in model.finger_names]
    return [
        {"on_table": "slides" if s else "sticks", "on_table_given": said is not None}
        for s, said in zip(slides(model), declared_on_table(model), strict=True)
    ]


def _add(report: CheckReport, *args: Any) -> None:
    report.problems.append(Problem(*args))


def _check_size(report: CheckReport) -> None:
    lo, hi = SIZE_RANGE
    if report.size_m > hi:
        _add(
            report,
            "error",
            "urdf",
            f"the gripper is {report.size_m:.2f} m across: a URDF in millimetres, "
            "or more than the gripper below base_link?",
            "URDF lengths are metres: scale the meshes (<mesh scale='0.001 0.001 "
            "0.001'>) or rescaffold with --mesh-units mm; where base_link carries "
            "an arm, set it to the link the arm holds",
        )
    elif report.size_m < lo:
        _add(
            report,
            "error",
            "urdf",
            f"the gripper is only {report.size_m * 1000:.1f} mm across",
            "check the <mesh scale> values in the URDF",
        )
    for f in report.fingers:
        if f["covered_fraction"] < MIN_COVERAGE:
            _add(
                report,
                "warning",
                "spheres_per_finger",
                f"finger {f['name']}'s spheres cover only {f['covered_fraction']:.0%} "
                "of its workspace, so grasps there are missed",
                "raise spheres_per_finger (or lower min_sphere_radius)",
            )


def _check_cloud(report: CheckReport) -> None:
    if report.cloud_inside_se < MIN_CLOUD_INSIDE:
        _add(
            report,
            "error",
            "ellipsoids",
            f"only {report.cloud_inside_se:.1%} of the gripper cloud is inside the "
            "body superellipsoids, so collisions with those parts go unseen",
            "remove ellipsoids.given to fit them, or enlarge the given ones",
        )


def enveloping_links(kin: Any, data: dict[str, Any]) -> set[str]:
    """The links whose own shapes hold most of some finger's workspace (see
    :func:`_enveloping_link`) in the guessed description ``data`` read from the
    URDF ``kin``: an envelope drawn round the fingers for arm motion planning.
    Only fingers whose pad centre, open, lies inside some link's shapes off its
    chain have their workspaces sampled."""
    from wsgrasp.gripper._urdf import shape_mesh
    from wsgrasp.gripper._workspace import sample_workspace
    from wsgrasp.spec import GripperDescription

    desc = GripperDescription.model_validate(data)
    pre = dict(desc.pregrasp)
    poses = kin.link_poses(desc.base_link, pre)
    out: set[str] = set()
    for finger in desc.fingers:
        chain = {j.child for j in kin.chain(desc.base_link, finger.pad.link)}
        chain.add(finger.pad.link)
        T = _pad_frame(kin, desc.base_link, finger.pad.link, pre)
        pad = T[:3, :3] @ np.asarray(finger.pad.center) + T[:3, 3]
        suspect = False
        for link, shapes in kin.shapes.items():
            if link in chain or link not in poses or not shapes:
                continue
            Tl = poses[link]
            local = (pad - Tl[:3, 3]) @ Tl[:3, :3]
            if any(
                shape_mesh(sh).convex_hull.contains(local[None])[0] for sh in shapes
            ):
                suspect = True
                break
        if not suspect:
            continue
        ws = sample_workspace(kin, desc, finger)
        pts = ws.centers(np.argwhere(ws.occupied))
        hit = _enveloping_link(kin, desc, finger, pts, pre)
        if hit is not None:
            out.add(hit[0])
    return out


def _enveloping_link(
    kin: Any,
    desc: Any,
    finger: Any,
    pts: NDArray[np.float64],
    posture: dict[str, float],
) -> tuple[str, float] | None:
    """The link off ``finger``'s chain whose shapes (each as its convex hull, in
    ``posture``) hold the largest fraction of the finger's workspace points
    ``pts`` ``(W, 3)``, and that fraction, where it passes ``INTRUSION_ERROR``;
    else None."""
    from wsgrasp.gripper._urdf import shape_mesh

    chain = {j.child for j in kin.chain(desc.base_link, finger.pad.link)}
    chain.add(finger.pad.link)  # a rigid jaw's pad lies against its own link
    poses = kin.link_poses(desc.base_link, posture)
    best: tuple[str, float] | None = None
    for link, shapes in kin.shapes.items():
        if link in chain or link not in poses or not shapes or not len(pts):
            continue
        T = poses[link]
        local = (pts - T[:3, 3]) @ T[:3, :3]  # (W, 3) in the link's frame
        inside = np.zeros(len(pts), dtype=bool)
        for shape in shapes:
            hull = shape_mesh(shape).convex_hull
            lo, hi = hull.bounds
            near = np.flatnonzero(np.all((local >= lo) & (local <= hi), axis=1))
            if len(near):
                inside[near] |= hull.contains(local[near])
        frac = float(np.mean(inside))
        if frac > INTRUSION_ERROR and (best is None or frac > best[1]):
            best = (link, frac)
    return best


def _own_ellipsoids(kin: Any, desc: Any, model: GripperModel) -> list[set[int]]:
    """Per finger, the body superellipsoids fitted round its own links in the
    pre-grasp posture: those most of whose body surface (sampled as the builder
    samples it) lies on links that the finger's joints move."""
    from wsgrasp.gripper._body import sample_body
    from wsgrasp.gripper._sweep import finger_links

    body = sample_body(kin, desc.base_link, dict(desc.pregrasp), desc.cloud_points)
    moved_by = finger_links(
        kin, desc, [[kin.master(j) for j in f.joints] for f in desc.fingers]
    )  # per finger, the links its joints move
    owners = np.array(body.links)[body.link]  # (N,) link of each sample
    inside = [
        points_in_superellipsoids(
            body.points, c[None], a[None], model.se_exponent
        )  # (N,)
        for c, a in zip(model.se_centers, model.se_semi_axes, strict=True)
    ]
    out = []
    for links in moved_by:
        moved = np.isin(owners, sorted(links))  # (N,)
        out.append(
            {
                i
                for i, hit in enumerate(inside)
                if hit.any() and moved[hit].mean() > OWN_SHARE
            }
        )
    return out


def _check_kinematics(report: CheckReport, desc: Any, base_dir: Path) -> None:
    from scipy.spatial import cKDTree

    from wsgrasp.gripper._build import urdf_path
    from wsgrasp.gripper._jaws import independent_jaws
    from wsgrasp.gripper._urdf import load_kinematics
    from wsgrasp.gripper._workspace import sample_workspace

    model = report.model
    kin = load_kinematics(urdf_path(desc, base_dir), desc.name)
    base = desc.base_link
    pre = dict(desc.pregrasp)
    closed = dict(desc.closed)

    # -- workspaces: superellipsoid intrusions, reach between fingers --------------
    voxels = []
    for finger in desc.fingers:
        ws = sample_workspace(kin, desc, finger)
        voxels.append(ws.centers(np.argwhere(ws.occupied)))  # (W, 3)

    def pad_inside(finger: Any, i: int) -> bool:
        T = _pad_frame(kin, base, finger.pad.link, pre)
        p = T[:3, :3] @ np.asarray(finger.pad.center) + T[:3, 3]
        return bool(
            points_in_superellipsoids(
                p[None],
                model.se_centers[i][None],
                model.se_semi_axes[i][None],
                model.se_exponent,
            )[0]
        )

    # a link whose own shapes swallow a finger's workspace (a coarse envelope
    # drawn round the fingers for arm motion planning): no superellipsoid count
    # helps, the link's geometry must change
    enveloped = {
        finger.name: hit
        for finger, pts in zip(desc.fingers, voxels, strict=True)
        if (hit := _enveloping_link(kin, desc, finger, pts, pre)) is not None
    }
    for finger in desc.fingers:
        if finger.name in enveloped:
            link, frac = enveloped[finger.name]
            _add(
                report,
                "error",
                "urdf",
                f"the geometry of link {link!r} itself holds {frac:.0%} of finger "
                f"{finger.name}'s workspace (an envelope drawn round the fingers, "
                "as for arm motion planning?): object points there reject every "
                "grasp, whatever the superellipsoids",
                f"give link {link!r} <collision> shapes of its own form (its "
                "<visual> mesh, say) in the URDF, and the fingers theirs, then rerun "
                "`wsgrasp gripper new ... --force`",
            )
    own_links = _own_ellipsoids(kin, desc, model)
    for k, (finger, pts) in enumerate(zip(desc.fingers, voxels, strict=True)):
        inside = np.stack(
            [
                points_in_superellipsoids(
                    pts, e[None], model.se_semi_axes[i][None], model.se_exponent
                )
                for i, e in enumerate(model.se_centers)
            ]
        )  # (ne, W)
        fracs = inside.mean(axis=1)  # (ne,)
        # the finger's own links in the pre-grasp posture: expected, and only a
        # problem when together they swallow much of the workspace
        own = [i in own_links[k] or pad_inside(finger, i) for i in range(len(fracs))]
        for i, frac in enumerate(fracs):
            if frac > INTRUSION_WARN:
                report.intrusions.append(
                    {
                        "ellipsoid": i,
                        "finger": finger.name,
                        "fraction": round(float(frac), 3),
                        "own_link": own[i],
                    }
                )
        if finger.name in enveloped:
            continue  # said above, with the fix that helps
        for i, frac in enumerate(fracs):
            if own[i] or frac <= INTRUSION_WARN:
                continue
            e = model.se_centers[i]
            _add(
                report,
                "error" if frac > INTRUSION_ERROR else "warning",
                "ellipsoids",
                f"body superellipsoid {i} (centre "
                f"{np.round(e * 1000).astype(int).tolist()} mm) holds {frac:.0%} "
                f"of finger {finger.name}'s workspace: object points there "
                "reject the grasp",
                "raise ellipsoids.count so links are fitted apart, or give "
                "ellipsoids.given by hand; if the finger reaches into the body at "
                "the end of its joint range, narrow that joint's <limit> in the "
                "URDF (then set closed to the new limit, or rerun `wsgrasp "
                "gripper new ... --force`)",
            )
        mine = [i for i in range(len(fracs)) if own[i]]
        frac = float(inside[mine].any(axis=0).mean()) if mine else 0.0
        if frac > INTRUSION_ERROR:
            one = len(mine) == 1
            centres = ", ".join(
                str(np.round(model.se_centers[i] * 1000).astype(int).tolist())
                for i in mine
            )
            _add(
                report,
                "error",
                "ellipsoids",
                f"body superellipsoid{'' if one else 's'} "
                f"{', '.join(map(str, mine))} (centre{'' if one else 's'} {centres} "
                f"mm), fitted round finger {finger.name}'s own links open, "
                f"hold{'s' if one else ''} {frac:.0%} of finger {finger.name}'s "
                "workspace: object points there reject the grasp",
                "raise ellipsoids.count (added superellipsoids go to the links "
                "whose boxes swallow the most finger workspace), or give "
                f"ellipsoids.given by hand; or open finger {finger.name} less in "
                "pregrasp",
            )
    if len(voxels) > 1:
        for k, finger in enumerate(desc.fingers):
            others = np.concatenate([v for j, v in enumerate(voxels) if j != k])
            gap = float(cKDTree(others).query(voxels[k])[0].min())
            if gap > max(3 * desc.workspace_voxel, MAX_FINGER_GAP) + 1e-9:
                _add(
                    report,
                    "warning",
                    f"fingers[{finger.name}]",
                    f"finger {finger.name} (pad link {finger.pad.link!r}) cannot "
                    f"touch another finger's workspace: it stays {gap * 1000:.0f} mm "
                    "away, so objects thinner than that cannot be held",
                    "check its joints and joint limits in the URDF, and that "
                    f"fingers[{finger.name}].joints lists every joint that closes it",
                )

    # -- pads: do they close towards and face the other fingers? -------------------
    if len(desc.fingers) > 1:
        frames_open = [_pad_frame(kin, base, f.pad.link, pre) for f in desc.fingers]
        frames_closed = [
            _pad_frame(kin, base, f.pad.link, {**pre, **closed}) for f in desc.fingers
        ]

        def centre(T: Array, f: Any) -> Array:
            return T[:3, :3] @ np.asarray(f.pad.center) + T[:3, 3]

        def between(t: float) -> dict[str, float]:
            """The posture a fraction ``t`` of the way from pregrasp to closed."""
            out = {j: float(v) for j, v in closed.items()}
            for j, v in pre.items():
                end = closed[j] if j in closed else v
                out[j] = (1.0 - t) * float(v) + t * float(end)
            return out

        p_open = np.array(
            [centre(T, f) for T, f in zip(frames_open, desc.fingers, strict=True)]
        )
        p_closed = np.array(
            [centre(T, f) for T, f in zip(frames_closed, desc.fingers, strict=True)]
        )
        # facing is judged open: the pad must face the finger it closes against,
        # or lead the finger's first closing motion (curling fingers of a hand)
        start = between(0.1)
        p_start = np.array(
            [centre(_pad_frame(kin, base, f.pad.link, start), f) for f in desc.fingers]
        )
        p_path = []  # pad centres at 8 steps from open to closed: (F, 3) each
        for t in np.linspace(0.0, 1.0, 9)[1:]:
            post = between(float(t))
            p_path.append(
                np.array(
                    [
                        centre(_pad_frame(kin, base, f.pad.link, post), f)
                        for f in desc.fingers
                    ]
                )
            )
        boxes = _link_centres(kin, [f.pad.link for f in desc.fingers])

        n = len(desc.fingers)

        def pad_path(pre_d: dict[str, float], closed_d: dict[str, float]) -> Array:
            """Pad centres at 9 steps from ``pre_d`` to ``closed_d``: (9, F, 3)."""
            out = []
            for t in np.linspace(0.0, 1.0, 9):
                post = {j: float(v) for j, v in closed_d.items()}
                for j, v in pre_d.items():
                    end = closed_d.get(j, v)
                    post[j] = (1.0 - t) * float(v) + t * float(end)
                out.append(
                    [
                        centre(_pad_frame(kin, base, f.pad.link, post), f)
                        for f in desc.fingers
                    ]
                )
            return np.array(out)

        def share(k: int, path: Array) -> tuple[float, float, float]:
            """Finger ``k``'s pad distance (m) to the mean of the other pads open,
            and nearest on the way to closed (long fingers may pass each other at
            the end); and how much nearer (m) its own motion brings it, at best
            along the way, than it would be had it stayed open while the others
            move."""
            rest = [j for j in range(n) if j != k]
            others = path[:, rest].mean(axis=1)  # (9, 3)
            d_open = float(np.linalg.norm(path[0, k] - others[0]))
            moving = np.linalg.norm(path[1:, k] - others[1:], axis=1)  # (8,)
            still = np.linalg.norm(path[0, k] - others[1:], axis=1)  # (8,)
            return d_open, float(moving.min()), float((still - moving).max())

        # a finger's own closing must bring its pad nearer the others, somewhere on
        # the way, than staying open would. The worst offender is blamed, with the
        # fingers sharing its joints, and judged reversed while the rest are judged
        # again: a finger closing the wrong way is named, not those whose
        # distances it spoils
        path = pad_path(pre, closed)
        shares = [share(k, path) for k in range(n)]
        blamed: list[int] = []
        pre_fixed, closed_fixed = dict(pre), dict(closed)
        while True:
            # a rigid jaw (no joints) does not move: the others close on it
            owns = {
                k: share(k, path)[2]
                for k in range(n)
                if k not in blamed and desc.fingers[k].joints
            }
            failing = [k for k, v in owns.items() if v < 1e-3]
            if not failing:
                break
            worst = min(failing, key=lambda k: owns[k])
            joints = {kin.master(j) for j in desc.fingers[worst].joints}
            for k, f in enumerate(desc.fingers):
                if k not in blamed and joints & {kin.master(j) for j in f.joints}:
                    blamed.append(k)
            for j in joints:
                if j in pre_fixed and j in closed_fixed:
                    pre_fixed[j], closed_fixed[j] = closed_fixed[j], pre_fixed[j]
            if len(blamed) == n:
                break
            path = pad_path(pre_fixed, closed_fixed)
        for k, f in enumerate(desc.fingers):
            d_open, d_closed, d_own = shares[k]
            report.fingers[k]["pad_closes_mm"] = round((d_open - d_closed) * 1000, 1)
            if k in blamed:
                _add(
                    report,
                    "error",
                    "closed",
                    f"finger {f.name}'s pad does not get nearer the other fingers "
                    f"on the way from pregrasp to closed ({d_open * 1000:.0f} -> "
                    f"{d_closed * 1000:.0f} mm; its own motion brings it "
                    f"{d_own * 1000:.0f} mm nearer, at best, than staying in pregrasp "
                    "while the others close)",
                    "swap the values of pregrasp and closed for the joints "
                    f"{f.joints}, or fix the joint axes in the URDF",
                )
            rest = [j for j in range(n) if j != k]
            # a rigid jaw's pad box stands in front of the jaw's face, which
            # may lie far from its link's centre (the whole gripper body)
            ref = _nearest_surface(kin, f) if not f.joints else boxes.get(f.pad.link)
            normal = _pad_normal(f, ref)
            if normal is None:
                report.fingers[k]["pad_facing_deg"] = None
                continue
            n_base = frames_open[k][:3, :3] @ normal
            # the partner: the finger farthest away when open (the one it opposes)
            partner = max(rest, key=lambda j: np.linalg.norm(p_open[j] - p_open[k]))
            cos = -1.0
            for ref in (p_open[partner] - p_open[k], p_start[k] - p_open[k]):
                length = float(np.linalg.norm(ref))
                if length > 1e-9:
                    cos = max(cos, float(n_base @ ref) / length)
            deg = float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
            report.fingers[k]["pad_facing_deg"] = round(deg, 1)
            if cos < FACING_COS:
                _add(
                    report,
                    "warning",
                    f"fingers[{f.name}].pad",
                    f"finger {f.name}'s pad on {f.pad.link!r} faces {deg:.0f} deg "
                    "away from the finger it closes against and from its own closing "
                    "motion: it is not on the inner face",
                    f"move fingers[{f.name}].pad.center to the face of "
                    f"{f.pad.link!r} that points at the other fingertips",
                )

    # -- joints that move nothing, joints left out ---------------------------------
    listed = {kin.master(j) for f in desc.fingers for j in f.joints}
    below = set(kin.subtree(base))
    geo = [link for link in below if kin.shapes.get(link)]
    ref = _geometry_points(kin, base, geo, pre)
    for j in kin.actuated():
        if kin.joints[j].child not in below:
            continue
        lo, hi = kin.joints[j].lower, kin.joints[j].upper
        a = _geometry_points(kin, base, geo, {**pre, j: lo})
        b = _geometry_points(kin, base, geo, {**pre, j: hi})
        motion = float(max(np.abs(a - ref).max(), np.abs(b - ref).max()))
        where = next(
            (f.name for f in desc.fingers if j in {kin.master(x) for x in f.joints}),
            None,
        )
        if motion < MIN_MOTION:
            report.idle_joints.append(j)
            _add(
                report,
                "warning",
                f"fingers[{where}].joints" if where else "pregrasp",
                f"joint {j!r} moves nothing: no link with geometry moves when it "
                f"goes from {lo:g} to {hi:g}",
                "remove it from the finger's joints, or give its child link "
                f"{kin.joints[j].child!r} collision geometry",
            )
        elif j not in listed and j not in desc.pregrasp:
            _add(
                report,
                "warning",
                "pregrasp",
                f"actuated joint {j!r} is in no finger and not set in pregrasp: it "
                "is held at 0 (clipped into its limits)",
                f"set pregrasp.{j} (and closed.{j}) to the posture you grasp with",
            )

    # -- axes ---------------------------------------------------------------------
    approach = model.approach_axis
    tips = model.sphere_centers.mean(axis=0)
    if float(tips @ approach) <= 0.0:
        _add(
            report,
            "error",
            "approach_axis",
            "the finger workspaces lie behind the base along approach_axis "
            f"{np.round(approach, 3).tolist()}",
            "flip approach_axis: it points from the base towards the fingertips",
        )
    coupling = independent_jaws(kin, desc.model_dump())
    if coupling is not None:
        _add(
            report,
            "warning",
            "fingers",
            f"the jaws on joints {coupling.leader!r} and {coupling.follower!r} "
            "mirror each other but are driven apart: planned apart, they may stop "
            "at openings a one-drive gripper cannot make; simulated, both at their "
            "force limit on an object, they float together under a side push",
            f'if one drive moves both, add <mimic joint="{coupling.leader}" '
            f'multiplier="{coupling.multiplier:g}" offset="{coupling.offset:g}"/> '
            f"to joint {coupling.follower!r} in the URDF and give both fingers "
            f"joints: [{coupling.leader}] (`wsgrasp gripper new` does this unless "
            "--independent-jaws)",
        )
    if len(desc.fingers) > 1:
        motion = p_closed - p_open  # (F, 3)
        motion -= np.outer(motion @ approach, approach)
        w, v = np.linalg.eigh(motion.T @ motion)
        main = v[:, -1]
        cos = abs(float(main @ model.closing_axis))
        if w[-1] > 1e-8 and cos < 0.5:
            _add(
                report,
                "warning",
                "closing_axis",
                "the pads move mostly along "
                f"{np.round(main, 2).tolist()} when closing, not along closing_axis "
                f"{np.round(model.closing_axis, 3).tolist()}",
                "set closing_axis to the direction across which the fingers close",
            )


def _link_centres(kin: Any, links: list[str]) -> dict[str, Array]:
    from wsgrasp.gripper._urdf import shape_mesh

    out = {}
    for link in links:
        shapes = kin.shapes.get(link, [])
        if shapes:
            v = np.concatenate([np.asarray(shape_mesh(s).vertices) for s in shapes])
            out[link] = 0.5 * (v.min(axis=0) + v.max(axis=0))
    return out


def _nearest_surface(kin: Any, finger: Any) -> Array | None:
    """The point of the pad link's geometry nearest the pad's centre (link
    frame); None for a link without geometry."""
    from wsgrasp.gripper._urdf import link_mesh

    if not kin.shapes.get(finger.pad.link):
        return None
    mesh = link_mesh(kin, finger.pad.link)
    return np.asarray(mesh.nearest.on_surface([finger.pad.center])[0][0])


def _pad_normal(finger: Any, link_centre: Array | None) -> Array | None:
    """The pad's outward normal in its link frame: its thinnest axis, pointing
    away from ``link_centre`` (the link geometry's centre, or for a rigid jaw
    the point of its surface nearest the pad); None when it cannot be told."""
    size = np.asarray(finger.pad.size, dtype=np.float64)
    order = np.argsort(size)
    if size[order[0]] >= 0.8 * size[order[1]]:
        return None  # no clearly thinnest axis
    k = int(order[0])
    c = np.asarray(finger.pad.center, dtype=np.float64)
    ref = link_centre if link_centre is not None else np.zeros(3)
    off = c[k] - ref[k]
    if abs(off) < 1e-6:
        return None
    n = np.zeros(3)
    n[k] = np.sign(off)
    return n


def _geometry_points(
    kin: Any, base: str, links: list[str], posture: dict[str, float]
) -> Array:
    """Each link's origin and unit offsets along its axes, in the base frame, as a
    cheap stand-in for its geometry: ``(4 L, 3)``."""
    poses = kin.link_poses(base, posture)
    probe = np.vstack([np.zeros(3), 0.05 * np.eye(3)])  # (4, 3)
    return np.concatenate([probe @ poses[k][:3, :3].T + poses[k][:3, 3] for k in links])
