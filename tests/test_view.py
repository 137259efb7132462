"""Pictures of recorded runs: PNG, and a self-contained HTML page checked in a real
headless browser."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest
from test_record_fakes import plan_recorded
from typer.testing import CliRunner

from wsgrasp.cli import app
from wsgrasp.record import open_run
from wsgrasp.view._html import page_data

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
    assert not re.search(r"""(src|href)=["']?(https?:)?//""", text), "no remote assets"
    data = page_data(open_run(run_path))
    names = [layer["name"] for layer in data["layers"]]
    assert "object" in names and any(
        n.startswith("candidates: feasible") for n in names
    )
    assert data["spheres"][0]["name"] == "spheres holding the object"


def test_view_of_a_truncated_run(run_path: Path, tmp_path: Path) -> None:
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(run_path.read_bytes()[: run_path.stat().st_size // 2])
    out = tmp_path / "cut.png"
    res = CliRunner().invoke(app, ["view", str(cut), "-o", str(out)])
    assert res.exit_code == 0 and "truncated" in res.stdout


@pytest.mark.skipif(
    CHROMIUM is None,
    reason="no headless Chromium (install it with `apt-get install -y chromium`)",
)
def test_html_page_renders_in_headless_chromium(run_path: Path, tmp_path: Path) -> None:
    out = tmp_path / "run.html"
    CliRunner().invoke(app, ["view", str(run_path), "-o", str(out)])
    proc = subprocess.run(
        [
            str(CHROMIUM),
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--virtual-time-budget=5000",
            "--dump-dom",
            out.as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    m = re.search(r'<div id="status" data-ready="1" data-drawn="(\d+)"', proc.stdout)
    assert m, f"the page did not draw: {proc.stdout[-500:]} {proc.stderr[-500:]}"
    assert int(m.group(1)) > 1000
