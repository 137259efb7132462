"""The documentation: the README's tour, and the site's strict build.

The site is built once (``mkdocs build --strict``, as ``make docs`` does) into a
temporary folder; a broken internal link or anchor, or a render marker that no
longer renders, fails the build. The reference pages are generated from the code
at build time; these tests check the built pages against the code, so a spec
field, a plugin option, a command or a recording channel that the docs leave out
fails here.
"""

from __future__ import annotations

import html
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

pytest.importorskip("mkdocs")
pytest.importorskip("mkdocstrings")

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
LINK = re.compile(r"\]\(([^)\s]+)\)")


def _mkdocs(config: Path, site: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1", "MPLBACKEND": "Agg"}
    return subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(config)]
        + ["-d", str(site)],
        capture_output=True,
        text=True,
        cwd=config.parent,
        env=env,
        timeout=600,
    )


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("site")
    res = _mkdocs(ROOT / "mkdocs.yml", out)
    assert res.returncode == 0, res.stdout + res.stderr
    return out


def _text(site: Path, page: str) -> str:
    """A built page's article as plain text."""
    raw = (site / page / "index.html").read_text()
    body = raw[raw.find("<article") : raw.find("</article>")]
    return html.unescape(re.sub(r"<[^>]+>", " ", body))


# --------------------------------------------------------------------------------
# the README
# --------------------------------------------------------------------------------


def test_readme_starts_with_the_two_commands_and_stays_a_tour() -> None:
    lines = (ROOT / "README.md").read_text().splitlines()
    first_block = lines[lines.index("```sh") + 1 : lines.index("```")]
    assert lines[0].startswith("# wsgrasp")
    assert first_block == ["make demo", "make test"]
    assert len(lines) <= 250


def test_readme_links_resolve() -> None:
    text = (ROOT / "README.md").read_text()
    targets = [t for t in LINK.findall(text) if "://" not in t]
    assert targets, "the README links into the site"
    for target in targets:
        path = target.split("#", 1)[0]
        if path:
            assert (ROOT / path).exists(), f"README links to {target}: not found"


# --------------------------------------------------------------------------------
# the site
# --------------------------------------------------------------------------------


def test_every_page_is_in_the_nav() -> None:
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text().replace("!!python", ""))

    def pages(node: object) -> list[str]:
        if isinstance(node, str):
            return [node]
        if isinstance(node, dict):
            return [p for v in node.values() for p in pages(v)]
        if isinstance(node, list):
            return [p for v in node for p in pages(v)]
        return []

    in_nav = set(pages(config["nav"]))
    on_disk = {
        str(p.relative_to(DOCS)) for p in DOCS.rglob("*.md") if "hooks" not in p.parts
    }
    assert on_disk == in_nav


def test_render_markers_are_known() -> None:
    sys.path.insert(0, str(DOCS / "hooks"))
    try:
        import render  # type: ignore[import-not-found]
    finally:
        sys.path.remove(str(DOCS / "hooks"))
    for page in DOCS.rglob("*.md"):
        for name in render.MARKER.findall(page.read_text()):
            assert name in render.RENDERERS, f"{page}: unknown marker {name}"


