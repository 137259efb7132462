"""One command line: short options that mean one thing everywhere, one
``gripper`` group, help without types on flags, ``plan --gripper``, ``view``
beside the run, ``spec check`` listing every problem, ``replay``'s exit codes,
``runs/latest.mcap`` and tables that fit 80 columns."""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import typer.main
from test_record_fakes import plan_recorded

from wsgrasp.cli import app, main
from wsgrasp.cli._common import console

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "examples" / "scenes" / "box_upright.npz"
OTHER_SPEC = (
    "version: 1\ngripper: fake_franka\nsegmenter: {name: ransac_dbscan}\n"
    "sampling: {points: 60, orientations: 3, angle_range_deg: 180}\n"
    "scorers: [{name: centroid_distance, weight: 1.0}]\n"
)


def _commands(group: Any, prefix: str = "") -> Iterator[tuple[str, Any]]:
    for name, cmd in group.commands.items():
        yield f"{prefix}{name}", cmd
        if hasattr(cmd, "commands"):  # a group (typer vendors its own click)
            yield from _commands(cmd, f"{prefix}{name} ")


@pytest.fixture(scope="module")
def run_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("cli") / "run.mcap"
    plan_recorded(path)
    return path


@pytest.fixture
def width_80() -> Iterator[None]:
    before = console.width
    console.width = 80
    yield
    console.width = before


def test_each_short_option_means_one_thing_everywhere() -> None:
    meaning: dict[str, set[str]] = {}
    for _, cmd in _commands(typer.main.get_command(app)):  # type: ignore[arg-type]
        for p in (p for p in cmd.params if p.param_type_name == "option"):
            longs = [o for o in p.opts if o.startswith("--")]
            for short in (o for o in p.opts if not o.startswith("--")):
                meaning.setdefault(short, set()).add(longs[0])
    clashes = {s: m for s, m in meaning.items() if len(m) > 1}
    assert not clashes, f"short options with several meanings: {clashes}"
    assert meaning["-o"] == {"--out"} and meaning["-s"] == {"--spec"}
    assert meaning["-g"] == {"--gripper"}


def test_help_shows_no_type_on_flags(capsys: pytest.CaptureFixture[str]) -> None:
    root = typer.main.get_command(app)
    for name, _ in [("", root), *_commands(root)]:  # type: ignore[arg-type]
        assert main([*name.split(), "--help"]) == 0
        text = capsys.readouterr().out
        assert "<bool>" not in text, f"`wsgrasp {name} --help` prints <bool>"


def test_one_gripper_group_and_a_hidden_plural(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["--help"]) == 0
    top = capsys.readouterr().out
    assert "  gripper " in top and "  grippers " not in top
    assert main(["gripper", "--help"]) == 0
    group = capsys.readouterr().out
    for sub in ("list", "show", "new", "check"):
        assert f"  {sub} " in group
    assert main(["grippers", "list", "--help"]) == 0  # the old spelling works


def test_spec_check_lists_every_problem_at_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        "version: 1\ngripper: franka_hnd\ncolour: red\n"
        "segmenter: {name: ransac_dbscan, options: {plane_distance: -1, bogus: 3}}\n"
        "sampling: {points: -5}\n"
        "scorers: [{name: centroid_distance, weight: -1}, {name: nope}]\n"
    )
    assert main(["spec", "check", str(bad)]) == 2
    err = capsys.readouterr().err
    problems = [line for line in err.splitlines() if line.startswith("error:")]
    wanted = [
        ":2: gripper: unknown gripper 'franka_hnd'",
        ":3: unknown key 'colour'",
        ":4: segmenter.options.plane_distance",
        ":4: unknown key 'segmenter.options.bogus'",
        ":5: sampling.points",
        ":6: scorers.0.weight",
        ":6: scorers.1.name: unknown scorer 'nope'",
    ]
    assert len(problems) == len(wanted), err
    for line, fragment in zip(problems, wanted, strict=True):
        assert fragment in line, (fragment, line)
    assert "7 problems" in err
    assert "spec check" not in err, "the fix of `spec check` is not `spec check`"
    assert "Traceback" not in err


