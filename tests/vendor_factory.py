"""Small URDFs with the quirks of vendor descriptions, written by tests: names of any
form, limits at 12 digits, wrist joints above the palm, meshes in several formats
referenced as relative paths or ``package://`` URIs, visual meshes that are missing.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path
from xml.sax.saxutils import quoteattr

#: axis and limits of the jaws' slides
_SLIDE = ("0 1 0", "0", "0.04")
_SLIDE_R = ("0 -1 0", "0", "0.04")
#: axis and limits of the forearm hand's wrist, finger and thumb flexion joints
_WRIST = ("0 1 0", "-0.5", "0.2")
_CURL = ("-1 0 0", "0", "1.4")
_THUMB = ("0 -1 0", "-0.3", "1.2")
#: ... and of the swing-thumb hand's finger and thumb flexion joints
_CURL_Y = ("0 1 0", "-0.2", "1.4")
_THUMB_Z = ("0 0 1", "-0.2", "0.8")
#: the Shadow hand's way of writing 30 and 10 degrees
DEG30 = "0.523598775598"
DEG10 = "0.174532925199"


def _box(size: Sequence[float], xyz: Sequence[float] = (0, 0, 0)) -> str:
    s = " ".join(f"{v:g}" for v in size)
    o = " ".join(f"{v:g}" for v in xyz)
    return (
        f'<collision><origin xyz="{o}" rpy="0 0 0"/>'
        f'<geometry><box size="{s}"/></geometry></collision>'
    )


def _joint(
    name: str,
    kind: str,
    parent: str,
    child: str,
    xyz: Sequence[float],
    axis: str,
    lower: str,
    upper: str,
    rpy: Sequence[float] = (0, 0, 0),
) -> str:
    o = " ".join(f"{v:g}" for v in xyz)
    r = " ".join(f"{v:g}" for v in rpy)
    return (
        f"<joint name={quoteattr(name)} type={quoteattr(kind)}>"
        f"<parent link={quoteattr(parent)}/><child link={quoteattr(child)}/>"
        f'<origin xyz="{o}" rpy="{r}"/><axis xyz="{axis}"/>'
        f'<limit lower="{lower}" upper="{upper}" effort="10" velocity="1"/></joint>'
    )


def named_jaw_urdf(joints: tuple[str, str], links: tuple[str, str, str]) -> str:
    """A parallel jaw along y, approach +z, whose two prismatic finger joints and
    three links (palm, left, right) carry the given names, written as XML
    attributes (quotes escaped)."""
    palm, left, right = links
    j_left = _joint(joints[0], "prismatic", palm, left, (0, 0.005, 0.05), *_SLIDE)
    j_right = _joint(joints[1], "prismatic", palm, right, (0, -0.005, 0.05), *_SLIDE_R)
    return f"""<?xml version="1.0"?>
<robot name="named_jaw">
  <link name={quoteattr(palm)}>{_box((0.04, 0.16, 0.05), (0, 0, 0.025))}</link>
  <link name={quoteattr(left)}>{_box((0.02, 0.015, 0.05), (0, 0.0075, 0.025))}</link>
  <link name={quoteattr(right)}>{_box((0.02, 0.015, 0.05), (0, -0.0075, 0.025))}</link>
  {j_left}
  {j_right}