def test_results_page_splits_success_by_object_height(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    sys.path.insert(0, str(DOCS / "hooks"))
    try:
        import docs_results  # type: ignore[import-not-found]
    finally:
        sys.path.remove(str(DOCS / "hooks"))
    split = {
        "low_below_m": 0.03,
        "low": {"trials": 4, "successes": 1, "success_rate": 0.25},
        "tall": {"trials": 0, "successes": 0, "success_rate": None},
    }
    report = {
        "results": [
            {"gripper": "hand", "spec": "default", "by_height": split},
            {"gripper": "jaw", "spec": "default"},  # written before the split
        ],
        "baseline": [
            {
                "gripper": "hand",
                "spec": "default",
                "by_height": {
                    "low": {"scenes": 4, "chosen_rate": 0.25, "random_rate": 0.5},
                    "tall": {"scenes": 0, "chosen_rate": None, "random_rate": None},
                },
            }
        ],
    }
    bands, rows = docs_results._by_height(report)
    assert bands == ["objects under 3 cm high", "the others"]
    assert rows == [["hand", "default", "25.0 % of 4 (random 50.0 %)", "– of 0"]]
    assert docs_results._by_height({"results": report["results"][1:]})[1] == []
    # the band's height as the run recorded it
    at_5cm = {**split, "low_below_m": 0.05}
    r5 = {"results": [{"gripper": "hand", "spec": "default", "by_height": at_5cm}]}
    assert docs_results._by_height(r5)[0][0] == "objects under 5 cm high"
    # a folder of runs: a row per run that splits, none for one that does not
    folder = tmp_path / "runs"
    folder.mkdir()
    (folder / "a.json").write_text(json.dumps(report))
    (folder / "b.json").write_text(json.dumps({"results": report["results"][1:]}))
    monkeypatch.setattr(docs_results, "RESULTS", tmp_path)
    out = docs_results._height_table("runs")
    assert "`a.json` | `hand` | `default` | 25.0 % of 4 (random 50.0 %) | – of 0" in out
    assert "b.json" not in out
    (folder / "a.json").unlink()
    assert docs_results._height_table("runs") == ""


def test_strict_build_fails_on_a_broken_link(tmp_path: Path) -> None:
    """The validation settings of mkdocs.yml turn a broken link into a failure."""
    validation = yaml.safe_load(
        "\n".join(
            line
            for line in (ROOT / "mkdocs.yml").read_text().splitlines()
            if not line.startswith("  - docs/hooks")
        )
    )["validation"]
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "index.md").write_text(
        "# Home\n\n[a page that is not there](missing.md) [an anchor](#nowhere)\n"
    )
    config = {
        "site_name": "t",
        "docs_dir": "docs",
        "validation": validation,
    }
    (tmp_path / "mkdocs.yml").write_text(yaml.safe_dump(config))
    res = _mkdocs(tmp_path / "mkdocs.yml", tmp_path / "site")
    assert res.returncode != 0
    assert "missing.md" in res.stdout + res.stderr


def test_site_builds_with_the_generated_pages(site: Path) -> None:
    for page in (
        "reference/spec",
        "reference/plugins",
        "reference/cli",
        "reference/api",
        "reference/recording",
        "results/grippers",
        "results/speed",
        "results/success",
    ):
        assert (site / page / "index.html").is_file(), page
    assert "<!-- render:" not in (site / "reference/spec/index.html").read_text()


def _fields(model: type, seen: set[type] | None = None) -> set[str]:
    """The field names of ``model`` and of the models its fields hold (a model
    that holds itself, as ``Sampling.fallback`` does, once)."""
    from pydantic import BaseModel

    seen = set() if seen is None else seen
    seen.add(model)
    names = set(model.model_fields)  # type: ignore[attr-defined]
    for f in model.model_fields.values():  # type: ignore[attr-defined]
        stack = [f.annotation]
        while stack:
            a = stack.pop()
            if isinstance(a, type) and issubclass(a, BaseModel) and a not in seen:
                names |= _fields(a, seen)
            stack += list(getattr(a, "__args__", ()))
    return names


def test_spec_reference_lists_every_field(site: Path) -> None:
    from wsgrasp.spec import GripperDescription, PipelineSpec

    for page, model in (
        ("reference/spec", PipelineSpec),
        ("reference/gripper-yaml", GripperDescription),
    ):
        words = set(_text(site, page).split())
        missing = sorted(_fields(model) - words)
        assert not missing, f"{page} leaves out {missing}"


