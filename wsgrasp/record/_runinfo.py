"""What a run file says about the run besides its stages: the versions, the spec,
the plugins and the gripper's files.

:func:`run_info` is the ``/wsgrasp/run`` record, in a chunk (so the chunk's CRC
covers it); the recorder also writes each of its parts as MCAP metadata of the
same name, for tools that show metadata (Foxglove, ``mcap info``), and the reader
reports a metadata record that differs from the record as corruption.
"""

from __future__ import annotations

import json
import platform
import sys
from dataclasses import fields
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import xxhash

from wsgrasp._names import gripper_ref, is_gripper_path
from wsgrasp.record._codec import FORMAT_VERSION

if TYPE_CHECKING:
    from wsgrasp.gripper.model import GripperModel
    from wsgrasp.spec import PipelineSpec

__all__ = ["gripper_attachments", "model_key", "run_info"]


def run_info(spec: PipelineSpec, gripper: GripperModel) -> dict[str, dict[str, str]]:
    """The parts ``wsgrasp`` (format and package versions, platform, seed,
    gripper), ``spec`` (the resolved spec as JSON) and ``plugins`` (every plugin's
    distribution and version), each a dict of str to str."""
    from wsgrasp._version import __version__

    meta = {
        "format_version": str(FORMAT_VERSION),
        "wsgrasp_version": __version__,
        "created_utc": datetime.now(timezone.utc).isoformat(),
        "gripper": gripper.name,
        "gripper_hash": gripper.source_hash,
        "seed": str(spec.seed),
        "python": platform.python_version(),
        "platform": platform.platform(),
        "numpy": np.__version__,
        "command": " ".join(sys.argv)[:2000],
    }
    return {
        "wsgrasp": meta,
        "spec": {
            "json": spec.model_dump_json(),  # pydantic's own encoder: 4x faster
            "source": "" if spec.source is None else str(spec.source),
        },
        "plugins": _plugins(),
    }


def _plugins() -> dict[str, str]:
    try:
        from wsgrasp.plugins import get_registry

        summary = get_registry().plugin_summary()
    except Exception as exc:  # noqa: BLE001 - recorded, not fatal
        return {"error": repr(exc)}
    return {
        f"{p['distribution']}:{p['name']}": json.dumps(p, sort_keys=True)
        for p in summary
    }


def model_key(gripper: GripperModel) -> tuple[Any, ...]:
    """A fingerprint of the model's exact content: every array's XXH3 (tens of
    microseconds for a model) and every other field's JSON."""
    key: list[Any] = [type(gripper).__qualname__]
    for f in fields(gripper):
        v = getattr(gripper, f.name)
        if isinstance(v, np.ndarray):
            a = np.ascontiguousarray(v)
            key.append((f.name, a.dtype.str, a.shape, xxhash.xxh3_64_intdigest(a.data)))
        else:
            key.append((f.name, json.dumps(v, sort_keys=True, default=_plain)))
    return tuple(key)


def _plain(v: Any) -> Any:
    return v.tolist() if isinstance(v, np.ndarray) else repr(v)


#: the attachments by model fingerprint and the gripper files' paths and stats
_ATTACHMENTS: dict[tuple[Any, ...], list[tuple[str, str, bytes]]] = {}


def _file_stat(path: Path | None) -> tuple[str, int, int] | None:
    try:
        st = path.stat() if path is not None else None
    except OSError:
        return None
    return None if st is None else (str(path), st.st_mtime_ns, st.st_size)


def gripper_attachments(
    spec: PipelineSpec, gripper: GripperModel
) -> list[tuple[str, str, bytes]]:
    """``(name, media type, data)`` of a run's gripper: the model
    (``gripper/model.npz``, exact arrays), its description and, when found, its
    YAML and URDF; built once per model and files (their size and modification
    time: a compressed npz takes milliseconds)."""
    yaml_path = _gripper_yaml(spec)
    urdf = gripper.description.get("urdf")
    urdf_path = (yaml_path.parent / urdf).resolve() if yaml_path and urdf else None
    key = (model_key(gripper), _file_stat(yaml_path), _file_stat(urdf_path))
    out = _ATTACHMENTS.get(key)
    if out is None:
        description = json.dumps(gripper.description, sort_keys=True, default=str)
        out = [
            ("gripper/model.npz", "application/x-npz", gripper.to_bytes()),
            ("gripper/description.json", "application/json", description.encode()),
        ]
        files = [(yaml_path, "application/yaml"), (urdf_path, "application/xml")]
        for path, media in files:
            try:
                if path is not None and path.is_file():
                    out.append((f"gripper/{path.name}", media, path.read_bytes()))
            except OSError:
                break
        if len(_ATTACHMENTS) >= 8:
            _ATTACHMENTS.clear()
        _ATTACHMENTS[key] = out
    return out


def _gripper_yaml(spec: PipelineSpec) -> Path | None:
    """The gripper YAML the spec names, when there is one on disk."""
    base = Path.cwd() if spec.source is None else Path(spec.source).parent
    ref: Any = gripper_ref(spec.gripper, base)  # as the Pipeline read it
    if not is_gripper_path(ref):
        try:
            from wsgrasp.plugins import get_registry

            ref = get_registry().get("grippers", ref).obj
        except Exception:  # noqa: BLE001 - an attachment is a convenience
            return None
    return Path(ref) if isinstance(ref, (str, Path)) and Path(ref).is_file() else None
