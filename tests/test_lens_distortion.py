"""A camera's raw depth image with its lens distortion: rectified before it is
deprojected (:func:`wsgrasp.perception.depth.rectify_depth`), from a scene YAML,
``--intrinsics FILE:raw`` and a bag's ``image_raw`` topic; a rectified image
through its ``P``; and a camera_info whose distortion could be either, named."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from bag_factory import write_depth_bag
from PIL import Image

from wsgrasp.cli import main
from wsgrasp.errors import InputError
from wsgrasp.perception.bag import read_bag_scene
from wsgrasp.perception.depth import Intrinsics, depth_points
from wsgrasp.perception.flying import pixel_grid
from wsgrasp.perception.io import load_scene

W, H = 160, 120
PINHOLE = {"fx": 120.0, "fy": 120.0, "cx": 80.3, "cy": 59.6}
#: lenses of the three models, bending the image's corners by several pixels
#: (the last like a wide-angle time-of-flight camera's)
LENSES = {
    "plumb_bob": [-0.28, 0.09, 0.0012, -0.0008, -0.012],
    "equidistant": [0.08, -0.03, 0.01, -0.002],
    "rational_polynomial": [0.35, -0.05, 0.0004, 0.0002, 0.001, 0.7, -0.02, 0.003],
}
#: the plane every test image sees: n . X = c, tilted 30 degrees towards +x
NORMAL = np.array([-np.sin(np.radians(30.0)), 0.0, np.cos(np.radians(30.0))])
OFFSET = 0.6


def _lens(model: str, c: list[float], x: np.ndarray, y: np.ndarray) -> tuple:
    """Undistorted normalised points through the lens, written out term by
    term as OpenCV documents its camera and fisheye models."""
    if model == "equidistant":
        r = np.hypot(x, y)
        theta = np.arctan(r)
        theta_d = theta * (
            1 + c[0] * theta**2 + c[1] * theta**4 + c[2] * theta**6 + c[3] * theta**8
        )
        scale = theta_d / np.where(r > 0, r, 1.0)
        return x * np.where(r > 0, scale, 1.0), y * np.where(r > 0, scale, 1.0)
    k1, k2, p1, p2, k3, k4, k5, k6 = [*c, 0.0, 0.0, 0.0, 0.0, 0.0][:8]
    r2 = x * x + y * y
    radial = (1 + k1 * r2 + k2 * r2**2 + k3 * r2**3) / (
        1 + k4 * r2 + k5 * r2**2 + k6 * r2**3
    )
    return (
        x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
        y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y,
    )


def _raw_image(model: str, c: list[float], supersample: int = 5) -> np.ndarray:
    """The raw depth image (millimetres) of ``NORMAL . X = OFFSET`` through the
    lens, by rays alone: rays spread finely over the undistorted image and
    well past it, each sent through the lens, each raw pixel taking the depth
    of the ray that lands nearest its centre (no lens inverted)."""
    k = PINHOLE
    s = np.arange(-W // 2 * supersample, 3 * W // 2 * supersample) / supersample
    t = np.arange(-H // 2 * supersample, 3 * H // 2 * supersample) / supersample
    u, v = np.meshgrid(s, t)
    x, y = ((u - k["cx"]) / k["fx"]).ravel(), ((v - k["cy"]) / k["fy"]).ravel()
    xd, yd = _lens(model, c, x, y)
    # the rays the lens still moves outwards (past, it folds them back)
    xo, yo = _lens(model, c, x * 1.001, y * 1.001)
    grows = np.hypot(xo, yo) > np.hypot(xd, yd)
    ud, vd = k["fx"] * xd + k["cx"], k["fy"] * yd + k["cy"]
    z = OFFSET / (NORMAL[0] * x + NORMAL[1] * y + NORMAL[2])
    iu, iv = np.rint(ud).astype(int), np.rint(vd).astype(int)
    keep = np.flatnonzero(grows & (iu >= 0) & (iu < W) & (iv >= 0) & (iv < H))
    pixel = iv[keep] * W + iu[keep]
    miss = np.hypot(ud - iu, vd - iv)[keep]
    order = np.lexsort((miss, pixel))  # by pixel, the nearest ray first
    first = np.unique(pixel[order], return_index=True)[1]
    depth = np.zeros(H * W)
    depth[pixel[order][first]] = z[keep][order][first]
    assert (depth > 0).all()
    return np.rint(depth.reshape(H, W) * 1000).astype(np.uint16)


def _bound(points: np.ndarray) -> float:
    """How far off the plane a rectified pixel's point may lie (m): tan 30° of
    a pixel's width at the farthest point, and half a millimetre of depth."""
    pixel = points[:, 2].max() / PINHOLE["fx"]
    return float(np.tan(np.radians(30.0)) * pixel + 0.5e-3)


