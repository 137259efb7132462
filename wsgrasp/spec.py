"""Pipeline specs and gripper descriptions: pydantic models and their loading.

Both are plain files (YAML, TOML or JSON). Every model forbids unknown keys; a bad
file gets one ``SpecError`` naming the file, line, key path, what was expected and
what was found. Plugin options are validated against the plugin's own ``Options``
model when the spec loads, not halfway through a run.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    NonNegativeFloat,
    PositiveFloat,
    PositiveInt,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)

from wsgrasp._loading import (
    DocumentLines,
    format_validation_error,
    load_document,
    validate_document,
)
from wsgrasp._names import is_gripper_path
from wsgrasp.errors import PluginError, SpecError

__all__ = [
    "FingerDescription",
    "GripperDescription",
    "PadRegion",
    "PipelineSpec",
    "load_gripper_description",
    "load_spec",
]

Vec3 = tuple[float, float, float]
#: the most pad points along one edge, where each edge has its own count
MAX_EDGE_SAMPLES = 64
#: three sizes, each above zero
Size3 = tuple[PositiveFloat, PositiveFloat, PositiveFloat]
#: pad points along one box edge, where each edge has its own count
EdgeSamples = Annotated[int, Field(ge=1, le=MAX_EDGE_SAMPLES)]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=False, allow_inf_nan=False)


# --------------------------------------------------------------------------------
# Gripper description
# --------------------------------------------------------------------------------
class PadRegion(_Model):
    """The fingertip pad: a box on a link, in that link's frame (metres)."""

    link: str = Field(description="URDF link that carries the pad")
    center: Vec3 = Field((0.0, 0.0, 0.0), description="box centre in the link frame")
    size: tuple[NonNegativeFloat, NonNegativeFloat, NonNegativeFloat] = Field(
        description="full box extents along the link's x, y, z (0: a flat pad)"
    )
    samples: (
        Annotated[int, Field(ge=1, le=12)]
        | tuple[EdgeSamples, EdgeSamples, EdgeSamples]
    ) = Field(
        3,
        description="points per box edge when sampling the pad: one count for "
        "every edge (at most 12), or one per edge along the link's x, y, z (at "
        f"most {MAX_EDGE_SAMPLES} each), so that a wide, thin pad is sampled "
        "about as densely along each edge",
    )


class FingerDescription(_Model):
    """One finger: the joints that move its pad, and the pad."""

    name: str
    joints: list[str] = Field(
        description="actuated joints that move this finger's pad; mimic joints "
        "follow their masters automatically. Empty: a rigid jaw, a pad on a link "
        "no joint moves that the other fingers close the object against; its "
        "workspace is its pad box, so give the box the depth across which the "
        "other fingers may push the object onto it",
    )
    pad: PadRegion
    on_table: Literal["slides", "sticks"] | None = Field(
        None,
        description="what the fingertip does where its closing sweep meets the "
        "table: 'slides' along it (the sweep may dip up to 15 mm below the "
        "table), or 'sticks' there (the sweep stays above it, within the "
        "plane's 2 mm noise); left out, guessed: a finger of one joint sticks, "
        "one of several joints slides unless its joints press its pad into the "
        "table as it comes down (`gripper check` prints the guess)",
    )


class FrameOffset(_Model):
    """A frame fixed to a link: translation (m) and roll-pitch-yaw (rad)."""

    link: str
    xyz: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)


class BodyEllipsoid(_Model):
    """A body superellipsoid given by hand, in the base frame."""

    center: Vec3
    semi_axes: Size3


class EllipsoidSettings(_Model):
    """Superellipsoids that approximate the gripper body."""

    count: int = Field(5, ge=1, le=32, description="number of superellipsoids (ne)")
    exponent: float = Field(
        10.0, ge=2.0, description="exponent l of eq. (1) for x and y"
    )
    given: list[BodyEllipsoid] | None = Field(
        None,
        description="superellipsoids given by hand instead of fitted; their number "
        "must equal count",
    )

    @model_validator(mode="after")
    def _given_count(self) -> EllipsoidSettings:
        if self.given is not None and len(self.given) != self.count:
            raise ValueError(
                f"ellipsoids.given has {len(self.given)} entries but count is "
                f"{self.count}"
            )
        return self


