"""ROS 2 bags as input: PointCloud2 clouds, depth Images with their CameraInfo,
/tf and /tf_static, --at, bad bags."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from bag_factory import DEPTH_QUANT, encode_rvl, write_cloud_bag, write_depth_bag

from wsgrasp.errors import InputError
from wsgrasp.perception.bag import decode_rvl, read_bag_scene
from wsgrasp.perception.depth import Intrinsics, depth_points

S = 1_000_000_000


def _T(xyz, yaw: float = 0.0) -> np.ndarray:
    T = np.eye(4)
    c, s = np.cos(yaw), np.sin(yaw)
    T[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
    T[:3, 3] = xyz
    return T


@pytest.fixture
def cloud() -> np.ndarray:
    return np.random.default_rng(0).uniform(-0.1, 0.1, (500, 3)) + [0, 0, 0.5]


@pytest.fixture
def bag(tmp_path: Path, cloud: np.ndarray) -> Path:
    return write_cloud_bag(
        tmp_path / "capture.mcap",
        [
            ("/camera/points", "camera", cloud, 1 * S),
            ("/camera/points", "camera", cloud * 2, 3 * S),
        ],
        [
            ("/tf_static", "world", "base", _T([1.0, 0.0, 0.0], 0.5), 0),
            ("/tf", "base", "camera", _T([0.0, 0.0, 0.1]), 1 * S),
            ("/tf", "base", "camera", _T([0.0, 0.0, 0.2]), 3 * S),
        ],
    )


def test_latest_cloud_with_the_pose_from_tf(bag: Path, cloud: np.ndarray) -> None:
    scene = read_bag_scene(bag, "/camera/points")
    (view,) = scene.views
    assert (
        view.points.tobytes() == (cloud * 2).astype(np.float32).astype(float).tobytes()
    )
    want = _T([1.0, 0.0, 0.0], 0.5) @ _T([0.0, 0.0, 0.2])
    np.testing.assert_allclose(view.T_world_camera, want, atol=1e-12)
    world = view.points @ want[:3, :3].T + want[:3, 3]
    np.testing.assert_allclose(scene.points, world, atol=1e-12)


def test_at_picks_the_cloud_and_the_transform_of_that_time(
    bag: Path, cloud: np.ndarray
) -> None:
    scene = read_bag_scene(bag, "/camera/points", at=1.5)
    (view,) = scene.views
    np.testing.assert_array_equal(view.points, cloud.astype(np.float32))
    want = _T([1.0, 0.0, 0.0], 0.5) @ _T([0.0, 0.0, 0.1])
    np.testing.assert_allclose(view.T_world_camera, want, atol=1e-12)
    with pytest.raises(InputError, match="at or before"):
        read_bag_scene(bag, "/camera/points", at=0.5)


def test_transforms_stamped_in_simulated_time(
    tmp_path: Path, cloud: np.ndarray
) -> None:
    """A bag recorded with ``use_sim_time``: messages recorded in wall-clock
    time, stamped in simulated time (seconds since the simulator started). A
    wrist camera's pose is the transform stamped last at or before the cloud's
    stamp (it was the first one recorded: 10 cm off), as in a bag stamped in
    wall-clock time."""
    wall = 1_700_000_000 * S
    clouds = [("/camera/points", "camera", cloud, wall + 12 * S + S // 2)]
    tf = [
        ("/tf", "base", "camera", _T([0.0, 0.0, 0.1 * k]), wall + (8 + 2 * k) * S)
        for k in (1, 2, 3)
    ]
    for clock in (wall - 10 * S, 0):
        bag = write_cloud_bag(tmp_path / f"{clock}.mcap", clouds, tf, clock=clock)
        (view,) = read_bag_scene(bag, "/camera/points").views
        np.testing.assert_allclose(view.T_world_camera, _T([0.0, 0.0, 0.2]), atol=1e-12)


def test_frame_option(bag: Path) -> None:
    scene = read_bag_scene(bag, "/camera/points", frame="base")
    np.testing.assert_allclose(
        scene.views[0].T_world_camera, _T([0, 0, 0.2]), atol=1e-12
    )
    scene = read_bag_scene(bag, "/camera/points", frame="camera")
    np.testing.assert_allclose(scene.views[0].T_world_camera, np.eye(4))
    with pytest.raises(InputError, match="frames in the bag: base, camera, world"):
        read_bag_scene(bag, "/camera/points", frame="map")


def test_bag_without_tf_uses_the_cloud_frame(tmp_path: Path, cloud) -> None:
    bag = write_cloud_bag(tmp_path / "b.mcap", [("/pts", "cam", cloud, S)])
    scene = read_bag_scene(bag, "/pts")
    np.testing.assert_array_equal(scene.views[0].T_world_camera, np.eye(4))


def test_missing_topic_lists_the_topics(bag: Path) -> None:
    with pytest.raises(InputError, match=r"'/nope'.*/camera/points \(sensor_msgs/msg"):
        read_bag_scene(bag, "/nope")
    with pytest.raises(InputError, match="TFMessage, not sensor_msgs/msg/PointCloud2"):
        read_bag_scene(bag, "/tf")


def test_cloud_without_xyz_names_its_fields(tmp_path: Path, cloud) -> None:
    bag = write_cloud_bag(
        tmp_path / "b.mcap", [("/depth", "cam", cloud, S)], fields=("u", "v", "depth")
    )
    with pytest.raises(InputError, match="no x/y/z field; its fields are: u:f4, v:f4"):
        read_bag_scene(bag, "/depth")


def test_not_a_bag(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="no such bag"):
        read_bag_scene(tmp_path / "nope.mcap", "/x")
    f = tmp_path / "x.mcap"
    f.write_text("hello")
    with pytest.raises(InputError, match="not an MCAP file"):
        read_bag_scene(f, "/x")


def test_a_bag_cut_short_is_read_up_to_where_it_stops(
    bag: Path, cloud: np.ndarray
) -> None:
    data = bag.read_bytes()
    bag.write_bytes(data[: len(data) - 100])  # the summary and footer cut off
    scene = read_bag_scene(bag, "/camera/points", at=1.5)
    np.testing.assert_array_equal(scene.views[0].points, cloud.astype(np.float32))


def test_only_the_chunks_of_the_cloud_and_its_transforms_are_read(
    tmp_path: Path, cloud: np.ndarray, monkeypatch: pytest.MonkeyPatch
) -> None:
    import mcap.reader

    clouds = [("/camera/points", "camera", cloud + i, i * S) for i in range(1, 41)]
    tf = [("/tf", "world", "camera", _T([0.0, 0.0, 0.1 * i]), i * S) for i in (0, 20)]
    bag = write_cloud_bag(tmp_path / "long.mcap", clouds, tf, chunk_size=1)
    read: list[int] = []
    real = mcap.reader.breakup_chunk

    def counted(chunk, *args, **kwargs):  # noqa: ANN001, ANN202
        read.append(1)
        return real(chunk, *args, **kwargs)

    monkeypatch.setattr(mcap.reader, "breakup_chunk", counted)
    scene = read_bag_scene(bag, "/camera/points", at=10.0)
    np.testing.assert_array_equal(scene.views[0].points, (cloud + 10).astype("f4"))
    np.testing.assert_allclose(scene.views[0].T_world_camera, _T([0, 0, 0]))
    assert len(read) <= 4, "one chunk a message: the bag is not read whole"


def test_plan_cli_on_a_bag_is_recorded(tmp_path: Path) -> None:
    """The `plan` command reads the bag; the recording replays identically."""
    from typer.testing import CliRunner

    from wsgrasp.cli import app
    from wsgrasp.perception.synth import synth_scene
    from wsgrasp.record import open_run, replay_run

    syn = synth_scene("box", views=1, seed=0, width=160, height=120)
    v = syn.views[0]
    bag = write_cloud_bag(
        tmp_path / "cap.mcap",
        [("/cam/points", "cam", v.points, S)],
        [("/tf_static", "world", "cam", v.T_world_camera, 0)],
    )
    spec = Path(__file__).parents[1] / "examples" / "specs" / "franka.yaml"
    rec = tmp_path / "run.mcap"
    res = CliRunner().invoke(
        app,
        [
            "plan",
            str(bag),
            "--topic",
            "/cam/points",
            "--spec",
            str(spec),
            "--record",
            str(rec),
            "--json",
        ],
    )
    assert res.exit_code == 0, res.stdout
    run = open_run(rec)
    assert run.scene.views[0].name.startswith("/cam/points")
    assert replay_run(run).identical


K = [280.0, 0.0, 79.5, 0.0, 282.0, 59.5, 0.0, 0.0, 1.0]


@pytest.mark.parametrize(
    ("encoding", "scale", "pad", "big_endian"),
    [("16UC1", 0.001, 0, False), ("32FC1", 1.0, 8, True), ("mono16", 0.001, 4, True)],
)
def test_a_depth_image_with_its_camera_info(
    tmp_path: Path, encoding: str, scale: float, pad: int, big_endian: bool
) -> None:
    """A depth Image is deprojected by the K of the camera_info beside it, in
    millimetres (16-bit) or metres (float), with padded rows and either byte
    order; its pixels without depth are counted."""
    rng = np.random.default_rng(1)
    mm = rng.integers(400, 900, (120, 160)).astype(np.uint16)
    mm[:3] = 0
    depth = mm if scale < 1 else (mm * 0.001).astype(np.float32)
    path = write_depth_bag(
        tmp_path / "d.mcap",
        "/camera/depth/image_rect_raw",
        "camera_depth_optical_frame",
        depth,
        K,
        encoding=encoding,
        pad=pad,
        big_endian=big_endian,
    )
    scene = read_bag_scene(path, "/camera/depth/image_rect_raw")
    k = Intrinsics(fx=K[0], fy=K[4], cx=K[2], cy=K[5])
    want = depth_points(mm, k)
    np.testing.assert_allclose(scene.points, want[want.any(axis=1)], atol=1e-6)
    assert scene.dropped_no_depth == 3 * 160


def test_a_depth_image_that_cannot_be_read_is_named(tmp_path: Path) -> None:
    """No camera_info beside it, a colour encoding, short data: one error each."""
    depth = np.full((12, 16), 500, dtype=np.uint16)
    topic = "/camera/depth/image_rect_raw"
    bare = write_depth_bag(tmp_path / "a.mcap", topic, "cam", depth, None)
    with pytest.raises(InputError, match="no sensor_msgs/msg/CameraInfo beside it"):
        read_bag_scene(bare, topic)
    rgb = write_depth_bag(tmp_path / "b.mcap", topic, "cam", depth, K, encoding="rgb8")
    with pytest.raises(InputError, match="encoding 'rgb8', not a depth encoding"):
        read_bag_scene(rgb, topic)
    short = write_depth_bag(tmp_path / "c.mcap", topic, "cam", depth, K, cut=7)
    with pytest.raises(InputError, match="bytes of data for 12 rows of 16 pixels"):
        read_bag_scene(short, topic)


def test_bags_whose_schema_ids_name_other_types(tmp_path: Path, bag: Path) -> None:
    """Schema ids are numbers within one file: a cloud bag's id 1 is
    PointCloud2 where a depth bag's is Image. Read one after the other in one
    process, each is decoded by its own definitions."""
    depth = np.full((120, 160), 500, dtype=np.uint16)
    topic = "/camera/depth/image_rect_raw"
    other = write_depth_bag(tmp_path / "d.mcap", topic, "cam", depth, K)
    for _ in range(2):
        assert len(read_bag_scene(bag, "/camera/points").points) == 500
        assert len(read_bag_scene(other, topic).points) == 120 * 160


def test_plan_on_a_bag_of_depth_images(tmp_path: Path, capsys) -> None:
    """``plan BAG --topic IMAGE`` plans on a rendered camera's depth image with
    the camera_info beside it; ``--intrinsics`` with a bag is refused."""
    from wsgrasp.cli import main
    from wsgrasp.perception.synth import synth_scene

    synth = synth_scene("cylinder", size=(0.03, 0.12), views=1, seed=1)
    cam = synth.cameras[0]
    mm = np.rint(cam.depth_image(synth.views[0].points) * 1000).astype(np.uint16)
    k = [cam.fx, 0.0, cam.cx, 0.0, cam.fy, cam.cy, 0.0, 0.0, 1.0]
    topic = "/camera/depth/image_rect_raw"
    path = write_depth_bag(tmp_path / "d.mcap", topic, "camera", mm, k)
    args = ["plan", str(path), "--topic", topic, "-g", "franka_hand", "--no-record"]
    assert main([*args, "--json"]) == 0
    assert '"found": true' in capsys.readouterr().out
    assert main([*args, "--intrinsics", "1,1,1,1"]) == 2
    assert "camera_info beside them" in capsys.readouterr().err


@pytest.mark.parametrize(
    "fmt",
    [
        "16UC1; compressedDepth png",
        "16UC1",
        "32FC1",
        "16UC1; compressedDepth rvl",
        "32FC1; compressedDepth rvl",
    ],
)
def test_a_compressed_depth_image(tmp_path: Path, fmt: str) -> None:
    """A compressedDepth image (its PNG or RVL after
    compressed_depth_image_transport's header; a 32FC1 one as quantised inverse
    depth) plans as the raw image, with the camera_info beside the image it
    compressed."""
    mm = np.random.default_rng(2).integers(400, 900, (120, 160)).astype(np.uint16)
    mm[:2] = 0
    k = Intrinsics(fx=K[0], fy=K[4], cx=K[2], cy=K[5])
    want = depth_points(mm, k)
    stored = mm
    if fmt.startswith("32FC1"):
        a, b = DEPTH_QUANT
        z = np.where(mm > 0, mm * 0.001, np.inf)
        stored = np.where(mm > 0, np.rint(a / z + b), 0).astype(np.uint16)
        fmt = fmt if "; " in fmt else "32FC1; compressedDepth png"
    topic = "/camera/depth/image_rect_raw"
    path = write_depth_bag(tmp_path / "c.mcap", topic, "cam", stored, K, compressed=fmt)
    scene = read_bag_scene(path, topic + "/compressedDepth")
    assert scene.dropped_no_depth == 2 * 160
    if fmt.startswith("16UC1"):
        np.testing.assert_allclose(scene.points, want[want.any(axis=1)], atol=1e-6)
    else:  # the inverse depth's steps: a tenth of a millimetre at 0.9 m
        np.testing.assert_allclose(scene.points, want[want.any(axis=1)], atol=2e-4)


def test_a_colour_or_unknown_compressed_image_is_named(tmp_path: Path) -> None:
    depth = np.full((120, 160), 500, dtype=np.uint16)
    topic = "/camera/depth/image_rect_raw"
    for fmt, match in (
        ("bgr8; jpeg compressed bgr8", "not a depth image's compressedDepth"),
        ("16UC1; compressedDepth zstd", "compressedDepth 'zstd' is not read"),
    ):
        path = write_depth_bag(
            tmp_path / "c.mcap", topic, "cam", depth, K, compressed=fmt
        )
        with pytest.raises(InputError, match=match):
            read_bag_scene(path, topic + "/compressedDepth")


def test_rvl_decodes_what_the_plain_encoder_wrote() -> None:
    """:func:`decode_rvl` gives back every image the loop-by-loop encoder
    wrote: holes of every length, a row of zeros, values that wrap round
    (65535 after 1), an image of zeros, one pixel, an image of holes with a
    patch of depth (far smaller than 4 to 1); data cut short or with sizes it
    cannot hold is a ValueError."""
    rng = np.random.default_rng(5)
    images = [np.zeros((3, 4), dtype=np.uint16), np.array([[7]], dtype=np.uint16)]
    for _ in range(20):
        h, w = rng.integers(1, 40, 2)
        img = rng.integers(0, 65536, (h, w)).astype(np.uint16)
        img[rng.random((h, w)) < rng.random()] = 0  # holes, few to most
        images.append(img)
    images.append(np.array([[1, 65535, 1, 0, 0, 2]], dtype=np.uint16))
    sparse = np.zeros((480, 640), dtype=np.uint16)  # 40 to 1: holes cost little
    sparse[200:220, 300:340] = 700
    images.append(sparse)
    for img in images:
        np.testing.assert_array_equal(decode_rvl(encode_rvl(img)), img)
    data = encode_rvl(images[-3])
    for bad in (data[:5], data[: len(data) // 2], b"\0" * 8 + data[8:]):
        with pytest.raises(ValueError, match="RVL"):
            decode_rvl(bad)