def _off_plane(points: np.ndarray) -> np.ndarray:
    p = points[points.any(axis=1)]
    return np.abs(p @ NORMAL - OFFSET)


@pytest.mark.parametrize("model", list(LENSES))
def test_a_raw_image_lies_on_its_surface_once_its_lens_is_undone(model: str):
    """Every point of a raw image of a plane lies on the plane once the lens
    distortion is undone, as near as the pixels allow (each takes the depth of
    a raw pixel whose ray passes within a pixel of its own, on a plane whose
    depth changes by tan 30° of that per pixel; depths in millimetres):
    millimetres for this 160 x 120 camera. Deprojected through the pinhole
    model alone, the same image bends the plane by centimetres. The points
    are a pinhole camera's again: the flying-pixel filter finds their pixel
    grid."""
    mm = _raw_image(model, LENSES[model])
    raw = Intrinsics(**PINHOLE, distortion_model=model, distortion=LENSES[model])
    undone = depth_points(mm, raw)
    bent = depth_points(mm, Intrinsics(**PINHOLE))
    bound = _bound(undone)
    assert _off_plane(undone).max() < bound, model
    assert np.median(_off_plane(undone)) < bound / 3, model
    assert _off_plane(bent).max() > 10 * bound, model
    # most pixels keep a depth; those whose rays miss the raw image have none
    assert undone.any(axis=1).mean() > 0.9
    assert pixel_grid(undone[undone.any(axis=1)]) is not None


def test_a_lens_that_folds_back_leaves_those_pixels_without_depth():
    """Past the radius where a strong barrel distortion stops moving a ray
    outwards, the model folds back over the image: those pixels get no
    depth rather than another pixel's."""
    folding = Intrinsics(
        **PINHOLE, distortion_model="plumb_bob", distortion=[-1.2, 0.0, 0, 0, 0]
    )
    mm = np.full((H, W), 700, dtype=np.uint16)
    points = depth_points(mm, folding)
    r = np.hypot(
        (np.arange(W)[None] - PINHOLE["cx"]) / PINHOLE["fx"],
        (np.arange(H)[:, None] - PINHOLE["cy"]) / PINHOLE["fy"],
    ).ravel()
    has = points.any(axis=1)
    # r (1 - 1.2 r^2) grows up to r = 1/sqrt(3.6) and falls past it
    assert has[r < 0.5].all() and not has[r > 0.56].any()


def test_distortion_needs_its_model_and_its_number_of_coefficients():
    with pytest.raises(ValueError, match="need their distortion_model"):
        Intrinsics(**PINHOLE, distortion=[0.1, 0, 0, 0, 0])
    with pytest.raises(ValueError, match="rational_polynomial distortion has 8"):
        Intrinsics(**PINHOLE, distortion_model="rational_polynomial", distortion=[0.1])
    flat = Intrinsics(**PINHOLE, distortion_model="plumb_bob", distortion=[0.0] * 5)
    assert not flat.distorted


def _camera_info(d: list[float], model: str = "plumb_bob") -> dict:
    k = PINHOLE
    return {
        "height": H,
        "width": W,
        "distortion_model": model,
        "d": d,
        "k": [k["fx"], 0.0, k["cx"], 0.0, k["fy"], k["cy"], 0.0, 0.0, 1.0],
        "p": [101.0, 0.0, 79.0, 0.0, 0.0, 102.0, 61.0, 0.0, 0.0, 0.0, 1.0, 0.0],
    }