class DriveSettings(_Model):
    """The fingers' drive in simulation (``wsgrasp eval``): the position gains of
    the hand's own controller, where they are known. Planning does not read it."""

    kp_revolute: float | None = Field(
        None,
        gt=0.0,
        description="gain (N·m/rad) of every revolute finger joint's position "
        "actuator; default: the simulator's kp_revolute",
    )
    kp_prismatic: float | None = Field(
        None,
        gt=0.0,
        description="gain (N/m) of every prismatic finger joint's position "
        "actuator; default: the simulator's kp_prismatic",
    )
    joints: dict[str, PositiveFloat] = Field(
        default_factory=dict,
        description="gains of single actuated joints, by URDF joint name (N·m/rad "
        "for a revolute joint, N/m for a prismatic one), over kp_revolute and "
        "kp_prismatic: a controller whose gains differ per joint (a thumb that "
        "presses against several fingers)",
    )


class _TooFewFingers(SpecError):
    """A gripper description with fewer than two fingers."""


class GripperDescription(_Model):
    """A gripper: URDF plus what the planner needs to know about it.

    Units are SI: metres and radians. Axes are unit vectors in the base frame.
    """

    version: Literal[1] = 1
    name: str = Field(description="registered name of the gripper")
    urdf: str = Field(description="URDF path, relative to this YAML file")
    base_link: str = Field(description="link the arm's flange holds (gripper frame)")
    tool_frame: FrameOffset = Field(
        description="tool centre point (TCP) as an offset from a link"
    )
    approach_axis: Vec3 = Field(description="direction the gripper moves to grasp")
    closing_axis: Vec3 = Field(
        description="direction across which the fingers close (perpendicular to "
        "approach)"
    )
    fingers: list[FingerDescription] = Field(
        min_length=2,
        description="the fingers, at least two that close against each other",
    )
    joint_samples: int = Field(
        8, ge=2, le=64, description="grid points per joint when sampling workspaces"
    )
    spheres_per_finger: int = Field(10, ge=1, le=500, description="nsp")
    workspace_voxel: float = Field(
        0.002, gt=0.0, le=0.05, description="voxel size (m) of the sampled workspace"
    )
    min_sphere_radius: float = Field(
        0.002, gt=0.0, description="smallest sphere radius (m) worth placing"
    )
    ellipsoids: EllipsoidSettings = EllipsoidSettings()
    cloud_points: int = Field(500, ge=50, le=20000, description="ng")
    pregrasp: dict[str, float] = Field(
        description="joint positions (m or rad) of the open, pre-grasp posture"
    )
    closed: dict[str, float] = Field(
        description="joint positions (m or rad) the fingers close towards, all "
        "joints together on the straight line from pregrasp: where the pads meet "
        "(a claw's tips before they cross, a hand's fingertips at its thumb's), "
        "or the limits of a jaw whose pads meet only there"
    )
    contact_fingers: list[str] | None = Field(
        None,
        min_length=2,
        description="the fingers that must hold object points for a candidate to "
        "be feasible; the others close with them and may miss the object. Left "
        "out: every finger (Algorithm 1). A hand of four or five fingers grasps "
        "small objects between its thumb and the two fingers that meet it",
    )
    drive: DriveSettings = Field(
        default_factory=DriveSettings,
        description="the fingers' position gains in simulation, where the hand's "
        "controller is known to be stiffer or softer than the simulator's default",
    )

    @field_validator("fingers", mode="before")
    @classmethod
    def _two_fingers(cls, fingers: Any, info: ValidationInfo) -> Any:
        """Refuse fewer than two fingers with what was found and the fix, before
        the length check (whose message would say neither), as an error of its
        own: pydantic passes it on as it is, so a description built in code
        (a scaffold, a script) gets it too."""
        if isinstance(fingers, list) and len(fingers) < 2:
            names = [
                f.get("name") if isinstance(f, dict) else getattr(f, "name", None)
                for f in fingers
            ]
            found = ", ".join(repr(n) for n in names) or "none"
            raise _TooFewFingers(
                f"gripper {info.data.get('name', '?')!r} describes {len(fingers)} "
                f"finger{'' if len(fingers) == 1 else 's'} ({found}); a grasp needs "
                "at least two opposing fingers",
                hint="list under 'fingers:' each finger whose pad closes towards "
                "another's (a thumb is a finger; a jaw fixed to the body is a "
                "finger with `joints: []`)",
            )
        return fingers

    @model_validator(mode="after")
    def _axes(self) -> GripperDescription:
        import numpy as np

        a = np.asarray(self.approach_axis, dtype=float)
        c = np.asarray(self.closing_axis, dtype=float)
        for label, v in (("approach_axis", a), ("closing_axis", c)):
            if not np.isclose(np.linalg.norm(v), 1.0, atol=1e-3):
                raise ValueError(f"{label} must be a unit vector, found {tuple(v)}")
        if abs(float(a @ c)) > 1e-3:
            raise ValueError("approach_axis and closing_axis must be perpendicular")
        if all(not f.joints for f in self.fingers):
            raise ValueError(
                "every finger is a rigid jaw (empty joints); list under a finger's "
                "joints the joints that close it"
            )
        names = [f.name for f in self.fingers]
        if len(set(names)) != len(names):
            raise ValueError(f"finger names must be unique, found {names}")
        if self.contact_fingers is not None:
            unknown = [n for n in self.contact_fingers if n not in names]
            if unknown:
                raise ValueError(
                    f"contact_fingers names {unknown}, which are not fingers; "
                    f"the fingers are {names}"
                )
            if len(set(self.contact_fingers)) != len(self.contact_fingers):
                raise ValueError(
                    f"contact_fingers names a finger twice: {self.contact_fingers}"
                )
        return self


