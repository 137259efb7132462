"""A gripper plugin package scaffolded from a URDF (``wsgrasp gripper new``).

:func:`guess_description` reads a URDF and guesses the gripper YAML: the base link,
the fingers (kinematic chains from the base to the distal links, with their actuated
joints), each fingertip pad (the inner face of the distal link), the approach and
closing axes, the open (pre-grasp) and closed postures, and sampling settings. Every
guess carries a note saying how it was made; :func:`render_yaml` writes the notes as
comments beside the fields. :func:`scaffold_plugin` writes a pip-installable package
around it (URDF and meshes copied in by :func:`copy_urdf`, ``pyproject.toml`` with a
``wsgrasp`` entry point, a module implementing ``wsgrasp_register_grippers``, a test
and a README), then checks the model and records what the check found.
"""

from __future__ import annotations

import re
import shutil
import tempfile
from pathlib import Path
from typing import Any

from wsgrasp.default_specs import generic_spec_text
from wsgrasp.errors import GripperError, WsgraspError
from wsgrasp.gripper._approach import choose_approach, choose_thumb
from wsgrasp.gripper._guess import (
    Scaffold,
    clear_rigid_pads,
    fit_sphere_count,
    guess_description,
)
from wsgrasp.gripper._jaws import independent_jaws, summed_effort
from wsgrasp.gripper._scaffold_urdf import (
    MESH_UNITS,
    add_mimic,
    check_is_urdf,
    collisions_from_visuals,
    copy_urdf,
    expand_xacro,
    free_fixed_mimics,
    is_xacro,
    joint_names,
    narrow_limits,
    prune_urdf,
    repair_mimics,
    set_limits,
)
from wsgrasp.gripper._urdf import load_kinematics

__all__ = [
    "MESH_UNITS",
    "Scaffold",
    "copy_urdf",
    "fit_sphere_count",
    "guess_description",
    "module_name",
    "render_yaml",
    "scaffold_plugin",
]

#: the scaffolder tries up to this many body superellipsoids
MAX_ELLIPSOIDS = 9
_NAME_RE = re.compile(r"^[A-Za-z][A-Za-z0-9_\-]*$")
#: the most (m) ``--close-past`` moves a hand's pads on past where they meet
MAX_CLOSE_PAST = 0.2


# ------------------------------------------------------------------------------
# Writing
# ------------------------------------------------------------------------------
def _flow(v: Any) -> str:
    """``v`` as one line of YAML (flow style), every scalar written by PyYAML so
    that it reads back as it is: names such as ``0``, ``1.5``, ``yes``, ``null``
    or ``a: b`` quoted, floats at full precision."""
    import yaml

    text = yaml.safe_dump(
        v,
        default_flow_style=True,
        sort_keys=False,
        allow_unicode=True,
        width=float("inf"),
    )
    # a lone scalar is written as a document: drop its end marker
    return text.removesuffix("\n").removesuffix("\n...").rstrip("\n")


def _comment(text: str, indent: str = "") -> str:
    import textwrap

    lines = textwrap.wrap(text, 84 - len(indent))
    return "".join(f"{indent}# {line}\n" for line in lines)