def test_a_camera_info_with_a_distortion_says_which_image(tmp_path: Path, capsys):
    """A camera_info file whose D is not zero goes with the raw image
    (``FILE:raw``: K and D) or the rectified one (``FILE:rect``: P); given
    bare, it is refused naming both. In a scene YAML the same."""
    info = tmp_path / "info.yaml"
    info.write_text(yaml.safe_dump(_camera_info(LENSES["plumb_bob"])) + "---\n")
    with pytest.raises(InputError, match="does not say which image") as exc:
        Intrinsics.parse(str(info))
    assert ":raw" in exc.value.hint and ":rect" in exc.value.hint
    raw = Intrinsics.parse(f"{info}:raw")
    assert (raw.fx, raw.cx, raw.distortion) == (120.0, 80.3, LENSES["plumb_bob"])
    rect = Intrinsics.parse(f"{info}:rect")
    assert (rect.fx, rect.fy, rect.cx, rect.cy, rect.distorted) == (
        101.0,
        102.0,
        79.0,
        61.0,
        False,
    )
    mm = _raw_image("plumb_bob", LENSES["plumb_bob"])
    Image.fromarray(mm).save(tmp_path / "d.png")
    for ref, want in ((f"{info.name}:raw", raw), (f"{info.name}:rect", rect)):
        (tmp_path / "s.yaml").write_text(
            f"views:\n  - depth: d.png\n    intrinsics: {ref}\n"
        )
        points = load_scene(tmp_path / "s.yaml").points
        expect = depth_points(mm, want)
        np.testing.assert_allclose(points, expect[expect.any(axis=1)], atol=1e-9)
    inline = {**PINHOLE, "distortion_model": "plumb_bob"}
    (tmp_path / "i.yaml").write_text(
        yaml.safe_dump(
            {
                "views": [
                    {
                        "depth": "d.png",
                        "intrinsics": {**inline, "distortion": LENSES["plumb_bob"]},
                    }
                ]
            }
        )
    )
    expect = depth_points(mm, raw)
    got = load_scene(tmp_path / "i.yaml").points
    np.testing.assert_allclose(got, expect[expect.any(axis=1)], atol=1e-9)
    args = ["scene", "info", str(tmp_path / "d.png"), "--intrinsics", str(info)]
    assert main(args) != 0
    err = " ".join(capsys.readouterr().err.split())
    assert "does not say which image" in err and f"{info}:raw" in err
    assert "Traceback" not in err
    main([*args[:-1], f"{info}:raw"])  # a plane alone: nothing stands on it
    err = " ".join(capsys.readouterr().err.split())
    assert "nothing stands on the table" in err and "which image" not in err
    fisheye = tmp_path / "fisheye.yaml"
    fisheye.write_text(yaml.safe_dump(_camera_info([0.1] * 6, "kannala_brandt")))
    with pytest.raises(InputError, match="is not undone"):
        Intrinsics.parse(f"{fisheye}:raw")
    assert not Intrinsics.parse(f"{fisheye}:rect").distorted


def test_a_bag_raw_topic_is_rectified_and_a_rect_topic_read_through_p(
    tmp_path: Path,
):
    """A depth Image on ``image_raw`` (or its compressedDepth transport) is
    rectified by the K and D of its camera_info; on an ``image_rect`` topic
    (RealSense's ``image_rect_raw`` too) it is already rectified, and its P
    gives the intrinsics."""
    mm = _raw_image("rational_polynomial", LENSES["rational_polynomial"])
    info = _camera_info(LENSES["rational_polynomial"], "rational_polynomial")
    raw = Intrinsics(
        **PINHOLE,
        distortion_model="rational_polynomial",
        distortion=LENSES["rational_polynomial"],
    )
    rect = Intrinsics(fx=101.0, fy=102.0, cx=79.0, cy=61.0)
    # the last: the raw image's compressedDepth transport, after its topic
    for topic, want, compressed in (
        ("/depth/image_raw", raw, None),
        ("/camera/depth/image_rect_raw", rect, None),
        ("/camera/depth/image_rect", rect, None),
        ("/depth/image_raw", raw, "16UC1; compressedDepth png"),
    ):
        path = write_depth_bag(
            tmp_path / "b.mcap",
            topic,
            "depth_camera_link",
            mm,
            info["k"],
            distortion=info["d"],
            distortion_model=info["distortion_model"],
            p=info["p"],
            compressed=compressed,
        )
        read = topic + "/compressedDepth" if compressed else topic
        points = read_bag_scene(path, read).points
        expect = depth_points(mm, want)
        np.testing.assert_allclose(points, expect[expect.any(axis=1)], atol=1e-9)
    undone = depth_points(mm, raw)
    assert _off_plane(undone).max() < _bound(undone)


