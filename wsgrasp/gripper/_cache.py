"""Resolve a gripper by name or path, and cache built models on disk."""

from __future__ import annotations

import hashlib
import json
import os
import re
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from wsgrasp._names import is_gripper_path
from wsgrasp._version import __version__
from wsgrasp.errors import GripperError
from wsgrasp.gripper._build import BUILDER_VERSION, Progress, build_model, urdf_path
from wsgrasp.gripper._urdf import resolve_mesh
from wsgrasp.gripper.model import MODEL_FORMAT_VERSION, GripperModel
from wsgrasp.spec import GripperDescription, load_gripper_description

CACHE_ENV = "WSGRASP_CACHE_DIR"
_MESH_RE = re.compile(rb"""filename\s*=\s*["']([^"']+)["']""")


def default_cache_dir(cache_dir: str | Path | None = None) -> Path:
    """The model cache: ``cache_dir``, else ``$WSGRASP_CACHE_DIR``, else
    ``~/.cache/wsgrasp/grippers``."""
    if cache_dir is not None:
        return Path(cache_dir).expanduser()
    env = os.environ.get(CACHE_ENV)
    if env:
        return Path(env).expanduser()
    return Path.home() / ".cache" / "wsgrasp" / "grippers"


def source_hash(desc: GripperDescription, base_dir: Path) -> str:
    """SHA-256 of the description, the URDF text, the bytes of every mesh it
    references, and the wsgrasp, model-format and builder versions."""
    h = hashlib.sha256()
    versions = f"{__version__}/{MODEL_FORMAT_VERSION}/{BUILDER_VERSION}"
    h.update(versions.encode())
    # the drive is the simulator's, not the model's: changing it rebuilds nothing
    model = desc.model_dump(mode="json", exclude={"drive"})
    h.update(json.dumps(model, sort_keys=True).encode())
    path = urdf_path(desc, base_dir)
    try:
        text = path.read_bytes()
    except OSError:
        text = b""  # the build reports the missing file
    h.update(b"\0urdf\0" + text)
    for name in sorted(set(_MESH_RE.findall(text))):
        mesh = resolve_mesh(name.decode(errors="replace"), path.parent)
        if mesh is not None:
            h.update(b"\0mesh\0" + name + b"\0" + mesh.read_bytes())
    return h.hexdigest()


#: What a gripper name is looked up in when no ``registry`` is given: the process's
#: plugin registry, which the root package sets here as it loads (this layer
#: imports neither ``wsgrasp.plugins`` nor the root package).
default_registry: Callable[[], Any] | None = None


def resolve_gripper(
    name_or_path: str | Path, registry: Any | None = None
) -> tuple[GripperDescription, Path] | GripperModel:
    """A registered name or a YAML path, as a description and its directory, or a
    ready model when a plugin registered one."""
    if is_gripper_path(name_or_path):
        return load_gripper_description(name_or_path)
    reg = registry
    if reg is None and default_registry is not None:
        reg = default_registry()
    if reg is None:
        raise GripperError(
            f"gripper {name_or_path!r}: a name needs a plugin registry to look it up",
            hint="pass registry=wsgrasp.plugins.get_registry(), or a YAML path",
        )
    entry = reg.get("grippers", str(name_or_path))
    obj = entry.obj
    if isinstance(obj, GripperModel):
        return obj
    if isinstance(obj, GripperDescription):
        return obj, Path.cwd()
    if isinstance(obj, str | Path):
        return load_gripper_description(obj)
    raise GripperError(
        f"gripper {name_or_path!r} registered by plugin {entry.plugin.name!r} "
        f"({entry.plugin.distribution}) is a {type(obj).__name__}",
        hint="register a path to a gripper YAML, a GripperDescription or a "
        "GripperModel",
    )


def load_gripper(
    name_or_path: str | Path,
    *,
    registry: Any | None = None,
    cache_dir: str | Path | None = None,
    rebuild: bool = False,
    progress: Progress | None = None,
) -> GripperModel:
    """Load a gripper model, building it on a cache miss.

    Parameters
    ----------
    name_or_path
        A registered gripper name, or a path to a gripper YAML.
    registry
        Plugin registry for names; the process-wide one by default.
    cache_dir
        Where built models are kept (``.npz``); see :func:`default_cache_dir`.
    rebuild
        Build even if a cached model exists (and replace it).
    progress
        Called with a short label at each build stage.

    Returns
    -------
    GripperModel
        ``stats["cache"]`` is ``"hit"`` (with ``stats["load_s"]``), ``"miss"`` or
        ``"off"`` (cache not writable); ``stats["build_s"]`` is the build time,
        ``stats["load_s"]`` the whole call on a hit (resolve, hash, read).
    """
    t0 = time.perf_counter()
    resolved = resolve_gripper(name_or_path, registry)
    if isinstance(resolved, GripperModel):
        return resolved
    desc, base_dir = resolved
    key = source_hash(desc, base_dir)
    directory = default_cache_dir(cache_dir)
    path = directory / f"{desc.name}-{key[:24]}.npz"
    if not rebuild and path.is_file():
        try:
            model = GripperModel.load(path)
        except GripperError:
            model = None  # corrupt or old entry: rebuild below
        if model is not None and model.source_hash == key:
            model.stats["cache"] = "hit"
            model.stats["load_s"] = round(time.perf_counter() - t0, 4)
            model.stats["cache_path"] = str(path)
            return model
    model = build_model(desc, base_dir, progress=progress)
    model.source_hash = key
    status = "miss"
    try:
        directory.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=path.stem, suffix=".tmp", dir=directory)
        with os.fdopen(fd, "wb") as fh:
            fh.write(model.to_bytes())
        os.replace(tmp, path)
    except OSError:
        status = "off"
    model.stats["cache"] = status
    model.stats["cache_path"] = str(path)
    return model
