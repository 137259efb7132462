"""``wsgrasp eval`` of one gripper with several specs side by side, the same drops
for each: what ``upright_boxes.py`` and ``noisy_depth.py`` run."""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import yaml


def run_paired(
    gripper: str,
    specs: dict[str, dict[str, Any]],
    eval_args: list[str],
    out: Path,
    workers: int = 0,
) -> int:
    """Evaluate ``gripper`` with each of ``specs`` (label -> spec data), passing
    ``eval_args`` on (objects, trials, ...); the report goes to ``out``. Returns
    ``wsgrasp eval``'s exit status."""
    with tempfile.TemporaryDirectory() as tmp:
        files = []
        for label, data in specs.items():
            path = Path(tmp) / f"{label}.yaml"
            path.write_text(yaml.safe_dump(data))
            files += ["-s", f"{label}={path}"]
        out.parent.mkdir(parents=True, exist_ok=True)
        wsgrasp = str(Path(sys.executable).with_name("wsgrasp"))
        cmd = [wsgrasp, "eval", "-g", gripper, "--no-paper", *files, *eval_args]
        cmd += ["--seed", "0", "-j", str(workers), "--json-out", str(out)]
        return subprocess.run(cmd).returncode