def load_gripper_description(path: str | Path) -> tuple[GripperDescription, Path]:
    """Load and validate a gripper YAML; returns it and the YAML's directory."""
    data, lines = load_document(path)
    try:
        desc = validate_document(
            GripperDescription,
            data,
            lines,
            "gripper description",
            hint="see schemas/gripper.schema.json for the fields of a gripper YAML",
        )
    except _TooFewFingers as err:  # with the file and line, as the others
        line = lines.line_of(["fingers"]) if lines is not None else None
        where = f"{path}:{line}: " if line else f"{path}: "
        raise SpecError(where + err.message, hint=err.hint) from None
    return desc, Path(path).resolve().parent


# --------------------------------------------------------------------------------
# Pipeline spec
# --------------------------------------------------------------------------------
class PluginRef(_Model):
    """A plugin by name, with its options (validated by the plugin's model)."""

    name: str
    options: dict[str, Any] = Field(default_factory=dict)


class ScorerRef(PluginRef):
    """A scorer and its weight in the combined score."""

    weight: float = Field(1.0, ge=0.0)


class TargetRule(_Model):
    """Which cluster is the object when the segmenter finds several."""

    rule: Literal[
        "largest",
        "nearest",
        "inside_box",
        "only",
        "highest",
        "most_isolated",
        "id",
        "cluster",
    ] = Field(
        "largest",
        description="largest cluster, nearest to `point`, the one inside `box`, "
        "`only` (several clusters are an error); for piles: `highest` (top "
        "highest above the table), `most_isolated` (farthest from the others), "
        "`id` (an instance id from a plan's result.info['segments'], same scene) "
        "or `cluster` (instance `id` with every instance split from the same "
        "cluster, as one object); largest, highest and most_isolated pass over a "
        "container (a bin's walls) while something lies in it",
    )
    id: int | None = Field(
        None, ge=0, description="for rules id and cluster: the instance id"
    )
    point: Vec3 | None = Field(None, description="for rule nearest, world frame (m)")
    box_min: Vec3 | None = Field(None, description="for rule inside_box (m)")
    box_max: Vec3 | None = Field(None, description="for rule inside_box (m)")
    obstacles: bool = Field(
        True, description="other clusters are obstacles candidates must not hit"
    )

    @model_validator(mode="after")
    def _needs(self) -> TargetRule:
        if self.rule == "nearest" and self.point is None:
            raise ValueError("target.rule 'nearest' needs target.point")
        if self.rule == "inside_box" and (self.box_min is None or self.box_max is None):
            raise ValueError("target.rule 'inside_box' needs box_min and box_max")
        if self.rule in ("id", "cluster") and self.id is None:
            raise ValueError(f"target.rule {self.rule!r} needs target.id")
        return self