def render_yaml(scaffold: Scaffold, header: list[str] | None = None) -> str:
    """The gripper YAML with each guess explained in a comment above its field."""
    d, n = scaffold.data, scaffold.notes
    out = [
        f"# Gripper {d['name']!r}, scaffolded by `wsgrasp gripper new` from "
        f"{d['urdf']}.\n",
        "# Every value below is a guess from the URDF; the comment above it says how "
        "it was\n# made. Check them with `wsgrasp gripper check <this file> -o "
        "gripper.png`.\n# Units: metres and radians; axes are in the base link's "
        "frame.\n",
    ]
    for line in header or []:
        out.append(_comment(line))
    for w in scaffold.warnings:
        out.append(_comment("WARNING: " + w))
    out.append(f"version: 1\nname: {_flow(d['name'])}\nurdf: {_flow(d['urdf'])}\n")
    for key in ("base_link", "tool_frame", "approach_axis", "closing_axis"):
        if key in n:
            out.append(_comment(n[key]))
        out.append(f"{key}: {_flow(d[key])}\n")
    out.append(_comment(n.get("fingers", "")))
    out.append(_comment("pads: " + n.get("pad", "")))
    out.append("fingers:\n")
    for f in d["fingers"]:
        out.append(f"  - name: {_flow(f['name'])}\n")
        out.append(f"    joints: {_flow(f['joints'])}\n")
        out.append(f"    pad: {_flow(f['pad'])}\n")
    if "contact_fingers" in n:
        out.append(_comment(n["contact_fingers"]))
        if "contact_fingers" in d:
            out.append(f"contact_fingers: {_flow(d['contact_fingers'])}\n")
    for key in (
        "joint_samples",
        "spheres_per_finger",
        "workspace_voxel",
        "min_sphere_radius",
    ):
        if key in n:
            out.append(_comment(n[key]))
        out.append(f"{key}: {_flow(d[key])}\n")
    out.append(
        _comment(n.get("ellipsoids", "body superellipsoids fitted to the links"))
    )
    out.append(f"ellipsoids: {_flow(d['ellipsoids'])}\n")
    out.append(f"cloud_points: {d['cloud_points']}\n")
    import yaml

    for key in ("pregrasp", "closed"):
        out.append(_comment(n.get(key, "")))
        out.append(
            yaml.safe_dump(
                {key: d[key]},
                default_flow_style=False,
                sort_keys=False,
                allow_unicode=True,
                width=float("inf"),
            )
        )
    if "drive" in d:
        out.append(_comment(n.get("drive", "")))
        out.append(f"drive: {_flow(d['drive'])}\n")
    else:
        out.append(_drive_comment())
    return "".join(out)


def _drive_comment() -> str:
    """The commented-out ``drive`` field at the end of a scaffolded YAML of a
    gripper with no drive guessed (fewer than three fingers, or none revolute):
    the simulator's defaults, named and left for the user to change."""
    from wsgrasp.sim.params import SimParams

    p = SimParams()
    gains = {"kp_revolute": p.kp_revolute, "kp_prismatic": p.kp_prismatic}
    text = (
        "the fingers' position gains in simulation (`wsgrasp eval`): kp_revolute "
        "(N·m/rad), kp_prismatic (N/m). A URDF carries no controller gains; for a "
        "gripper of fewer than three fingers, or without revolute finger joints, "
        "none is guessed and the simulator's defaults drive the fingers "
        f"({gains['kp_revolute']:g} N·m/rad, {gains['kp_prismatic']:g} N/m). Where "
        "the hand's own controller or grip force is known, set them to match it; "
        "compare runs with `wsgrasp eval --sim kp_revolute=...` first"
    )
    return _comment(text) + f"# drive: {_flow(gains)}\n"


def _refit_ellipsoids(
    scaffold: Scaffold, yaml_path: Path, header: list[str], report: Any
) -> Any:
    """While the check finds body superellipsoids in the finger workspaces, try
    more of them (up to :data:`MAX_ELLIPSOIDS`); keep the best count."""
    from wsgrasp.gripper.check import check_gripper

    def cost(r: Any) -> tuple[int, float]:
        bad = [p for p in r.problems if p.field == "ellipsoids"]
        return (len(bad), sum(i["fraction"] for i in r.intrusions))

    ell = scaffold.data["ellipsoids"]
    first = ell["count"]
    best, best_count = report, first
    count = first
    while cost(best)[0] and count + 2 <= MAX_ELLIPSOIDS:
        count += 2
        ell["count"] = count
        yaml_path.write_text(render_yaml(scaffold, header))
        trial = check_gripper(str(yaml_path))
        if cost(trial) < cost(best):
            best, best_count = trial, count
    ell["count"] = best_count
    if best_count != first:
        scaffold.notes["ellipsoids"] = (
            f"body superellipsoids fitted to the links (l = 10); {best_count} "
            f"rather than {first}, as fewer swallowed part of a finger workspace"
        )
    yaml_path.write_text(render_yaml(scaffold, header))
    return best


