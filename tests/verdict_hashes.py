"""Hashes of what the search decides on the bundled scenes: every candidate's
verdict, contacts and score, and the plan's choice (its index, pose and contacts),
for each gripper's default spec and the bench's dense sampling.

``tests/test_verdict_hashes.py`` holds the search to the hashes stored in
``tests/data/verdict_hashes.json``; after a change that is meant to change a
verdict, write them again::

    .venv/bin/python tests/verdict_hashes.py --write

The last bits of a plan depend on the numerical libraries and on the processor:
the same code gave other hashes for every case after a fresh install took newer
releases from the package index, and OpenBLAS's kernels for another processor
change the scores' last bits. So the hashes are stored per environment
(:func:`environment`: the processor's vector extensions and the versions of the
libraries a plan runs through), and the test compares with the set stored for
the environment it runs in, skipping where none is. To hold a change to them in
a new environment, store the set from the unchanged code first (``--write`` on
a checkout of the commit before the change), then run the test on the change.
"""

from __future__ import annotations

import argparse
import functools
import hashlib
import json
import sys
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
STORED = ROOT / "tests" / "data" / "verdict_hashes.json"
SCENES = ROOT / "examples" / "scenes"
BARRETT = (
    ROOT
    / "examples/plugins/barrett_bh8_like/wsgrasp_barrett_bh8_like/barrett_bh8_like.yaml"
)
ROBOTIQ = (
    ROOT / "examples/plugins/robotiq_2f85_like/wsgrasp_robotiq_2f85_like/"
    "robotiq_2f85_like.yaml"
)
#: a synthetic five-finger hand (``hand_factory``) of which a grasp needs three
#: fingers (``contact_fingers``): the paths of hands with more than four fingers
#: and of fingers that may hold nothing, which no bundled gripper takes
HAND5 = "hand5_three_holding"
GRIPPERS = {
    "franka_hand": "franka_hand",
    "allegro_right": "allegro_right",
    "barrett_bh8_like": str(BARRETT),
    "robotiq_2f85_like": str(ROBOTIQ),
    HAND5: "",  # written by _gripper_ref
}
SCENE_FILES = {
    "bottle_lying": SCENES / "bottle_lying.npz",
    "box_camera_frame": SCENES / "box_camera_frame.npz",
    "box_upright": SCENES / "box_upright.npz",
    "mug": SCENES / "mug.npz",
    "cone_views": SCENES / "cone_views" / "scene.yaml",
}
#: the dense cases: ``wsgrasp bench``'s sampling on its scene
DENSE = {
    "franka_hand_dense": ("franka_hand", "box_upright"),
    "allegro_right_dense": ("allegro_right", "box_upright"),
}


#: the distributions a plan's arithmetic runs through
LIBRARIES = ("numpy", "scipy", "open3d-cpu", "open3d", "numba", "trimesh", "yourdfpy")


def environment() -> str:
    """What the stored hashes depend on besides the code: the machine, its widest
    vector extension numpy dispatches to (``wsgrasp._version.cpu``: OpenBLAS
    picks its kernels by the same), and the versions of :data:`LIBRARIES`
    installed."""
    from wsgrasp._version import cpu

    libs = []
    for name in LIBRARIES:
        try:
            libs.append(f"{name} {version(name)}")
        except PackageNotFoundError:
            continue
    return ", ".join([cpu(), *libs])


def _digest(*arrays: Any) -> str:
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(np.asarray(a))
        h.update(str((a.dtype.str, a.shape)).encode())
        h.update(a.tobytes())
    return h.hexdigest()[:16]


def _gripper_ref(name: str) -> str:
    """What a spec names the gripper ``name`` by: :data:`HAND5`'s YAML is
    written once per process into a temporary folder, removed at exit."""
    if name != HAND5:
        return GRIPPERS[name]
    return _hand5_yaml()


@functools.cache
def _hand5_yaml() -> str:
    import tempfile

    from hand_factory import write_hand

    folder = tempfile.TemporaryDirectory(prefix="wsgrasp-hand5-")
    _KEEP.append(folder)  # removed when the interpreter exits
    path = write_hand(Path(folder.name), 5, HAND5)
    path.write_text(path.read_text() + "contact_fingers: [f0, f1, f2]\n")
    return str(path)


_KEEP: list[Any] = []


