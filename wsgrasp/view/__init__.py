"""Pictures of gripper models and of recorded runs (matplotlib PNG, and a
self-contained interactive HTML page)."""

from __future__ import annotations

from pathlib import Path

from wsgrasp.view._gripper import render_gripper

__all__ = ["render_gripper", "render_run"]


def render_run(run_path: str | Path, out: str | Path) -> Path:
    """Draw a recorded run: ``out`` ending in ``.png`` (a few viewpoints) or
    ``.html`` (interactive, works offline)."""
    from wsgrasp.record import open_run

    run = open_run(run_path)
    if str(out).lower().endswith(".html"):
        from wsgrasp.view._html import render_html

        return render_html(run, out)
    from wsgrasp.view._png import render_png

    return render_png(run, out)