</robot>
"""


def hand_urdf(
    *,
    names: Sequence[str] | None = None,
    wrist: Sequence[tuple[str, str, str, str]] = (),
    limits: tuple[str, str] = ("-0.3", "1.2"),
) -> str:
    """A three-finger hand of boxes, fingers pointing along +z: two fingers on the
    palm's -y side, one on its +y side, each of two revolute joints that curl it
    towards the palm's centre line.

    All joints turn about -x, and the lone finger's limits are the others'
    negated, so it closes towards its lower limits while the other two close
    towards their upper ones.

    Parameters
    ----------
    names
        The six finger joints' names (finger after finger, proximal first);
        ``f{i}_j{k}`` if omitted.
    wrist
        ``(name, axis, lower, upper)`` of revolute joints between the root link
        ``mount`` and the ``palm``, root first.
    limits
        ``(lower, upper)`` of the finger joints, as written in the URDF.
    """
    names = list(names or [f"f{i}_j{k}" for i in range(3) for k in range(2)])
    parts = [f'<link name="mount">{_box((0.05, 0.05, 0.02), (0, 0, -0.06))}</link>']
    parent = "mount"
    for i, (name, axis, lower, upper) in enumerate(wrist):
        link = "palm" if i == len(wrist) - 1 else f"wrist_{i}"
        parts.append(
            _joint(name, "revolute", parent, link, (0, 0, 0.02), axis, lower, upper)
        )
        if link != "palm":
            parts.append(f'<link name="{link}"/>')
        parent = link
    if not wrist:
        parts.append(
            '<joint name="mount_palm" type="fixed"><parent link="mount"/>'
            '<child link="palm"/></joint>'
        )
    parts.append(f'<link name="palm">{_box((0.09, 0.09, 0.02), (0, 0, 0.01))}</link>')
    lower, upper = limits
    mounts = [(-0.025, -0.03), (0.025, -0.03), (0.0, 0.03)]
    for i, (x, y) in enumerate(mounts):
        # the same axis everywhere: positive angles curl the -y fingers inwards,
        # the lone +y finger outwards
        lo, hi = (lower, upper) if i < 2 else (_neg(upper), _neg(lower))
        prox, dist = f"finger{i}_proximal", f"finger{i}_distal"
        ax = "-1 0 0"
        parts += [
            f'<link name="{prox}">{_box((0.015, 0.015, 0.05), (0, 0, 0.025))}</link>',
            f'<link name="{dist}">{_box((0.015, 0.015, 0.04), (0, 0, 0.02))}</link>',
            _joint(names[2 * i], "revolute", "palm", prox, (x, y, 0.02), ax, lo, hi),
            _joint(names[2 * i + 1], "revolute", prox, dist, (0, 0, 0.05), ax, lo, hi),
        ]
    body = "\n  ".join(parts)
    return f'<?xml version="1.0"?>\n<robot name="hand">\n  {body}\n</robot>\n'


def _neg(value: str) -> str:
    return value[1:] if value.startswith("-") else "-" + value


def forearm_hand_urdf(*, thumb_turn: tuple[str, str] = ("0", "1.5708")) -> str:
    """A four-finger hand on a forearm, laid out as the Shadow hand is, in boxes.

    The root link is a 20 cm ``forearm`` along +z; a wrist joint ``WRJ1`` (about
    y) carries the ``palm`` above it, a slab 2 cm thick along y. Three fingers of
    two joints (``F0J2``, ``F0J1``, ...) stand on the palm's top leaning 0.8 rad
    forwards and curl towards +y: the palm faces sideways from the forearm. The
    thumb ``th`` rises from the palm's +x side, 0.9 rad from the vertical; at
    ``THJ_TURN`` 0 its two flexion joints (``THJ2``, ``THJ1``) curl it in the
    plane of the palm, beside the fingers; ``THJ_TURN`` (about the thumb's own
    length, ``thumb_turn`` its limits) turns that plane towards the front of
    the palm, where the fingers close.
    """
    turn_lower, turn_upper = thumb_turn
    parts = [
        f'<link name="forearm">{_box((0.06, 0.06, 0.2), (0, 0, 0.1))}</link>',
        _joint("WRJ1", "revolute", "forearm", "palm", (0, 0, 0.21), *_WRIST),
        f'<link name="palm">{_box((0.08, 0.02, 0.09), (0, 0, 0.045))}</link>',
        '<link name="th_base"/>',
        f'<link name="th_proximal">{_box((0.05, 0.018, 0.018), (0.025, 0, 0))}</link>',
        f'<link name="th_distal">{_box((0.04, 0.018, 0.018), (0.02, 0, 0))}</link>',
        _joint(
            "THJ_TURN",
            "revolute",
            "palm",
            "th_base",
            (0.045, 0, 0.05),
            "-1 0 0",
            turn_lower,
            turn_upper,
            rpy=(0, -0.9, 0),
        ),
        _joint("THJ2", "revolute", "th_base", "th_proximal", (0, 0, 0), *_THUMB),
        _joint("THJ1", "revolute", "th_proximal", "th_distal", (0.05, 0, 0), *_THUMB),
    ]
    for i, x in enumerate((-0.025, 0.0, 0.025)):
        prox, dist = f"f{i}_proximal", f"f{i}_distal"
        parts += [
            f'<link name="{prox}">{_box((0.016, 0.016, 0.05), (0, 0, 0.025))}</link>',
            f'<link name="{dist}">{_box((0.016, 0.016, 0.04), (0, 0, 0.02))}</link>',
            _joint(
                f"F{i}J2",
                "revolute",
                "palm",
                prox,
                (x, 0, 0.09),
                *_CURL,
                rpy=(-0.8, 0, 0),
            ),
            _joint(f"F{i}J1", "revolute", prox, dist, (0, 0, 0.05), *_CURL),
        ]
    body = "\n  ".join(parts)
    return f'<?xml version="1.0"?>\n<robot name="forearm_hand">\n  {body}\n</robot>\n'


def swing_thumb_hand_urdf(*, swing: tuple[str, str] = ("0", "1.6")) -> str:
    """A five-finger hand whose thumb swings about the fingers' direction, laid
    out as Dexmate's F5D6 hand is, in boxes.

    The ``palm`` is a slab 2 cm thick whose front faces -z; four fingers of one
    joint (``F0J1`` ... ``F3J1``, about y) stand on its +x edge and curl
    towards -z. The thumb's swing joint ``THJ0`` turns about x (``swing`` its
    limits) through a point near where the fingers reach, and carries the
    thumb 3.5 cm out from that line: at 0 the thumb lies beside the palm, on
    its -y side, and its flexion joint ``THJ1`` (about z there) curls it
    across the palm towards the first finger's side; swung, it stands in front
    of the palm and curls back towards the finger pads. Swinging moves the
    thumb about a line near where the fingers reach, so it brings it barely
    nearer them; it changes only which way the thumb closes.
    """
    swing_lower, swing_upper = swing
    parts = [f'<link name="palm">{_box((0.08, 0.08, 0.02), (0, 0, 0.01))}</link>']
    for i, y in enumerate((-0.03, -0.01, 0.01, 0.03)):
        parts += [
            f'<link name="f{i}">{_box((0.05, 0.016, 0.016), (0.025, 0, 0))}</link>',
            _joint(f"F{i}J1", "revolute", "palm", f"f{i}", (0.04, y, 0.01), *_CURL_Y),
        ]
    parts += [
        '<link name="th_base"/>',
        f'<link name="th">{_box((0.05, 0.016, 0.016), (0.025, 0, 0))}</link>',
        _joint(
            "THJ0",
            "revolute",
            "palm",
            "th_base",
            (-0.02, -0.01, -0.01),
            "1 0 0",
            swing_lower,
            swing_upper,
        ),
        _joint("THJ1", "revolute", "th_base", "th", (0, -0.035, 0), *_THUMB_Z),
    ]
    body = "\n  ".join(parts)
    return (
        f'<?xml version="1.0"?>\n<robot name="swing_thumb_hand">\n  {body}\n</robot>\n'
    )


def write_box_mesh(
    path: Path, extents: Sequence[float], centre: Sequence[float]
) -> Path:
    """A box mesh in the format of ``path``'s suffix (.stl, .obj, .dae, .glb)."""
    import trimesh

    mesh = trimesh.creation.box(extents=extents)
    mesh.apply_translation(centre)
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix == ".dae":
        from trimesh.exchange.dae import export_collada

        path.write_bytes(export_collada(mesh))
    else:
        mesh.export(path)
    return path