class Preprocess(_Model):
    """Scene preprocessing."""

    voxel_size: float = Field(0.005, gt=0.0, le=0.1, description="voxel (m)")
    max_object_points: int = Field(
        800, ge=10, description="object cloud is thinned to at most this (no)"
    )
    icp: bool = Field(False, description="refine view poses with ICP")
    crop_radius: float | None = Field(
        None, gt=0.0, description="drop points farther than this from the origin"
    )
    flying_pixels: bool = Field(
        True,
        description="drop flying pixels: points of a view, still its camera's "
        "image, that lie between their neighbours along a row or column, one "
        "nearer and one farther (the veil a depth edge leaves)",
    )


class ObjectFrame(_Model):
    """How the object frame (z = major axis) is found."""

    method: Literal["farthest_split", "pca"] = "farthest_split"
    mirror_hidden: bool = Field(
        False,
        description="where every camera saw one side of the object, add its "
        "points turned half a turn about the vertical through its middle (the "
        "sides no camera saw, as a box's, a can's or a ball's are)",
    )


class Sampling(_Model):
    """Candidate sampling: points in the object's box times orientations.

    ``mode`` chooses the orientations: ``major_axis`` (the paper: ``orientations``
    about the object's major axis, the gripper perpendicular to it), ``xyz`` (the
    authors' follow-up: rotations about the object frame's x, y and z axes,
    ``steps`` each) or ``approach_sphere`` (``directions`` approach directions
    spread evenly over those that do not come from under the table, times
    ``orientations`` rolls about each over ``angle_range_deg``).
    """

    mode: Literal["major_axis", "xyz", "approach_sphere"] = Field(
        "major_axis", description="how candidate orientations are sampled"
    )
    points: int = Field(147, ge=1, le=100000, description="ns")
    grid: tuple[PositiveInt, PositiveInt, PositiveInt] | None = Field(
        None, description="explicit grid along object x, y, z; overrides points"
    )
    scale: Size3 = Field(
        (0.95, 0.95, 0.70), description="fraction of the object extents sampled"
    )
    orientations: int = Field(
        4,
        ge=1,
        le=360,
        description="nos: angles about the major axis (major_axis), or rolls about "
        "each approach direction (approach_sphere)",
    )
    angle_range_deg: float = Field(
        360.0,
        gt=0.0,
        le=360.0,
        description="the orientations (major_axis) or rolls (approach_sphere) span "
        "this",
    )
    flip: bool = Field(
        False,
        description="major_axis: also try each pose turned half a turn about the "
        "approach axis (for grippers not symmetric about it, e.g. hands with a "
        "thumb)",
    )
    angles_from: Literal["table", "object"] = Field(
        "table",
        description="major_axis: the middle angle approaches from straight above "
        "the table, and a gripper reaching farther on one side of its approach "
        "keeps that side off the table (table); or the angles start at the object "
        "frame's x axis, as the paper (object)",
    )
    across_narrowest: bool = Field(
        True,
        description="major_axis with angles_from table: on an upright object, "
        "where every angle is a side approach, turn the angles so that one closes "
        "across the object's narrowest width seen from above (false: from the "
        "object frame's x axis, as the paper)",
    )
    steps: tuple[int, int, int] | None = Field(
        None,
        description="xyz: angles about the object's x, y and z axes, each over a "
        "full turn (default [4, 4, 4]); repeated rotations are tried once",
    )
    directions: int | None = Field(
        None,
        ge=1,
        le=5000,
        description="approach_sphere: approach directions over the half-sphere "
        "above the table (default 24)",
    )
    depths: int = Field(
        1,
        ge=1,
        le=16,
        description="each orientation also tried with the gripper this many depths "
        "along its approach, over the fingers' workspace extent (1: the box "
        "sample at the workspace centroid, as the paper)",
    )
    upward_tolerance_deg: float = Field(
        5.0,
        ge=0.0,
        le=45.0,
        description="no candidate approaches pointing up (from under the table) by "
        "more than this",
    )
    fallback: Sampling | None = Field(
        None,
        description="where no candidate of this sampling is feasible, the search "
        "runs once more with this one (on the same object frame, table and "
        "neighbours), and the result's info says so (fallback)",
    )

    @model_validator(mode="after")
    def _mode_fields(self) -> Sampling:
        if self.fallback is not None and self.fallback.fallback is not None:
            raise ValueError("a fallback sampling has no fallback of its own")
        if self.steps is not None:
            if self.mode != "xyz":
                raise ValueError(f"steps is for mode xyz, not {self.mode}")
            if min(self.steps) < 1 or max(self.steps) > 72:
                raise ValueError("steps are 1 to 72 angles about each axis")
        if self.directions is not None and self.mode != "approach_sphere":
            raise ValueError(f"directions is for mode approach_sphere, not {self.mode}")
        if self.flip and self.mode != "major_axis":
            raise ValueError(
                f"flip is for mode major_axis; mode {self.mode} already tries both "
                "turns (xyz) or sets them with angle_range_deg (approach_sphere)"
            )
        return self