def _pipeline(gripper: str, sampling: dict[str, Any] | None = None) -> Any:
    from wsgrasp.api import Pipeline
    from wsgrasp.default_specs import default_spec
    from wsgrasp.spec import PipelineSpec

    data, _ = default_spec(gripper)
    spec = PipelineSpec.model_validate(data)
    if sampling is not None:
        spec.sampling = spec.sampling.model_validate(
            {**spec.sampling.model_dump(), **sampling}
        )
    return Pipeline(spec)


def result_hashes(result: Any) -> dict[str, str]:
    """Per part of a plan's result, a short hash: the candidates' verdicts,
    contacts and scores, and the choice."""
    c = result.candidates
    terms = [c.terms[k] for k in sorted(c.terms)]
    contacts = [(np.asarray(x.points), np.asarray(x.spheres)) for x in result.contacts]
    return {
        "reason": _digest(c.reason),
        "contacts": _digest(c.contacts),
        "score": _digest(c.score, *terms),
        "choice": _digest(
            np.asarray(-1 if result.best_index is None else result.best_index),
            np.zeros(0) if result.T_world_ee is None else result.T_world_ee,
            *(a for pair in contacts for a in pair),
        ),
    }


def case_names() -> list[str]:
    return [f"{g}/{s}" for g in GRIPPERS for s in SCENE_FILES] + list(DENSE)


def compute(names: list[str] | None = None) -> dict[str, dict[str, str]]:
    """The hashes of the cases ``names`` (all by default)."""
    from wsgrasp.api import as_scene
    from wsgrasp.bench import DENSE as DENSE_SAMPLING

    out: dict[str, dict[str, str]] = {}
    pipes: dict[str, Any] = {}
    for name in names or case_names():
        if name in DENSE:
            gripper, scene_name = DENSE[name]
            pipe = _pipeline(gripper, DENSE_SAMPLING[gripper])
        else:
            gripper, scene_name = name.split("/")
            if gripper not in pipes:
                pipes[gripper] = _pipeline(_gripper_ref(gripper))
            pipe = pipes[gripper]
        scene = as_scene(SCENE_FILES[scene_name])
        out[name] = result_hashes(pipe.plan(scene))
    return out


def _sets() -> list[dict[str, Any]]:
    if not STORED.exists():
        return []
    return json.loads(STORED.read_text())["sets"]  # type: ignore[no-any-return]


def stored(env: str | None = None) -> dict[str, dict[str, str]] | None:
    """The hashes stored for environment ``env`` (this one by default), or None."""
    env = env or environment()
    for entry in _sets():
        if entry["environment"] == env:
            return entry["cases"]  # type: ignore[no-any-return]
    return None


def missing_reason() -> str:
    """Why the test skips where no hashes are stored for this environment."""
    others = "; ".join(e["environment"] for e in _sets()) or "none"
    return (
        f"no verdict hashes stored for this environment ({environment()}); stored "
        f"for: {others}. Store them from the code before a change with "
        "`python tests/verdict_hashes.py --write`, then run the test on the change"
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="store the hashes")
    ap.add_argument("cases", nargs="*", help="case names (default: all)")
    args = ap.parse_args(argv)
    if not args.write:
        want = stored()
        if want is None:
            print(missing_reason())
            return 2
        # the cases stored for this environment (a set stored before a case was
        # added lacks it)
        got = compute(args.cases or [n for n in case_names() if n in want])
        bad = [n for n in got if got[n] != want.get(n)]
        for n in bad:
            print(f"{n}: {got[n]} != {want.get(n)}")
        print(f"{len(got) - len(bad)} of {len(got)} cases as stored")
        return 1 if bad else 0
    got = compute(args.cases or None)
    import subprocess

    commit = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"],
        cwd=ROOT,
        capture_output=True,
        text=True,
    ).stdout.strip()
    env = environment()
    sets = [e for e in _sets() if e["environment"] != env]
    cases = {**(stored(env) or {}), **got}  # a subset updates those cases
    sets.append({"environment": env, "commit": commit, "cases": cases})
    STORED.parent.mkdir(parents=True, exist_ok=True)
    data = {"sets": sorted(sets, key=lambda e: e["environment"])}
    STORED.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
    print(f"wrote {len(got)} cases for {env} to {STORED}")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    raise SystemExit(main())