def module_name(name: str) -> str:
    """The Python package of a scaffolded plugin: ``wsgrasp_<name>``."""
    return "wsgrasp_" + re.sub(r"[^0-9a-zA-Z_]", "_", name).lower()


_PYPROJECT = """\
[build-system]
requires = ["setuptools>=69"]
build-backend = "setuptools.build_meta"

[project]
name = "{name}"
version = "0.1.0"
description = "wsgrasp gripper plugin: {name}"
readme = "README.md"
requires-python = ">=3.10"
dependencies = ["wsgrasp"]

# wsgrasp finds the gripper through this entry point
[project.entry-points.wsgrasp]
{name} = "{module}"

[tool.setuptools]
packages = ["{module}"]

[tool.setuptools.package-data]
{module} = ["*.urdf", "*.yaml", "meshes/*", "specs/*.yaml"]
"""

_MODULE = '''\
"""wsgrasp gripper plugin.

Registers the gripper {name!r} by its YAML (beside the URDF). Scaffolded by
`wsgrasp gripper new`.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from wsgrasp.plugins import hookimpl

HERE = Path(__file__).resolve().parent


@hookimpl
def wsgrasp_register_grippers(register: Callable[[str, Any], None]) -> None:
    """Register {name!r} by the path of its gripper YAML."""
    register("{name}", HERE / "{name}.yaml")
'''

_TEST = '''\
"""The gripper of this package.

It builds, `wsgrasp gripper check` finds no error in it, and it plans a grasp.
"""

from __future__ import annotations

from pathlib import Path

import yaml

from wsgrasp import Pipeline
from wsgrasp.gripper.check import check_gripper
from wsgrasp.perception.io import scene_from_arrays
from wsgrasp.perception.synth import synth_scene
from wsgrasp.spec import load_spec

HERE = Path(__file__).resolve().parents[1]
YAML = HERE / "{module}" / "{name}.yaml"
SPEC = HERE / "{module}" / "specs" / "default.yaml"


def test_check_finds_no_errors():
    report = check_gripper(str(YAML))
    assert not report.errors, report.format()


def test_plans_a_grasp_on_a_cylinder():
    spec = yaml.safe_load(SPEC.read_text())  # the gripper's default spec
    spec.update(gripper=str(YAML), record={{"enabled": False}})
    pipe = Pipeline(load_spec(spec))
    radius = min(0.035, max(0.012, 0.2 * pipe.gripper.max_opening))
    scene = synth_scene("cylinder", size=(radius, 0.12), seed=0, width=160, height=120)
    result = pipe.plan(scene_from_arrays(scene.points))
    assert result.found, result.hint
'''

_README = """\
# {name}: a wsgrasp gripper plugin

Scaffolded from `{urdf}` by `wsgrasp gripper new`. The package holds the URDF (and
its meshes under `{module}/meshes/`), the gripper YAML `{module}/{name}.yaml` and a
module that registers it with wsgrasp through the `wsgrasp` entry-point group.

```sh
pip install -e .                      # register the gripper
wsgrasp grippers list                 # shows {name}
wsgrasp gripper check {name} -o gripper.png   # trust, but verify the guesses
pytest tests                          # builds, checks and plans a grasp
```

Then use it in a pipeline spec: `gripper: {name}`. `wsgrasp plan --gripper {name}`
and `wsgrasp eval --gripper {name}` use `{module}/specs/default.yaml`, wsgrasp's
generic default spec as written here (its first lines say whether `reach_down` was
added and `approach_direction` set to prefer a level approach, as they are for a hand
that approaches fingertips first); change it there to
change the gripper's default.

The YAML's comments say what `wsgrasp gripper new` guessed and how. Read the check's
report and its picture; fix the fields it names. To publish: `python -m build` and
upload the wheel, or install from your repository with `pip install git+URL`.
"""