class Approach(_Model):
    """How the gripper reaches and closes on the chosen grasp."""

    distance: float = Field(
        0.10,
        ge=0.0,
        le=1.0,
        description="the pre-grasp pose stands back this far (m) along the "
        "approach axis",
    )
    squeeze: float = Field(
        0.01,
        ge=0.0,
        le=0.1,
        description="each pad's grasp target lies this far (m) past its contact, "
        "so that position-controlled fingers press",
    )
    close_to: Literal["contacts", "closed"] = Field(
        "contacts",
        description="joints_grasp: each finger at its contacts plus the squeeze, "
        "or the gripper's closed posture (a hand that wraps the object)",
    )


class TableSettings(_Model):
    """The table's special ellipsoid, under the table surface."""

    semi_axes: Size3 = Field(
        (0.35, 0.35, 0.05), description="in-plane a, b; depth c (m)"
    )
    exponent: float = Field(10.0, ge=2.0)
    clearance: float = Field(
        0.0, ge=0.0, description="raise the SE's top by this (m) for a safety margin"
    )


class RecordSettings(_Model):
    """Recording of runs to MCAP."""

    enabled: bool = True
    dir: str = "runs"


class PipelineSpec(_Model):
    """A whole pipeline: gripper, segmenter, preprocessing, sampling, scoring."""

    version: Literal[1] = 1
    gripper: str = Field(
        description="a registered gripper name, or a path to a gripper YAML"
    )
    segmenter: PluginRef = PluginRef(name="ransac_dbscan")
    target: TargetRule = TargetRule()
    preprocess: Preprocess = Preprocess()
    object_frame: ObjectFrame = ObjectFrame()
    sampling: Sampling = Sampling()
    approach: Approach = Approach()
    table: TableSettings = TableSettings()
    scorers: list[ScorerRef] = Field(
        default_factory=lambda: [ScorerRef(name="centroid_distance")], min_length=1
    )
    top_k: int = Field(5, ge=1, le=1000, description="alternatives kept")
    seed: int = Field(0, description="random seed for every random step")
    record: RecordSettings = RecordSettings()

    #: where the spec was loaded from (not part of the file)
    _source: Path | None = None

    @field_validator("scorers")
    @classmethod
    def _some_weight(cls, scorers: list[ScorerRef]) -> list[ScorerRef]:
        if sum(ref.weight for ref in scorers) <= 0.0:
            raise ValueError(
                "every scorer has weight 0, so every candidate would score the same; "
                "give at least one scorer a weight above 0"
            )
        return scorers

    @field_validator("sampling")
    @classmethod
    def _budget(cls, sampling: Sampling) -> Sampling:
        need = candidate_count(sampling) * _BYTES_PER_CANDIDATE
        have = _physical_memory()
        if have and need > _MEMORY_SHARE * have:
            raise ValueError(
                f"sampling makes {candidate_count(sampling):,} candidates, about "
                f"{need / 2**30:.1f} GiB of arrays, more than {_MEMORY_SHARE:.0%} "
                f"of this machine's {have / 2**30:.1f} GiB; lower points, "
                "orientations, directions, steps or depths"
            )
        return sampling

    @property
    def source(self) -> Path | None:
        """The file this spec was loaded from, if any."""
        return self._source


