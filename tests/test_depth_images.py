"""Depth images as input: deprojected with their camera's intrinsics
(:mod:`wsgrasp.perception.depth`), from a scene YAML, the CLI's ``--intrinsics``
and Python, and every way of giving one wrong."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from PIL import Image

from wsgrasp.cli import main
from wsgrasp.errors import InputError
from wsgrasp.perception.depth import Intrinsics, depth_points
from wsgrasp.perception.flying import flying_points
from wsgrasp.perception.io import load_scene, save_cloud, write_scene_yaml
from wsgrasp.perception.synth import synth_scene

K = Intrinsics(fx=277.0, fy=281.0, cx=159.5, cy=119.5)


def test_pixels_are_deprojected_along_their_rays():
    """Each pixel ``(u, v)`` of depth ``z`` at ``((u - cx) z / fx, (v - cy) z /
    fy, z)``, row after row; 0, NaN and inf at ``(0, 0, 0)``; millimetres for
    integers and metres for floats unless a scale is given."""
    rng = np.random.default_rng(0)
    mm = rng.integers(300, 1500, (240, 320)).astype(np.uint16)
    mm[5, 7] = 0
    points = depth_points(mm, K)
    v, u = np.mgrid[0:240, 0:320]
    z = mm * 0.001
    want = np.stack([(u - K.cx) * z / K.fx, (v - K.cy) * z / K.fy, z], -1)
    np.testing.assert_allclose(points, want.reshape(-1, 3), atol=1e-6)
    assert not points[5 * 320 + 7].any()
    metres = mm.astype(np.float32) * np.float32(0.001)
    metres[0, 0] = np.nan
    metres[0, 1] = np.inf
    got = depth_points(metres, K)
    assert not got[:2].any() and not got[5 * 320 + 7].any()
    np.testing.assert_allclose(got[2:], points[2:], atol=1e-6)
    tum = depth_points(mm, K, depth_scale=0.0002)  # TUM RGB-D's 5000 per metre
    np.testing.assert_allclose(tum, points * 0.2, atol=1e-6)


def test_a_synthetic_scene_as_depth_images_is_the_same_scene(tmp_path: Path):
    """``write_scene_yaml`` with the cameras writes 16-bit PNGs and their
    intrinsics; loaded back, each view is its cloud to the millimetre, its
    pixels without depth counted, its flying pixels found as in the cloud."""
    synth = synth_scene("box", seed=2, flying=1.0)
    as_clouds = load_scene(write_scene_yaml(tmp_path / "c", synth.views))
    path = write_scene_yaml(tmp_path / "d", synth.views, cameras=synth.cameras)
    doc = yaml.safe_load(path.read_text())
    assert [set(v) for v in doc["views"]] == [
        {"depth", "intrinsics", "T_world_camera"}
    ] * 3
    assert Image.open(tmp_path / "d" / "view_0.png").mode.startswith("I;16")
    as_depth = load_scene(path)
    pixels = 3 * synth.cameras[0].width * synth.cameras[0].height
    assert as_depth.dropped_no_depth == pixels - len(synth.points)
    for a, b in zip(as_depth.views, as_clouds.views, strict=True):
        assert a.points.shape == b.points.shape
        # half a millimetre of rounding along a ray of at most a metre
        np.testing.assert_allclose(a.points, b.points, atol=0.0006)
        np.testing.assert_array_equal(a.T_world_camera, b.T_world_camera)
    flying_d, flying_c = flying_points(as_depth), flying_points(as_clouds)
    assert flying_d is not None and flying_c is not None
    assert abs(int(flying_d.sum()) - int(flying_c.sum())) < 0.05 * flying_c.sum()


def test_a_depth_image_plans_from_the_command_line(tmp_path: Path, capsys):
    """``plan depth.png --intrinsics`` and ``scene info`` read a camera's image in
    its own frame (table tilted), as the same camera's cloud."""
    synth = synth_scene("cylinder", size=(0.03, 0.12), views=1, seed=1)
    write_scene_yaml(tmp_path, synth.views, cameras=synth.cameras)
    cam = synth.cameras[0]
    k = f"{cam.fx},{cam.fy},{cam.cx},{cam.cy}"
    png = str(tmp_path / "view_0.png")
    assert main(["scene", "info", png, "--intrinsics", k, "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["points"] == len(synth.views[0].points)
    assert info["dropped_no_depth"] == cam.width * cam.height - info["points"]
    save_cloud(tmp_path / "cloud.npz", synth.views[0].points)
    tcp = []
    for inputs in ([png, "--intrinsics", k], [str(tmp_path / "cloud.npz")]):
        args = ["plan", *inputs, "-g", "franka_hand", "--no-record", "--json"]
        assert main(args) == 0
        result = json.loads(capsys.readouterr().out)
        assert result["found"]
        tcp.append(np.asarray(result["T_world_tcp"]))
    # in the camera's frame: the grasp lies in front of the camera
    assert tcp[0][2, 3] > 0.2
    # the image's millimetres and the cloud's points: about the same grasp
    assert np.linalg.norm(tcp[0][:3, 3] - tcp[1][:3, 3]) < 0.01


def _png(path: Path, array: np.ndarray, mode: str | None = None) -> Path:
    Image.fromarray(array, mode).save(path) if mode else Image.fromarray(array).save(
        path
    )
    return path


def test_every_wrong_depth_image_is_named(tmp_path: Path, capsys):
    """A depth image without intrinsics, a colour or 8-bit image, intrinsics
    off the image or not four numbers, intrinsics for a cloud, a view with both
    a cloud and a depth image, an image with no depth: one error each, naming
    the file and the fix."""
    depth = np.full((240, 320), 800, dtype=np.uint16)
    png = _png(tmp_path / "d.png", depth)
    with pytest.raises(InputError, match="is a depth image") as info:
        load_scene(png)
    assert "--intrinsics" in (info.value.hint or "")
    rgb = _png(tmp_path / "rgb.png", np.zeros((240, 320, 3), np.uint8))
    with pytest.raises(InputError, match="8-bit image .* not a depth image"):
        load_scene(rgb, intrinsics=K)
    off = Intrinsics(fx=277.0, fy=277.0, cx=639.5, cy=479.5)
    with pytest.raises(InputError, match=r"principal point at \(639.5, 479.5\)"):
        load_scene(png, intrinsics=off)
    with pytest.raises(InputError, match="no pixel with a depth"):
        load_scene(_png(tmp_path / "z.png", np.zeros_like(depth)), intrinsics=K)
    # the camera's intrinsics at half and twice this resolution (a colour
    # stream's, a binned one's), and fx swapped with cx: refused, not deprojected
    # along the wrong rays into a grasp decimetres off
    for k, size, scale in (
        (Intrinsics(fx=138.0, fy=138.0, cx=79.5, cy=59.5), "160 x 120", "2"),
        (Intrinsics(fx=554.0, fy=554.0, cx=319.5, cy=239.5), "640 x 480", "0.5"),
    ):
        with pytest.raises(InputError, match=f"middle of a {size} image") as info:
            load_scene(png, intrinsics=k)
        assert f"scale fx, fy, cx, cy by {scale}" in (info.value.hint or "")
    swapped = Intrinsics(fx=159.5, fy=277.0, cx=277.0, cy=119.5)
    with pytest.raises(InputError, match="at 87 % of its width") as info:
        load_scene(png, intrinsics=swapped)
    assert "order fx,fy,cx,cy" in (info.value.hint or "")
    # a scale or focal lengths that do not fit, a sensor's 65535 for no depth
    for scale, k, values in (
        (1.0, K, depth),
        (None, Intrinsics(fx=1, fy=1, cx=159.5, cy=119.5), depth),
        (None, K, depth * 0 + 65535),
    ):
        image = _png(tmp_path / "far.png", values)
        with pytest.raises(
            InputError, match="deprojects to points .* m across"
        ) as info:
            load_scene(image, intrinsics=k, depth_scale=scale)
        assert "--depth-scale" in (info.value.hint or "")
    np.save(tmp_path / "c.npy", np.ones((10, 3)))
    with pytest.raises(InputError, match="no input is a depth image"):
        load_scene(tmp_path / "c.npy", intrinsics=K)
    with pytest.raises(InputError, match="depth scale was given without"):
        load_scene(png, depth_scale=0.001)
    np.save(tmp_path / "d.npy", depth.astype(np.float32) / 1000)
    with pytest.raises(InputError, match="depth image: pass --intrinsics"):
        load_scene(tmp_path / "d.npy")
    assert len(load_scene(tmp_path / "d.npy", intrinsics=K).points) == 240 * 320
    scene_yaml = tmp_path / "s.yaml"
    scene_yaml.write_text(
        "views:\n  - cloud: c.npy\n    depth: d.png\n"
        "    intrinsics: {fx: 1, fy: 1, cx: 0, cy: 0}\n"
    )
    with pytest.raises(InputError, match="either `cloud:` or `depth:`"):
        load_scene(scene_yaml)
    scene_yaml.write_text("views:\n  - depth: d.png\n")
    with pytest.raises(InputError, match="needs its camera's `intrinsics"):
        load_scene(scene_yaml)
    for bad in ("1,2,3", "0,1,2,3", "a,b,c,d", "nan,1,1,1"):
        assert main(["scene", "info", str(png), "--intrinsics", bad]) == 2
        assert "not four numbers" in capsys.readouterr().err
    assert main(["plan", str(png), "-g", "franka_hand", "--no-record"]) == 2
    err = capsys.readouterr().err
    assert "is a depth image" in err and "Traceback" not in err


def test_a_float_tiff_in_metres(tmp_path: Path):
    """A 32-bit float TIFF is read in metres."""
    metres = np.full((120, 160), 0.75, dtype=np.float32)
    tif = tmp_path / "d.tif"
    Image.fromarray(metres, "F").save(tif)
    k = Intrinsics(fx=140.0, fy=140.0, cx=79.5, cy=59.5)
    scene = load_scene(tif, intrinsics=k)
    np.testing.assert_allclose(scene.points[:, 2], 0.75, atol=1e-6)


def test_the_camera_how_to_runs_as_written(tmp_path: Path, capsys, monkeypatch):
    """The commands of *Plan on a depth camera's data* run, every block of
    them, and ``scene info`` prints what the page shows."""
    import re
    import shlex

    page = (Path(__file__).parents[1] / "docs/how-to/camera-data.md").read_text()
    blocks = re.findall(r"```sh\n(.*?)```", page, re.S)
    text = re.search(r"```text\n(.*?)```", page, re.S)
    assert len(blocks) >= 2 and text
    monkeypatch.chdir(tmp_path)
    printed = ""
    commands = "\n".join(blocks).replace("\\\n", " ").strip().splitlines()
    for command in filter(str.strip, commands):
        args = shlex.split(command)
        assert args[0] == "wsgrasp"
        assert main(args[1:]) == 0, command
        out = capsys.readouterr().out
        if args[1:3] == ["scene", "info"]:
            printed = out
    assert " ".join(text.group(1).split()) in " ".join(printed.split())


def test_intrinsics_from_a_camera_info_file(tmp_path: Path, capsys):
    """``--intrinsics`` and a scene YAML's ``intrinsics:`` take a file: a
    CameraInfo as ``ros2 topic echo --once`` prints it (with its ``---``), a ROS
    calibration file, or fx, fy, cx, cy in JSON; one without a matrix is named."""
    k = [277.0, 0.0, 159.5, 0.0, 281.0, 119.5, 0.0, 0.0, 1.0]
    files = {
        "echo.yaml": yaml.safe_dump({"height": 240, "width": 320, "k": k}) + "---\n",
        "calib.yaml": yaml.safe_dump({"camera_matrix": {"rows": 3, "data": k}}),
        "k.json": json.dumps({"fx": 277.0, "fy": 281.0, "cx": 159.5, "cy": 119.5}),
    }
    for name, text in files.items():
        (tmp_path / name).write_text(text)
        assert Intrinsics.parse(str(tmp_path / name)) == K, name
    (tmp_path / "bad.yaml").write_text("a: 1\n")
    with pytest.raises(InputError, match="has no camera matrix"):
        Intrinsics.parse(str(tmp_path / "bad.yaml"))
    depth = np.full((240, 320), 800, dtype=np.uint16)
    _png(tmp_path / "d.png", depth)
    (tmp_path / "s.yaml").write_text(
        "views:\n  - depth: d.png\n    intrinsics: echo.yaml\n"
    )
    scene = load_scene(tmp_path / "s.yaml")
    np.testing.assert_allclose(scene.points, depth_points(depth, K), atol=1e-9)
    synth = synth_scene("box", views=1, seed=4)
    write_scene_yaml(tmp_path / "r", synth.views, cameras=synth.cameras)
    cam = synth.cameras[0]
    matrix = [cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1]
    calib = {"camera_matrix": {"data": [float(v) for v in matrix]}}
    (tmp_path / "r" / "calib.yaml").write_text(yaml.safe_dump(calib))
    info = ["scene", "info", str(tmp_path / "r" / "view_0.png"), "--json"]
    assert main([*info, "--intrinsics", str(tmp_path / "r" / "calib.yaml")]) == 0
    assert json.loads(capsys.readouterr().out)["points"] == len(synth.views[0].points)