def test_plugin_reference_lists_every_builtin_and_option(site: Path) -> None:
    from wsgrasp.plugins import get_registry

    words = set(_text(site, "reference/plugins").split())
    reg = get_registry()
    for kind in ("grippers", "segmenters", "scorers"):
        for name in reg.names(kind):
            r = reg.get(kind, name)
            if r.plugin.distribution != "wsgrasp":
                continue
            assert name in words, f"{kind} {name}"
            options = getattr(r.obj, "Options", None)
            for key in getattr(options, "model_fields", {}):
                assert key in words, f"{kind} {name} option {key}"


def test_cli_reference_has_every_command(site: Path) -> None:
    import typer

    from wsgrasp.cli import app

    text = _text(site, "reference/cli")

    def walk(path: list[str], cmd: object) -> None:
        assert f"Usage: {' '.join(['wsgrasp', *path])} " in text, path
        if hasattr(cmd, "list_commands"):
            ctx = cmd.context_class(cmd)  # type: ignore[attr-defined]
            for name in cmd.list_commands(ctx):
                sub = cmd.get_command(ctx, name)  # type: ignore[attr-defined]
                if sub is not None and not sub.hidden:
                    walk([*path, name], sub)

    walk([], typer.main.get_command(app))


def test_recording_reference_has_every_full_fidelity_topic(site: Path) -> None:
    from wsgrasp.record._codec import TOPICS

    text = _text(site, "reference/recording")
    for topic in TOPICS.values():
        assert topic in text, topic


SPEC_FILES = sorted(
    [
        *ROOT.glob("examples/specs/*.yaml"),
        *ROOT.glob("plugins/grippers/wsgrasp_grippers/*/specs/*.yaml"),
        *ROOT.glob("examples/plugins/*/wsgrasp_*/specs/*.yaml"),
        ROOT / "wsgrasp/data/default_spec.yaml",
    ]
)


@pytest.mark.parametrize(
    "path", SPEC_FILES, ids=[str(p.relative_to(ROOT)) for p in SPEC_FILES]
)
def test_spec_file_comment_is_one_line_linking_to_its_rationale(path: Path) -> None:
    from markdown.extensions.toc import slugify

    comments = [ln for ln in path.read_text().splitlines() if ln.startswith("#")]
    assert len(comments) == 1, f"{path}: {len(comments)} comment lines"
    m = re.search(r"(docs/\S+\.md)#(\S+)", comments[0])
    assert m, f"{path}: the comment links to no section of the docs"
    page = (ROOT / m.group(1)).read_text()
    headings = {slugify(h, "-") for h in re.findall(r"^#+ (.+)$", page, flags=re.M)}
    assert m.group(2) in headings, f"{path}: no section #{m.group(2)}"


def test_readme_gripper_table_is_the_published_run():
    """The README's gripper table is what ``benchmarks/eval_grippers.py`` writes
    from ``docs/results/grippers.json`` and ``grippers-strict.json``, not typed
    by hand."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        import eval_grippers
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    text = (ROOT / "README.md").read_text()
    results = DOCS / "results" / "grippers.json"
    report = json.loads(results.read_text())
    strict = eval_grippers.strict_beside(results)
    assert strict is not None, "docs/results/grippers-strict.json is published"
    start = text.index(eval_grippers.README_START) + len(eval_grippers.README_START)
    table = text[start : text.index(eval_grippers.README_END)]
    assert table == "\n" + eval_grippers.readme_table(report, strict), (
        "the README's gripper table differs from docs/results/grippers.json: run "
        "python benchmarks/eval_grippers.py --readme docs/results/grippers.json"
    )


def test_gripper_run_without_readme_leaves_it(tmp_path: Path) -> None:
    """``eval_grippers.py --no-readme`` (``make eval-grippers-strict``) writes
    its results file and leaves the README's table as it is."""
    before = (ROOT / "README.md").read_text()
    results = tmp_path / "grippers-strict.json"
    argv = ["--grippers-dir", str(tmp_path / "none"), "--only", "no_such_gripper"]
    argv += ["--no-eval", "--protocol", "strict", "--out", str(tmp_path / "out")]
    sys.path.insert(0, str(ROOT / "benchmarks"))  # it imports publish_result
    try:
        import eval_grippers

        code = eval_grippers.main([*argv, "--results", str(results), "--no-readme"])
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
        after = (ROOT / "README.md").read_text()
        (ROOT / "README.md").write_text(before)  # the checkout's, whatever happened
    assert code == 0
    assert after == before
    report = json.loads(results.read_text())
    assert report["protocol"] == "strict" and report["rows"] == []


