"""From a URDF to a planned grasp, as a user would: `wsgrasp gripper new` on three
URDFs the scaffolder was not written around (the two example plugins' URDFs and a
claw with odd conventions), `pip install` of the packages it writes (and of the two
example packages), `wsgrasp grippers list`, and a plan with each on a scene its
hand fits. Also: a broken third-party plugin does not break the others, and a spec
may name a gripper YAML by a path relative to the spec."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from urdf_factory import write_claw

from wsgrasp import Pipeline
from wsgrasp.cli import main
from wsgrasp.gripper.check import check_gripper
from wsgrasp.gripper.scaffold import scaffold_plugin
from wsgrasp.perception.io import scene_from_arrays
from wsgrasp.perception.synth import synth_scene
from wsgrasp.plugins import Registry, get_registry
from wsgrasp.spec import load_spec

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples" / "plugins"
SCENES = ROOT / "examples" / "scenes"

#: scaffolded name -> (URDF, scene planned on)
SCAFFOLDED = {
    "scaffolded_2f85": (
        EXAMPLES
        / "robotiq_2f85_like"
        / "wsgrasp_robotiq_2f85_like"
        / "robotiq_2f85_like.urdf",
        "mug.npz",
    ),
    "scaffolded_bh8": (
        EXAMPLES
        / "barrett_bh8_like"
        / "wsgrasp_barrett_bh8_like"
        / "barrett_bh8_like.urdf",
        "box_upright.npz",
    ),
    "scaffolded_claw": (None, "synthetic cylinder r 25 mm"),
}
#: the example packages themselves -> scene
SHIPPED = {
    "robotiq_2f85_like": "bottle_lying.npz",
    "barrett_bh8_like": "box_upright.npz",
}


def _pip_install(site: Path, packages: list[Path]) -> None:
    """``pip install --no-deps --target site`` (one call). Without build isolation
    first (fast, offline; needs `wheel` or setuptools >= 70.1 in the venv), then
    with it (pip fetches setuptools); skips when neither can build."""
    cmd = [sys.executable, "-m", "pip", "install", "-q", "--no-deps"]
    cmd += ["--target", str(site)] + [str(p) for p in packages]
    done = subprocess.run(
        [*cmd, "--no-build-isolation"], capture_output=True, text=True, check=False
    )
    if done.returncode != 0 and "bdist_wheel" in done.stderr:
        done = subprocess.run(cmd, capture_output=True, text=True, check=False)
        if done.returncode != 0:
            pytest.skip(
                "cannot build wheels here: `pip install wheel` into the venv "
                f"({done.stderr.strip().splitlines()[-1:]})"
            )
    assert done.returncode == 0, done.stderr


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """Scaffold three plugins, install them and the two examples into a site
    directory put on sys.path; yields (registry, site); removes them after."""
    mp = pytest.MonkeyPatch()
    base = tmp_path_factory.mktemp("plugins")
    mp.setenv("WSGRASP_CACHE_DIR", str(base / "cache"))
    claw = write_claw(base / "claw_src")
    packages = []
    for name, (urdf, _) in SCAFFOLDED.items():
        out = base / "src" / name
        _, sc = scaffold_plugin(name, urdf or claw, out)
        assert not [w for w in sc.warnings if w.startswith("error")], sc.warnings
        packages.append(out)
    for name in SHIPPED:  # copied, so that building leaves nothing in the repo
        packages.append(shutil.copytree(EXAMPLES / name, base / "src" / name))
    site = base / "site"
    _pip_install(site, packages)
    mp.syspath_prepend(str(site))
    get_registry.cache_clear()
    yield Registry.from_entry_points(), site
    # uninstall: forget the site directory, its modules and the cached registry
    mp.undo()
    for mod in [m for m in sys.modules if m.startswith("wsgrasp_scaffolded_")]:
        del sys.modules[mod]
    for name in SHIPPED:
        sys.modules.pop(f"wsgrasp_{name}", None)
    get_registry.cache_clear()


def test_installed_plugins_are_listed(installed, capsys):
    reg, _ = installed
    names = set(reg.names("grippers"))
    assert {*SCAFFOLDED, *SHIPPED, "franka_hand"} <= names
    assert not reg.failed
    dists = {reg.get("grippers", n).plugin.distribution for n in SCAFFOLDED}
    # distribution names compared as PEP 503 normalises them (setuptools versions
    # spell the installed name with "-" or "_")
    assert {_normalised(d) for d in dists} == {_normalised(n) for n in SCAFFOLDED}
    # `wsgrasp grippers list` builds and lists every gripper
    assert main(["grippers", "list", "--json"]) == 0
    rows = {r["name"]: r for r in json.loads(capsys.readouterr().out)}
    assert {*SCAFFOLDED, *SHIPPED} <= set(rows)
    for name in [*SCAFFOLDED, *SHIPPED]:
        assert "error" not in rows[name], rows[name]
    assert rows["scaffolded_bh8"]["fingers"] == 3


@pytest.mark.parametrize("name", [*SCAFFOLDED, *SHIPPED])
def test_each_plugin_checks_clean_and_plans(installed, name):
    reg, _ = installed
    report = check_gripper(name, registry=reg)
    assert not report.errors, report.format()
    pipe = Pipeline(
        load_spec({"gripper": name, "record": {"enabled": False}}, registry=reg),
        registry=reg,
    )
    scene = SCAFFOLDED[name][1] if name in SCAFFOLDED else SHIPPED[name]
    if scene.endswith(".npz"):
        result = pipe.plan(SCENES / scene)
    else:
        syn = synth_scene("cylinder", size=(0.025, 0.12), seed=0, width=160, height=120)
        result = pipe.plan(scene_from_arrays(syn.points))
    assert result.found, (name, result.hint, result.rejections)
    assert len(result.contacts) == pipe.gripper.num_fingers


def test_claw_guesses(installed):
    """The claw: approach along x, revolute fingers; the guesses the tests of the
    scaffolder check one by one, seen here through the installed package."""
    reg, _ = installed
    desc_path = reg.get("grippers", "scaffolded_claw").obj
    text = Path(desc_path).read_text()
    assert "approach_axis: [1.0, 0.0, 0.0]" in text
    assert "closing_axis: [0.0, 1.0, 0.0]" in text
    assert (Path(desc_path).parent / "meshes" / "palm.stl").is_file()


BROKEN_IMPORT = "raise ImportError('this plugin is broken on purpose')\n"
BROKEN_YAML = """
from pathlib import Path
from wsgrasp import hookimpl

