"""Pictures of recorded runs: PNG, and a self-contained HTML page checked in a real
headless Chromium (Playwright driving the system's browser) for what a person
sees: the sidebar's width and labels, the plot filling the rest, legend toggles
and stepping through the alternatives, from 1024 to 1920 px wide."""

from __future__ import annotations

import re
import shutil
from pathlib import Path
from typing import Any

import pytest
from test_record_fakes import plan_recorded
from typer.testing import CliRunner

from wsgrasp.cli import app, main
from wsgrasp.record import open_run
from wsgrasp.view._html import SIDEBAR_PX, page_figure

CHROMIUM = next(
    (
        shutil.which(n)
        for n in ("chromium", "chromium-browser", "google-chrome")
        if shutil.which(n)
    ),
    None,
)


@pytest.fixture(scope="module")
def run_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("view") / "run.mcap"
    plan_recorded(path)
    return path


def test_view_png(run_path: Path, tmp_path: Path) -> None:
    out = tmp_path / "run.png"
    res = CliRunner().invoke(app, ["view", str(run_path), "-o", str(out)])
    assert res.exit_code == 0, res.stdout
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert out.stat().st_size > 20_000
    again = CliRunner().invoke(app, ["view", str(run_path), "-o", str(out)])
    assert again.exit_code != 0, "an existing picture is not replaced without --force"


def test_view_html_is_self_contained(run_path: Path, tmp_path: Path) -> None:
    out = tmp_path / "run.html"
    res = CliRunner().invoke(app, ["view", str(run_path), "-o", str(out)])
    assert res.exit_code == 0, res.stdout
    text = out.read_text()
    remote = r"""<(script|link|img|iframe)\b[^>]*(src|href)=["']?(https?:)?//"""
    assert not re.search(remote, text), "no element loads a remote asset"
    assert "Plotly.newPlot" in text, "plotly.js is inlined"
    fig, side = page_figure(open_run(run_path))
    names = [t.name for t in fig.data]
    assert "object" in names and "table" in names
    assert any(n.startswith("candidate: feasible") for n in names)
    assert "gripper at grasp (closed)" in names
    assert "gripper at pre-grasp (open)" in names
    assert side["alternatives"][0]["label"] == "the chosen grasp"


def test_every_layer_has_its_own_colour(run_path: Path) -> None:
    fig, _ = page_figure(open_run(run_path))
    colours: dict[str, str] = {}
    for t in fig.data:
        if t.legendgroup == "alternative" or t.showlegend is False:
            continue
        if t.name.endswith(" frame"):  # x red, y green, z blue, each named
            continue
        c = t.color if t.type == "mesh3d" else (t.marker.color or t.line.color)
        colours.setdefault(str(c), t.name)
        assert colours[str(c)] == t.name, f"{t.name} and {colours[str(c)]}: {c}"