def test_gripper_table_counts_low_and_tall_objects_apart():
    """The gripper table's split of the plans' grasps by how high the object
    settled: plans only (random draws left out), records without a height
    ignored."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        import eval_grippers
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    low = eval_grippers.LOW_OBJECT
    records = [
        {"pick": "plan", "object_height": low / 2, "outcome": "success"},
        {"pick": "plan", "object_height": low / 2, "outcome": "slipped_lifting"},
        {"pick": "plan", "object_height": 2 * low, "outcome": "success"},
        {"pick": "random", "object_height": 2 * low, "outcome": "slipped_lifting"},
        {"pick": "plan", "outcome": "success"},  # a run from before the heights
    ]
    split = eval_grippers.by_height(records)["by_height"]
    assert split == {
        "low": {"trials": 2, "successes": 1},
        "tall": {"trials": 1, "successes": 1},
    }
    assert eval_grippers._cell_heights({"by_height": split}) == "50 % of 2 / 100 % of 1"
    assert eval_grippers.by_height(records[-1:]) == {}
    assert eval_grippers._cell_heights({}) == "–"


def test_gripper_table_names_each_grippers_finger_drive():
    """The gripper table's drive column: the gain of each joint kind the gripper
    has, and whether its YAML or the simulator's default gave it."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        import eval_grippers
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    gains = {
        "revolute": {"kp": 1.4, "source": "gripper"},
        "prismatic": {"kp": 5000.0, "source": "params"},
    }
    hand = {"efforts": {"a": {"unit": "N·m"}, "b": {"unit": "N·m"}}, "gains": gains}
    jaw = {"efforts": {"a": {"unit": "N"}}, "gains": gains}
    assert eval_grippers._cell_drive({"sim_notes": hand}) == "1.4 N·m/rad (YAML)"
    assert eval_grippers._cell_drive({"sim_notes": jaw}) == "5000 N/m (default)"
    assert eval_grippers._cell_drive({"sim_notes": {}}) == "–"  # an older table


def test_a_gripper_row_rerun_replaces_its_row_marked_with_its_commit():
    """``eval_grippers.py --only NAME --merge``: the row run replaces the row of
    that name in the published report and the tables name the commit it ran
    at; a run under other settings is refused."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        import eval_grippers
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    settings = {"objects": "random:000-299", "trials": 1, "seed": 0}
    old = {
        **settings,
        "protocol": "strict",
        "commit": "aaaaaaa",
        "date": "2026-12-01",
        "rows": [{"name": "a", "source": "x"}, {"name": "b", "source": "y"}],
    }
    new = {**old, "commit": "bbbbbbb", "date": "2026-12-06"}
    new["rows"] = [{"name": "b", "source": "y", "trials": 3}]
    out = eval_grippers.merged(old, new)
    assert [r["name"] for r in out["rows"]] == ["a", "b"]
    assert out["commit"] == "aaaaaaa" and "rerun" not in out["rows"][0]
    assert out["rows"][1]["trials"] == 3
    assert out["rows"][1]["rerun"] == {"commit": "bbbbbbb", "date": "2026-12-06"}
    assert eval_grippers._name(out["rows"][1]) == "b (run at bbbbbbb)"
    with pytest.raises(SystemExit, match="protocol"):
        eval_grippers.merged(old, {**new, "protocol": "lift"})
    with pytest.raises(SystemExit, match="no row"):
        eval_grippers.merged(old, {**new, "rows": [{"name": "c"}]})


def test_the_gripper_table_names_where_each_gripper_comes_from():
    """A vendor description's row names its file, a built-in gripper's
    ``built-in`` and an example plugin's ``examples/plugins``."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        import eval_grippers
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    vendor = {"name": "bhand_model", "source": "barrett_hand/bhand_model.urdf"}
    vendor["gripper"] = "eval-results/packages/bhand_model/bhand_model.yaml"
    assert eval_grippers._source(vendor) == "barrett_hand/bhand_model.urdf"
    ours = {"name": "franka_hand", "source": "built-in", "gripper": "franka_hand"}
    assert eval_grippers._source(ours) == "built-in"
    example = {"name": "x", "source": "built-in", "gripper": "examples/plugins/x.yaml"}
    assert eval_grippers._source(example) == "examples/plugins"