def scaffold_plugin(
    name: str,
    urdf: str | Path,
    out_dir: str | Path,
    *,
    base_link: str | None = None,
    mesh_dirs: list[Path] | None = None,
    mesh_units: str | None = None,
    force: bool = False,
    check: bool = True,
    package_paths: list[Path] | None = None,
    xacro_args: dict[str, str] | None = None,
    couple_jaws: bool = True,
    close_past: float = 0.0,
) -> tuple[Path, Scaffold]:
    """Write a pip-installable gripper plugin package into ``out_dir``.

    ``mesh_dirs`` are extra folders holding mesh files; ``package_paths`` are
    folders holding ROS packages, for ``package://`` URIs (as ``ROS_PACKAGE_PATH``).
    A xacro file is expanded first (:func:`expand_xacro`, with ``xacro_args``).
    Two jaws that the URDF drives apart but whose paths mirror each other are
    made to move together in the copied URDF unless ``couple_jaws`` is false
    (:func:`~wsgrasp.gripper._jaws.independent_jaws`). Fingers stopped where
    their pads meet close on until the pads have travelled ``close_past`` (m)
    more (:func:`guess_description`).

    Returns
    -------
    yaml_path, scaffold
        The gripper YAML written and the guesses (with warnings).

    Raises
    ------
    GripperError
        A bad name, an existing non-empty ``out_dir`` without ``force``, or a URDF
        that cannot be scaffolded (see :func:`guess_description`).
    """
    if not _NAME_RE.match(name):
        raise GripperError(
            f"gripper name {name!r} is not usable as a package name",
            hint="use letters, digits, '_' and '-', starting with a letter",
        )
    if not 0.0 <= close_past <= MAX_CLOSE_PAST:
        raise GripperError(
            f"--close-past {close_past:g} is outside 0 to {MAX_CLOSE_PAST:g} m",
            hint="give how far (m) the pads travel on past where they meet, e.g. 0.06",
        )
    if mesh_units is not None and mesh_units not in MESH_UNITS:
        raise GripperError(
            f"--mesh-units {mesh_units!r} is unknown",
            hint="use one of " + ", ".join(MESH_UNITS),
        )
    out = Path(out_dir)
    if out.exists() and any(out.iterdir()) and not force:
        raise GripperError(
            f"output folder {str(out)!r} exists and is not empty",
            hint="choose a new --out folder, or pass --force to overwrite",
        )
    fresh = not out.exists()
    try:
        with tempfile.TemporaryDirectory(prefix="wsgrasp-xacro-") as tmp:
            source, note = Path(urdf), None
            if source.is_file() and is_xacro(source):
                note = f"expanded from {source.name} by xacro"
                if xacro_args:
                    note += " with " + ", ".join(
                        f"{k}:={v}" for k, v in xacro_args.items()
                    )
                source = expand_xacro(source, Path(tmp), xacro_args, package_paths)
            elif xacro_args:
                raise GripperError(
                    f"--xacro-arg given, but {source.name} is no xacro file",
                    hint="leave --xacro-arg out for a URDF",
                )
            elif source.is_file():
                check_is_urdf(source.read_text(errors="replace"), source)
            return _write_package(
                name,
                source,
                out,
                base_link,
                mesh_dirs,
                mesh_units,
                check,
                package_paths,
                xacro_note=note,
                shown=Path(urdf),
                couple_jaws=couple_jaws,
                close_past=close_past,
            )
    except BaseException:
        if fresh:  # leave nothing half-written behind
            shutil.rmtree(out, ignore_errors=True)
        raise


def _naming_source(exc: GripperError, copy: Path, source: Path) -> GripperError:
    """``exc``, raised reading the package's copy of the URDF, as the user should
    read it: naming the file they gave (the copy goes with the half-written
    package), with a fix to the URDF rather than to a YAML not yet written."""
    message = exc.message.replace(str(copy), str(source))
    message = message.replace(copy.name, source.name)
    hint = exc.hint
    if hint and "`urdf` field of the gripper YAML" in hint:
        hint = "fix the URDF, then run `wsgrasp gripper new` again"
    return GripperError(message, hint=hint)


def _below_base(urdf_copy: Path, scaffold: Scaffold) -> str:
    """The copied URDF cut down to the links below the guess's base link (the
    arm above a gripper in a robot's URDF is no part of the plugin) and the
    meshes only those use; a note saying what was left out, or nothing."""
    if not scaffold.links_outside:
        return ""
    links, meshes = prune_urdf(urdf_copy, set(scaffold.links_below))
    base = scaffold.data["base_link"]
    return (
        f"left out of the copied URDF, above base link {base}: "
        + ", ".join(links[:8])
        + (f" ... ({len(links)} links)" if len(links) > 8 else "")
        + (f"; and {len(meshes)} of its meshes" if meshes else "")
    )