@hookimpl
def wsgrasp_register_grippers(register):
    register("broken_gripper", Path(__file__).with_name("missing.yaml"))
"""


def _fake_distribution(root: Path, dist: str, module: str, source: str) -> None:
    (root / f"{module}.py").write_text(textwrap.dedent(source))
    info = root / f"{dist}-0.1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\n")
    (info / "entry_points.txt").write_text(f"[wsgrasp]\n{dist} = {module}\n")


def test_broken_plugins_do_not_break_the_others(installed, tmp_path, monkeypatch):
    _fake_distribution(tmp_path, "broken_import", "wsgbroken_import", BROKEN_IMPORT)
    _fake_distribution(tmp_path, "broken_yaml", "wsgbroken_yaml", BROKEN_YAML)
    monkeypatch.syspath_prepend(str(tmp_path))
    reg = Registry.from_entry_points()
    assert [f.plugin.distribution for f in reg.failed] == ["broken_import"]
    assert "broken on purpose" in reg.failed[0].error
    assert {"scaffolded_2f85", "robotiq_2f85_like", "broken_gripper"} <= set(
        reg.names("grippers")
    )
    # the gripper whose YAML is missing fails alone, with a clear error
    with pytest.raises(Exception, match="missing.yaml"):
        check_gripper("broken_gripper", registry=reg)
    assert not check_gripper("scaffolded_2f85", registry=reg).errors
    for mod in ("wsgbroken_import", "wsgbroken_yaml"):
        sys.modules.pop(mod, None)


def test_spec_names_a_gripper_yaml_by_relative_path(tmp_path, monkeypatch):
    monkeypatch.setenv("WSGRASP_CACHE_DIR", str(tmp_path / "cache"))
    urdf = write_claw(tmp_path / "claw_src")
    project = tmp_path / "project"
    scaffold_plugin("my_claw", urdf, tmp_path / "pkg", check=False)
    shutil.copytree(tmp_path / "pkg" / "wsgrasp_my_claw", project / "grippers")
    spec = project / "spec.yaml"
    spec.write_text(
        "version: 1\ngripper: ./grippers/my_claw.yaml\nrecord: {enabled: false}\n"
    )
    monkeypatch.chdir(tmp_path)  # not the spec's folder: the path is the spec's
    pipe = Pipeline.from_file(spec)
    assert pipe.gripper.name == "my_claw"
    syn = synth_scene("cylinder", size=(0.025, 0.12), seed=1, width=160, height=120)
    assert pipe.plan(scene_from_arrays(syn.points)).found


def _normalised(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()