def test_the_gripper_table_says_what_tune_changed():
    """A row tuned by ``eval_grippers.py --tune`` says which closing ``gripper
    tune`` chose; a row not tuned says only whether it scaffolded; the tables'
    headers name ``gripper tune`` only where some row was tuned."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        import eval_grippers
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    cell = eval_grippers._cell_scaffolds
    tuned = {"scaffolds": True, "tune": {"chosen": "limits"}}
    kept = {"scaffolds": True, "tune": {"chosen": "as_is"}}
    assert cell(tuned) == "yes (tune: closed at limits)"
    assert cell(kept) == "yes (tune: as scaffolded)"
    assert cell({"scaffolds": True}) == "yes"
    assert cell({"scaffolds": True, "tune_error": "x"}) == "yes (tune failed)"
    assert cell({"scaffolds": False, "scaffold_error": "bad"}) == "no: bad"
    assert cell({"scaffolds": False, "scaffold_error": "bad"}, short=True) == "no"
    report = {
        "commit": "abc",
        "machine": "m",
        "date": "d",
        "protocol": "strict",
        "objects": "random:000-299",
        "trials": 1,
        "seed": 0,
        "rows": [{"name": "h", "source": "h.urdf", **tuned}],
    }
    assert "`gripper tune`" in eval_grippers.readme_table(report)
    assert "`gripper tune`" in eval_grippers.markdown(report)
    # the objects each row was tuned on, as its tune report gives them
    tuned["tune"]["objects"] = "random:000-059"
    other = {"scaffolds": True, "tune": {"chosen": "as_is", "objects": "random:7"}}
    report["rows"] = [
        {"name": "h", "source": "h.urdf", **tuned},
        {"name": "i", "source": "i.urdf", **other},
    ]
    for text in (eval_grippers.readme_table(report), eval_grippers.markdown(report)):
        assert "on `random:000-059` or `random:7` where" in " ".join(text.split())
    report["rows"] = [{"name": "h", "source": "h.urdf", "scaffolds": True}]
    assert "`gripper tune`" not in eval_grippers.readme_table(report)
    assert "`gripper tune`" not in eval_grippers.markdown(report)


def test_the_allegro_fingertips_rise_as_the_docs_say():
    """The Allegro hand's pad centres along its approach over the closing path
    (pre-grasp to closed): the deepest point and the end that the evaluation
    guide and the defaults' rationale give, read from the model."""
    import numpy as np

    from wsgrasp.gripper import load_gripper
    from wsgrasp.planning.closing import closing_paths

    g = load_gripper("allegro_right")
    depth = closing_paths(g)[1:] @ np.asarray(g.approach_axis)  # (3 fingers, K)
    deepest, end = depth.max(axis=1), depth[:, -1]
    for value, text in (
        (deepest, "9.6 cm"),
        (end, "6.3 cm"),
        (deepest - end, "3.3 cm"),
    ):
        assert np.allclose(value * 100, float(text.split()[0]), atol=0.05), text
    guide = (DOCS / "how-to" / "evaluate-a-gripper.md").read_text()
    assert "9.6 cm" in guide and "6.3 cm" in guide and "3.3 cm" in guide
    assert "3.3 cm" in (DOCS / "explanation" / "defaults.md").read_text()