#: a spec whose candidate arrays would take more than this share of the
#: machine's memory is refused
_MEMORY_SHARE = 0.5
#: bytes the search holds per candidate: poses (GWC, gripper, their inverses
#: and table-frame copies, 128 B each), sample and orientation indices, reasons,
#: contact counts, scores, with headroom for scorer terms
_BYTES_PER_CANDIDATE = 1024


def candidate_count(s: Sampling) -> int:
    """How many candidates a sampling makes at most: positions times orientations
    times depths (``xyz`` counts repeated rotations, which the search tries once,
    so this is an upper bound)."""
    if s.grid is not None:
        positions = s.grid[0] * s.grid[1] * s.grid[2]
    else:
        positions = s.points
    if s.mode == "major_axis":
        orientations = s.orientations * (2 if s.flip else 1)
    elif s.mode == "xyz":
        steps = s.steps or (4, 4, 4)
        orientations = steps[0] * steps[1] * steps[2]
    else:
        orientations = (s.directions or 24) * s.orientations
    return int(positions) * int(orientations) * int(s.depths)


def _physical_memory() -> int:
    import os

    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):  # not reported here
        return 0


def load_spec(
    source: str | Path | dict[str, Any],
    *,
    registry: Any | None = None,
    check_plugins: bool = True,
    check_files: bool = True,
    check_gripper: bool = True,
) -> PipelineSpec:
    """Load and validate a pipeline spec.

    Parameters
    ----------
    source
        A YAML/TOML/JSON file or an already loaded mapping.
    registry
        Plugin registry to resolve names and options against; the process-wide one
        by default.
    check_plugins
        Resolve the segmenter and scorers and validate their options.
    check_files
        With ``check_plugins``: find the files a gripper path leads to (its
        YAML, the URDF, the URDF's collision meshes), relative paths from the
        spec file's folder (the current directory for a mapping).
    check_gripper
        With ``check_plugins``: check the gripper (a registered name, or a path
        whose files are found with ``check_files``); off where the caller
        replaces it (``plan --spec FILE --gripper G``).

    Raises
    ------
    SpecError
        With file, line, key path, what was expected and what was found.
    """
    lines: DocumentLines | None = None
    if isinstance(source, dict):
        data = source
    else:
        data, lines = load_document(source)
    spec: PipelineSpec = validate_document(
        PipelineSpec,
        data,
        lines,
        "pipeline spec",
        hint="see schemas/pipeline.schema.json, or `wsgrasp spec check FILE`",
    )
    if lines is not None:
        spec._source = lines.path
    if check_plugins:
        from wsgrasp.plugins import get_registry

        reg = registry if registry is not None else get_registry()
        _check_plugin(reg, "segmenters", spec.segmenter, ("segmenter",), lines)
        for i, ref in enumerate(spec.scorers):
            _check_plugin(reg, "scorers", ref, ("scorers", i), lines)
        if check_gripper and not is_gripper_path(spec.gripper):
            _check_name(reg, "grippers", spec.gripper, ("gripper",), lines)
        elif check_gripper and check_files:
            check_gripper_files(spec.gripper, lines)
    return spec