def test_plugins_names_each_distribution_once(
    capsys: pytest.CaptureFixture[str], width_80: None
) -> None:
    assert main(["plugins"]) == 0
    out = capsys.readouterr().out
    assert out.count("wsgrasp 0.1.0") == 1
    assert "…" not in out and max(map(len, out.splitlines())) <= 80
    assert main(["plugins", "--options"]) == 0
    assert "plane_distance" in capsys.readouterr().out


def test_inspect_fits_80_columns(
    run_path: Path, capsys: pytest.CaptureFixture[str], width_80: None
) -> None:
    assert main(["inspect", str(run_path)]) == 0
    out = capsys.readouterr().out
    assert "…" not in out, "a header or value was cut"
    assert max(map(len, out.splitlines())) <= 80
    assert "centroid" in out and "distance" in out


def test_replay_exit_codes(
    run_path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    other = tmp_path / "other.yaml"
    other.write_text(OTHER_SPEC)
    # the recorded spec: a check that the run reproduces
    assert main(["replay", str(run_path)]) == 0
    capsys.readouterr()
    # another spec: the difference is the result, exit 0 when it ran
    assert main(["replay", str(run_path), "-s", str(other), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["identical"] is False
    # scripts that need the same result say so
    assert main(["replay", str(run_path), "-s", str(other), "--expect-identical"]) == 1
    assert main(["replay", str(run_path), "--expect-identical"]) == 0


def test_view_writes_beside_the_run(run_path: Path, tmp_path: Path) -> None:
    run = tmp_path / "a.mcap"
    run.write_bytes(run_path.read_bytes())
    link = tmp_path / "latest.mcap"
    link.symlink_to(run.name)
    assert main(["view", str(link)]) == 0
    # beside the run the link points at, named after it
    assert (tmp_path / "a.png").stat().st_size > 20_000
    assert (tmp_path / "a.html").stat().st_size > 20_000
    assert main(["view", str(run)]) == 2, "existing pictures need --force"
    assert main(["view", str(run), "--force"]) == 0


def test_plan_with_a_gripper_and_no_spec(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["plan", str(SCENE), "-g", "franka_hand", "--json"]) == 0
    first = json.loads(capsys.readouterr().out)
    assert first["gripper"] == "franka_hand" and first["found"]
    recording = Path(first["recording"])
    latest = recording.parent / "latest.mcap"
    assert latest.is_symlink() and os.readlink(latest) == recording.name
    # a second plan moves the link to the newest recording
    assert main(["plan", str(SCENE), "-g", "franka_hand", "--json"]) == 0
    second = Path(json.loads(capsys.readouterr().out)["recording"])
    assert second != recording and os.readlink(latest) == second.name


def test_plan_gripper_replaces_the_spec_gripper(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = ROOT / "examples" / "specs" / "allegro.yaml"
    args = ["plan", str(SCENE), "-s", str(spec), "-g", "franka_hand", "--no-record"]
    assert main([*args, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["gripper"] == "franka_hand"


def test_plan_gripper_replaces_a_gripper_not_installed_here(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A spec that a gripper package ships names its gripper, which may not be
    installed where it is used: with --gripper replacing it, the spec plans;
    without, the unknown name is the error."""
    text = (ROOT / "examples" / "specs" / "franka.yaml").read_text()
    spec = tmp_path / "default.yaml"
    spec.write_text(text.replace("gripper: franka_hand", "gripper: not_here"))
    assert "gripper: not_here" in spec.read_text()
    args = ["plan", str(SCENE), "-s", str(spec), "--no-record"]
    assert main([*args, "-g", "franka_hand", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["found"]
    assert main(args) == 2
    assert "unknown gripper 'not_here'" in capsys.readouterr().err


def test_plan_needs_a_spec_or_a_gripper(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", str(SCENE)]) == 2
    assert "--gripper" in capsys.readouterr().err
    assert main(["plan", str(SCENE), "-g", "no_such_gripper", "--no-record"]) == 2
    assert "no_such_gripper" in capsys.readouterr().err


def test_latest_link_never_replaces_a_recording(tmp_path: Path) -> None:
    from wsgrasp.cli._plan import link_latest

    run = tmp_path / "b.mcap"
    run.write_bytes(b"x")
    real = tmp_path / "latest.mcap"
    real.write_bytes(b"a recording of its own")
    assert link_latest(run) is None
    assert real.read_bytes() == b"a recording of its own"