def test_view_of_a_truncated_run(run_path: Path, tmp_path: Path) -> None:
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(run_path.read_bytes()[: run_path.stat().st_size // 2])
    out = tmp_path / "cut.png"
    res = CliRunner().invoke(app, ["view", str(cut), "-o", str(out)])
    assert res.exit_code == 0 and "truncated" in res.stdout


def check_page(page: Path, width: int, height: int) -> list[str]:
    """Open ``page`` in headless Chromium at ``width`` x ``height`` and return
    what a person would find wrong with it (empty: nothing)."""
    from playwright.sync_api import sync_playwright

    problems: list[str] = []
    with sync_playwright() as p:
        browser = p.chromium.launch(
            executable_path=CHROMIUM,
            args=[
                "--no-sandbox",
                "--use-gl=swiftshader",
                "--enable-unsafe-swiftshader",
            ],
        )
        tab = browser.new_page(viewport={"width": width, "height": height})
        remote: list[str] = []
        tab.on(
            "request",
            lambda r: (
                remote.append(r.url)
                if "://" in r.url and not r.url.startswith(("file:", "data:", "blob:"))
                else None
            ),
        )
        tab.goto(page.as_uri())
        tab.wait_for_load_state("load")
        box: dict[str, Any] = tab.evaluate(LAYOUT_JS)
        if box["side"] < 240:
            problems.append(f"sidebar {box['side']:.0f} px wide at {width} px")
        if box["scroll"] > width:
            problems.append(f"a horizontal scrollbar: {box['scroll']} px > {width}")
        for text, w, clipped in box["labels"]:
            if w <= 0 or clipped:
                problems.append(f"sidebar label {text[:30]!r} not readable")
        if box["plot"] < 0.95 * (width - box["side"]) or box["plotH"] < 0.95 * height:
            problems.append(
                f"the plot is {box['plot']:.0f} x {box['plotH']:.0f} px of "
                f"{width - box['side']:.0f} x {height} px left for it"
            )
        if problems:
            browser.close()
            return problems
        if remote:
            problems.append(f"the page fetched {remote[:3]} (it must work offline)")
        tab.wait_for_function("window.wsgraspReady === true", timeout=30_000)
        # a legend click hides the object and a second shows it again
        index = tab.evaluate(
            "document.getElementById('plot').data.findIndex(t => t.name === 'object')"
        )
        visible = f"document.getElementById('plot').data[{index}].visible"
        name = tab.locator(".legendtext", has_text=re.compile(r"^object$"))
        item = tab.locator("g.traces").filter(has=name).locator(".legendtoggle")
        item.click()
        tab.wait_for_timeout(700)  # plotly waits to tell a click from a double
        if tab.evaluate(visible) != "legendonly":
            problems.append("clicking 'object' in the legend does not hide it")
        item.click()
        tab.wait_for_timeout(700)
        if tab.evaluate(visible) not in (True, None):
            problems.append("a second click on 'object' does not show it again")
        # stepping: the next alternative is drawn and named, the first again last
        label = tab.locator("#alt-label")
        first = label.inner_text()
        tab.click("#next")
        second = label.inner_text()
        if not second.startswith("2 of ") or second == first:
            problems.append(f"stepping does not move on: {first!r} -> {second!r}")
        shown = tab.evaluate(
            "document.getElementById('plot').data.filter(t => "
            "t.legendgroup === 'alternative' && t.visible === true).length"
        )
        if shown != 1:
            problems.append(f"{shown} alternatives drawn after a step, not 1")
        tab.click("#prev")
        if label.inner_text() != first:
            problems.append("stepping back does not return to the chosen grasp")
        browser.close()
    return problems


#: the sidebar's and the plot's boxes, the page's scroll width, and every text
#: of the sidebar with its width and whether it is cut (wider than its box)
LAYOUT_JS = """() => {
  const r = id => document.getElementById(id).getBoundingClientRect();
  const side = document.getElementById("side");
  const labels = [...side.querySelectorAll("h1, h2, p, button")]
    .filter(e => e.offsetParent !== null && e.textContent.trim())
    .map(e => [e.textContent.trim(), e.getBoundingClientRect().width,
               e.scrollWidth > e.clientWidth + 1]);
  const plot = document.getElementById("plot") || document.querySelector("canvas");
  const p = plot.getBoundingClientRect();
  return {side: r("side").width, plot: p.width, plotH: p.height,
          scroll: document.documentElement.scrollWidth, labels};
}"""


@pytest.mark.skipif(
    CHROMIUM is None,
    reason="no headless Chromium (install it with `apt-get install -y chromium`)",
)
@pytest.mark.parametrize(
    "width,height", [(1024, 768), (1200, 900), (1920, 1080)], ids=str
)
def test_html_page_in_headless_chromium(
    run_path: Path, tmp_path_factory: pytest.TempPathFactory, width: int, height: int
) -> None:
    pytest.importorskip("playwright", reason="pip install playwright (in .[dev])")
    out = tmp_path_factory.mktemp("page") / "run.html"
    assert main(["view", str(run_path), "-o", str(out)]) == 0
    problems = check_page(out, width, height)
    assert not problems, problems
    assert SIDEBAR_PX >= 240


#: the canvas page's layout before plotly (a flex row, a 270 px sidebar of
#: unbreakable labels, a canvas with ``flex: 1`` and its default minimum width)
OLD_LAYOUT = """<!DOCTYPE html><html><head><style>
 body{margin:0;font:13px system-ui,sans-serif} #wrap{display:flex;height:100vh}
 #side{width:270px;padding:10px;overflow:auto;border-right:1px solid #ddd}
 canvas{flex:1;display:block} label{display:block;white-space:nowrap}
 h1{font-size:14px}</style></head><body><div id="wrap"><div id="side">
 <h1>run.mcap: grasp found</h1><label>candidates: table collision (196)</label>
 <p>drag: rotate · shift-drag: pan · wheel: zoom</p></div>
 <canvas id="c" width="1600" height="1000"></canvas></div></body></html>"""


@pytest.mark.skipif(CHROMIUM is None, reason="no headless Chromium")
def test_the_browser_check_catches_a_collapsing_sidebar(tmp_path: Path) -> None:
    pytest.importorskip("playwright", reason="pip install playwright (in .[dev])")
    page = tmp_path / "old.html"
    page.write_text(OLD_LAYOUT)
    problems = check_page(page, 1200, 900)
    assert any(p.startswith("sidebar ") and "px wide" in p for p in problems)


def test_a_gripper_given_by_its_yaml_is_drawn_from_its_urdf(tmp_path: Path) -> None:
    """A gripper the spec names by its YAML (no plugin registers it) is drawn
    from the URDF beside that YAML, not as its body superellipsoids."""
    import wsgrasp
    from wsgrasp.perception.synth import synth_scene
    from wsgrasp.record import RunRecorder
    from wsgrasp.spec import load_spec
    from wsgrasp.view._run import run_layers

    root = Path(__file__).resolve().parents[1]
    yaml = next(root.glob("examples/plugins/robotiq_2f85_like/wsgrasp_*/*.yaml"))
    spec = load_spec(
        {"gripper": str(yaml), "sampling": {"mode": "approach_sphere", "depths": 2}}
    )
    path = tmp_path / "run.mcap"
    scene = synth_scene("box", size=(0.05, 0.05, 0.08), seed=0, width=160, height=120)
    result = wsgrasp.Pipeline(spec).plan(scene.points, observers=[RunRecorder(path)])
    assert result.found, result.hint
    layers = run_layers(open_run(path))
    assert not any("URDF not found" in n for n in layers.notes), layers.notes