def check_gripper_files(gripper: str, lines: DocumentLines | None) -> None:
    """Raise ``SpecError`` naming the first file the gripper path ``gripper``
    (the ``gripper`` of the spec whose ``lines`` these are; relative to the
    spec file's folder, or to the current directory without a file) leads to
    that is missing: the path tried and what it is relative to."""
    from wsgrasp.gripper._files import missing_gripper_file

    if lines is not None and lines.path is not None:
        base, label = Path(lines.path).absolute().parent, "the spec file's folder"
    else:
        base, label = Path.cwd(), "the current directory"
    missing = missing_gripper_file(gripper, base, label)
    if missing is not None:
        raise SpecError(
            _where(lines, ("gripper",)) + "gripper: " + missing,
            hint="correct the path, or put the file there; a relative path is read "
            "from the folder of the file that names it (the spec, the gripper YAML, "
            "the URDF)",
        )


def _where(lines: DocumentLines | None, loc: tuple[str | int, ...]) -> str:
    if lines is None or lines.path is None:
        return ""
    line = lines.line_of(loc)
    return f"{lines.path}:{line}: " if line else f"{lines.path}: "


def _check_name(
    reg: Any, kind: str, name: str, loc: tuple[str | int, ...], lines: Any
) -> Any:
    try:
        return reg.get(kind, name)
    except PluginError as exc:
        raise SpecError(
            _where(lines, loc) + ".".join(map(str, loc)) + ": " + exc.message,
            hint=exc.hint,
        ) from None


def _check_plugin(
    reg: Any,
    kind: str,
    ref: PluginRef,
    loc: tuple[str | int, ...],
    lines: DocumentLines | None,
) -> None:
    entry = _check_name(reg, kind, ref.name, (*loc, "name"), lines)
    for key, value in _floats(ref.options, (*loc, "options")):
        if not math.isfinite(value):
            raise SpecError(
                _where(lines, key) + ".".join(map(str, key)) + f": {value} is not a "
                "finite number",
                hint="give a finite value",
            )
    options_model = getattr(entry.obj, "Options", None)
    if options_model is None:
        return
    try:
        options_model.model_validate(ref.options)
    except ValidationError as exc:
        msg = format_validation_error(
            exc, lines, f"options of {kind[:-1]} {ref.name!r}", (*loc, "options")
        )
        raise SpecError(
            msg,
            hint=f"see the options of {ref.name!r} in `wsgrasp plugins --options`",
        ) from None


def _floats(
    value: Any, loc: tuple[str | int, ...]
) -> list[tuple[tuple[Any, ...], float]]:
    """Every float inside nested dicts and lists, with its key path."""
    if isinstance(value, float):
        return [(loc, value)]
    if isinstance(value, dict):
        return [x for k, v in value.items() for x in _floats(v, (*loc, k))]
    if isinstance(value, (list, tuple)):
        return [x for i, v in enumerate(value) for x in _floats(v, (*loc, i))]
    return []


def json_schemas() -> dict[str, dict[str, Any]]:
    """JSON Schemas of the pipeline spec and the gripper description, by file name."""
    out = {}
    for fname, model, title in (
        ("pipeline.schema.json", PipelineSpec, "wsgrasp pipeline spec"),
        ("gripper.schema.json", GripperDescription, "wsgrasp gripper description"),
    ):
        schema = model.model_json_schema()
        schema["title"] = title
        schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
        out[fname] = schema
    return out


def write_schemas(directory: str | Path) -> list[Path]:
    """Write the JSON Schemas into ``directory``; returns the paths written."""
    import json

    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    paths = []
    for fname, schema in json_schemas().items():
        p = d / fname
        p.write_text(json.dumps(schema, indent=2, sort_keys=True) + "\n")
        paths.append(p)
    return paths