def _write_package(
    name: str,
    urdf: Path,
    out: Path,
    base_link: str | None,
    mesh_dirs: list[Path] | None,
    mesh_units: str | None,
    check: bool,
    package_paths: list[Path] | None = None,
    xacro_note: str | None = None,
    shown: Path | None = None,
    couple_jaws: bool = True,
    close_past: float = 0.0,
) -> tuple[Path, Scaffold]:
    """The package of :func:`scaffold_plugin`; ``shown`` is the file the user
    gave (a xacro file expanded into ``urdf``), named in errors."""
    module = module_name(name)
    pkg = out / module
    pkg.mkdir(parents=True, exist_ok=True)
    mesh_warnings: list[str] = []
    oversized: list[tuple[set[str], GripperError]] = []
    urdf_copy, mesh_notes = copy_urdf(
        urdf,
        pkg,
        name,
        mesh_dirs=mesh_dirs,
        mesh_units=mesh_units,
        package_paths=package_paths,
        warnings=mesh_warnings,
        oversized=oversized,
    )
    mimics = repair_mimics(urdf_copy)
    freed = free_fixed_mimics(urdf_copy)
    try:
        scaffold = guess_description(
            urdf_copy, name, base_link=base_link, close_past=close_past
        )
        base = scaffold.data["base_link"]
        # a mesh in millimetres matters where the gripper uses it, not on a link
        # of the robot above it (left out of the copy below)
        for users, error in oversized:
            if users & set(scaffold.links_below):
                raise error
        kin = load_kinematics(urdf_copy, name, below=base)
        # a link whose collision shapes envelop the fingers (drawn round them
        # for arm motion planning) takes its visual shapes, and the guess is
        # made again; so is it with two jaws moved together
        from wsgrasp.gripper.check import enveloping_links

        from_visuals = collisions_from_visuals(
            urdf_copy, enveloping_links(kin, scaffold.data)
        )
        # a collision mesh that is the link's visual mesh placed elsewhere: the
        # visual is what the URDF's authors looked at (the SAKE EZGripper's in
        # one robot's URDF, 90 degrees apart: it held 6-8 of random:000-019 under
        # the strict protocol as placed, 18 with the visual's placement)
        misplaced = collisions_from_visuals(
            urdf_copy, set(kin.misplaced) & set(kin.subtree(base))
        )
        if from_visuals or misplaced:
            scaffold = guess_description(
                urdf_copy, name, base_link=base_link, close_past=close_past
            )
            kin = load_kinematics(urdf_copy, name, below=base)
        coupling = independent_jaws(kin, scaffold.data) if couple_jaws else None
        effort = None
        if coupling is not None:
            effort = summed_effort(kin, coupling)
            if effort is not None:
                set_limits(urdf_copy, {coupling.leader: {"effort": effort}})
            add_mimic(
                urdf_copy,
                coupling.follower,
                coupling.leader,
                coupling.multiplier,
                coupling.offset,
            )
            scaffold = guess_description(
                urdf_copy, name, base_link=base_link, close_past=close_past
            )
    except GripperError as exc:
        raise _naming_source(exc, urdf_copy, shown or urdf) from None
    scaffold.warnings[:0] = mesh_warnings
    pruned = _below_base(urdf_copy, scaffold)
    if pruned:  # the notes of the meshes still there; no warning on links
        scaffold.warnings = [
            w for w in scaffold.warnings if not w.startswith("links not below base")
        ]
        mesh_notes = [
            n
            for n in mesh_notes
            if (pkg / n.split(" -> ")[-1].split(" (")[0]).is_file()
        ]
    narrow_limits(urdf_copy, scaffold.limits)
    choose_thumb(scaffold, pkg)
    fit_sphere_count(scaffold, pkg)
    choose_approach(scaffold, pkg)
    header = [xacro_note] if xacro_note else []
    if close_past > 0.0:
        header.append(
            f"scaffolded with --close-past {close_past:g}: where the fingers stop "
            "where their pads meet, they close on until the pads have travelled "
            f"{close_past * 1000:.0f} mm more (the comment on closed says whether "
            "they did)"
        )
    kept = set(joint_names(urdf_copy))  # those of the hand, where an arm went
    # the joints repaired in the copy, each kind once, where the hand kept them
    for what, repairs in (
        ("mimics that name no joint, pointed at the joint they mean", mimics),
        (
            "fixed joints that follow another (<mimic>, <axis>, <limit>), made "
            "to move as they follow it",
            freed,
        ),
    ):
        if any(j in kept for j in repairs):
            note = f"{what} in the copied URDF: " + ", ".join(
                f"{j} ({r})" for j, r in repairs.items() if j in kept
            )
            header.append(note)
            scaffold.warnings.append(note)
    for links, what in (
        (
            from_visuals,
            "collision shapes that envelop the fingers (drawn round them for arm "
            "motion planning)",
        ),
        (
            misplaced,
            "collision meshes placed apart from the same mesh as the link's visual",
        ),
    ):
        if links:
            note = (
                f"{what}, replaced in the copied URDF by the link's visual "
                "shapes: " + ", ".join(links)
            )
            header.append(note)
            scaffold.warnings.append(note)
    drawn = [link for link in kin.drawn_only if link in set(scaffold.links_below)]
    if drawn:  # a marker at the tool frame would be a solid between the jaws
        header.append(
            "links with visual geometry alone, drawn but not solid (the URDF "
            "gives its other links collision geometry): " + ", ".join(drawn)
        )
    if coupling is not None:
        header.append(coupling.note(effort))
        scaffold.warnings.append(coupling.note(effort))
    if mesh_notes:
        header.append("meshes copied: " + "; ".join(mesh_notes))
    if pruned:
        header.append(pruned)
    if scaffold.limits:
        header.append(
            "joint limits narrowed in the copied URDF, where a finger would close "
            "into the palm: "
            + ", ".join(
                f"{j} [{lo:g}, {hi:g}]" for j, (lo, hi) in scaffold.limits.items()
            )
        )
    yaml_path = pkg / f"{name}.yaml"
    yaml_path.write_text(render_yaml(scaffold, header))
    if check:
        from wsgrasp.gripper.check import check_gripper

        try:
            report = check_gripper(str(yaml_path))
        except WsgraspError as exc:  # the guess does not build: say so, keep it
            lines = [f"`wsgrasp gripper check` cannot build this guess: {exc}"]
            scaffold.build_error = str(exc)
        else:
            report = _refit_ellipsoids(scaffold, yaml_path, header, report)
            if any(p.field == "ellipsoids" for p in report.problems) and (
                clear_rigid_pads(scaffold, yaml_path)
            ):
                yaml_path.write_text(render_yaml(scaffold, header))
                report = check_gripper(str(yaml_path))
            lines = [
                f"`wsgrasp gripper check` on this guess: {p.severity}: {p.message} "
                f"(field {p.field}; fix: {p.fix})"
                for p in report.problems
            ] or ["`wsgrasp gripper check` on this guess found no problem"]
            scaffold.warnings += [
                f"{p.severity}: {p.message} (field {p.field})" for p in report.problems
            ]
        yaml_path.write_text(render_yaml(scaffold, header + lines))
    (out / "pyproject.toml").write_text(_PYPROJECT.format(name=name, module=module))
    (pkg / "__init__.py").write_text(_MODULE.format(name=name))
    (out / "tests").mkdir(exist_ok=True)
    (out / "tests" / f"test_{module}.py").write_text(
        _TEST.format(name=name, module=module)
    )
    (out / "README.md").write_text(
        _README.format(name=name, module=module, urdf=urdf.name)
    )
    (pkg / "specs").mkdir(exist_ok=True)
    (pkg / "specs" / "default.yaml").write_text(
        generic_spec_text(
            name,
            fingertips_first=scaffold.approaches_fingertips_first,
            fingers=len(scaffold.data["fingers"]),
        )
    )
    return yaml_path, scaffold