def test_scene_synth_writes_a_raw_image_through_a_lens(tmp_path: Path, capsys):
    """``scene synth --depth-images --lens`` writes each view as the raw image
    its lens bends, listed with the distortion: loaded back, it is the view's
    surfaces again (its points within a few millimetres of the rendered
    cloud's); read through the pinhole model alone it is not; and it plans.
    A lens that is no model, or one without depth images, is named."""
    from scipy.spatial import cKDTree

    lens = "plumb_bob:" + ",".join(map(str, LENSES["plumb_bob"]))
    out = tmp_path / "cam"
    args = ["scene", "synth", "--object", "box", "--size", "0.05,0.06,0.12"]
    args += ["--views", "1", "--camera-frame", "--seed", "3", "-o"]
    args += [str(tmp_path / "m.npz"), "--views-out", str(out), "--depth-images"]
    assert main([*args, "--lens", lens]) == 0
    doc = yaml.safe_load((out / "scene.yaml").read_text())
    k = doc["views"][0]["intrinsics"]
    assert (k["distortion_model"], k["distortion"]) == (
        "plumb_bob",
        LENSES["plumb_bob"],
    )
    rendered = np.load(tmp_path / "m.npz")["points"]
    tree = cKDTree(rendered)
    undone = load_scene(out / "scene.yaml").points
    del k["distortion_model"], k["distortion"]
    (out / "pinhole.yaml").write_text(yaml.safe_dump(doc))
    bent = load_scene(out / "pinhole.yaml").points
    near, far = tree.query(undone)[0], tree.query(bent)[0]
    assert np.median(near) < 1e-3 and np.percentile(near, 95) < 3e-3
    # (the bent table mostly slides along itself: its nearest distances show
    # a part of the bend)
    assert np.percentile(far, 95) > max(3 * np.percentile(near, 95), 5e-3)
    capsys.readouterr()
    assert main(["plan", str(out / "scene.yaml"), "-g", "franka_hand", "--json"]) == 0
    assert '"found": true' in capsys.readouterr().out
    assert main([*args, "--lens", "plumb_bob:1,2"]) == 2
    assert "not a distortion model" in capsys.readouterr().err
    assert main([*args[:-3], "--lens", lens]) == 2
    assert "needs --depth-images" in capsys.readouterr().err


def test_a_binned_image_or_a_region_of_interest_takes_its_own_pixels(
    tmp_path: Path,
):
    """A camera_info keeps the full sensor's K: an image binned 2 x 2 or cut
    to a region of interest is deprojected through K scaled and shifted to its
    own pixels (a binned pixel's centre the mean of its full pixels'), from a
    bag and from a camera_info file alike."""
    full = [240.0, 0.0, 160.3, 0.0, 241.0, 119.6, 0.0, 0.0, 1.0]  # 320 x 240
    cases = {
        ((2, 2), (0, 0), (120, 160)): Intrinsics(fx=120, fy=120.5, cx=79.9, cy=59.55),
        ((0, 0), (40, 30), (150, 200)): Intrinsics(fx=240, fy=241, cx=120.3, cy=89.6),
        ((2, 1), (10, 0), (240, 150)): Intrinsics(fx=120, fy=241, cx=74.9, cy=119.6),
    }
    for (binning, roi, shape), want in cases.items():
        mm = np.full(shape, 700, dtype=np.uint16)
        path = write_depth_bag(
            tmp_path / "b.mcap",
            "/camera/depth/image_rect_raw",
            "cam",
            mm,
            full,
            binning=binning,
            roi=roi,
        )
        got = read_bag_scene(path, "/camera/depth/image_rect_raw").points
        np.testing.assert_allclose(got, depth_points(mm, want), atol=1e-9)
        info = {
            "k": full,
            "binning_x": binning[0],
            "binning_y": binning[1],
            "roi": {"x_offset": roi[0], "y_offset": roi[1]},
        }
        (tmp_path / "info.yaml").write_text(yaml.safe_dump(info))
        got_k = Intrinsics.parse(str(tmp_path / "info.yaml"))
        pinhole = ("fx", "fy", "cx", "cy")
        assert [getattr(got_k, a) for a in pinhole] == pytest.approx(
            [getattr(want, a) for a in pinhole]
        )


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("d", ["a", 0, 0, 0, 0], "is not a list of numbers"),
        ("p", "x", "is not a list of numbers"),
        ("binning_x", "two", "are not whole numbers"),
        ("roi", {"x_offset": "left"}, "are not whole numbers"),
    ],
)
def test_a_camera_info_that_is_not_numbers_is_named(
    tmp_path: Path, field, value, match
):
    info = _camera_info([0.0] * 5)
    info[field] = value
    (tmp_path / "info.yaml").write_text(yaml.safe_dump(info))
    with pytest.raises(InputError, match=match):
        Intrinsics.parse(f"{tmp_path / 'info.yaml'}:rect")