#: link -> (mesh file stem, extents, centre) of the mesh jaw
JAW_PARTS = {
    "palm": ("palm", (0.04, 0.16, 0.05), (0.0, 0.0, 0.025)),
    "left_finger": ("left", (0.02, 0.015, 0.05), (0.0, 0.0075, 0.025)),
    "right_finger": ("right", (0.02, 0.015, 0.05), (0.0, -0.0075, 0.025)),
}


def write_mesh_jaw(
    urdf: Path,
    mesh_dir: Path,
    *,
    ext: str = "stl",
    uri: Callable[[str], str] | None = None,
    visual: Callable[[str], str] | None = None,
) -> Path:
    """A parallel jaw (approach +z, closing along y) whose links' collision
    geometry is meshes written into ``mesh_dir`` as ``<stem>.<ext>``.

    ``uri(file)`` is how the URDF names a mesh file (a path relative to the URDF
    by default); ``visual(file)``, when given, adds a ``<visual>`` mesh to each
    link named that way (for files that need not exist).
    """

    def relative(file: str) -> str:
        return Path(os.path.relpath(mesh_dir / file, urdf.parent)).as_posix()

    name_of = uri or relative
    links = []
    for link, (stem, extents, centre) in JAW_PARTS.items():
        file = f"{stem}.{ext}"
        write_box_mesh(mesh_dir / file, extents, centre)
        vis = (
            f'<visual><geometry><mesh filename="{visual(stem + ".STL")}"/>'
            "</geometry></visual>"
            if visual is not None
            else ""
        )
        links.append(
            f'<link name="{link}">{vis}<collision><geometry>'
            f'<mesh filename="{name_of(file)}"/></geometry></collision></link>'
        )
    left = _joint(
        "left_joint", "prismatic", "palm", "left_finger", (0, 0.005, 0.05), *_SLIDE
    )
    text = f"""<?xml version="1.0"?>
<robot name="mesh_jaw">
  {"".join(links)}
  {left}
  <joint name="right_joint" type="prismatic">
    <parent link="palm"/><child link="right_finger"/>
    <origin xyz="0 -0.005 0.05"/><axis xyz="0 -1 0"/>
    <limit lower="0" upper="0.04" effort="10" velocity="1"/>
    <mimic joint="left_joint"/>
  </joint>
</robot>
"""
    urdf.parent.mkdir(parents=True, exist_ok=True)
    urdf.write_text(text)
    return urdf


def write_package_xml(folder: Path, name: str) -> None:
    """A ROS ``package.xml`` naming package ``name`` in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "package.xml").write_text(
        f'<?xml version="1.0"?>\n<package format="2">\n  <name>{name}</name>\n'
        "  <version>0.1.0</version>\n</package>\n"
    )
