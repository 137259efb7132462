"""Mesh objects collide as their convex decomposition (coacd), cached on disk.

MuJoCo collides a mesh as its convex hull, which fills a mug's inside and a ring's
hole. A mesh object is therefore split into convex parts with coacd (Wei et al.,
SIGGRAPH 2022) before it becomes a MuJoCo body:

1. the mesh's bodies (a file may hold several, overlapping) are joined into one
   closed surface with manifold3d's boolean union;
2. a surface that fills its convex hull (volume ratio above ``1 -
   CONVEX_TOLERANCE``) is one part, without coacd;
3. otherwise coacd cuts it (``COACD``: concavity threshold 0.05, at most 32 hulls).
   Its own voxel remeshing is off, because step 1 already gave it a manifold: on
   the random objects remeshing took 6-8 times as long and swelled them by 11-13 %,
   and coacd without it on the raw, overlapping pieces ran for over 10 minutes. A
   mesh whose bodies cannot be joined is remeshed by coacd instead.

Decompositions are cached as ``.npz`` under ``$WSGRASP_CACHE_DIR/meshes`` (else
``~/.cache/wsgrasp/meshes``), keyed by the mesh's vertex and face bytes, the scale,
the coacd parameters and the coacd version. :func:`decompose_meshes` decomposes many
meshes in worker processes with a progress bar.

The decomposition's parameters and what they are for: docs/explanation/simulation.md,
"Objects: pybullet_data random objects".
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wsgrasp.errors import SimulationError
from wsgrasp.perception.io import NUMPY_READ_ERRORS
from wsgrasp.sim._pool import progress_bar, run_in_processes

__all__ = [
    "COACD",
    "CONVEX_TOLERANCE",
    "CoacdParams",
    "Decomposition",
    "MeshSource",
    "convex_decomposition",
    "decompose_meshes",
    "mesh_cache_dir",
    "require_coacd",
]

Array = NDArray[np.float64]

#: a closed surface whose volume is above (1 - this) of its hull's is convex
CONVEX_TOLERANCE = 1e-3
#: bump when the cached data or the steps before coacd change
DECOMPOSITION_FORMAT = 1


@dataclass(frozen=True)
class CoacdParams:
    """The parameters handed to ``coacd.run_coacd`` (see its documentation).

    Measured on the pybullet_data random objects (2 cores): coacd's own
    ``mcts_iterations=150, mcts_nodes=20, mcts_max_depth=3`` took 2-3 times as
    long for the same part counts and volumes. At most 16 hulls left the 5 % most
    branched objects at 1.5-4.5 times their volume (hulls up to 5 mm proud of the
    surface); 32 about halves the excess, and 95 % of the objects need under 16.
    """

    threshold: float = 0.05
    max_convex_hull: int = 32
    resolution: int = 2000
    mcts_iterations: int = 60
    mcts_nodes: int = 10
    mcts_max_depth: int = 2
    seed: int = 0


#: the decomposition every object uses
COACD = CoacdParams()


@dataclass
class Decomposition:
    """Convex parts of one mesh.

    Attributes
    ----------
    hulls : list of (n_i, 3) float
        Vertices of each convex part, in the scaled mesh's frame (metres).
    status : str
        ``hit`` (read from the cache), ``miss`` (computed by coacd, cached),
        ``off`` (computed, cache not writable) or ``convex`` (one part, no coacd).
    seconds : float
        Time spent computing (0 on a hit).
    """

    hulls: list[Array]
    status: str
    seconds: float = 0.0


@dataclass
class MeshSource:
    """A mesh to turn into an object once it is decomposed.

    Attributes
    ----------
    name : str
    mesh : trimesh.Trimesh
        As read from the file (its own units).
    scale : (3,) float
        Applied to ``mesh`` before anything else (metres after it).
    mass : float
    friction : float or None
        None: the trial protocol's.
    origin : str
        Where it came from, for messages (a file path).
    mass_given : bool
        ``mass`` is the object's own, not a placeholder (see
        :class:`~wsgrasp.sim.objects.SimObject`).
    """

    name: str
    mesh: Any
    scale: Array = field(default_factory=lambda: np.ones(3))
    mass: float = 0.2
    friction: float | None = None
    origin: str = ""
    mass_given: bool = True

    def scaled(self) -> Any:
        """A scaled copy of the mesh (metres)."""
        m = self.mesh.copy()
        m.apply_transform(np.diag([*np.broadcast_to(self.scale, (3,)), 1.0]))
        return m


def require_coacd() -> Any:
    """The ``coacd`` module, or a ``SimulationError`` saying how to install it."""
    try:
        import coacd
    except ImportError as exc:
        raise SimulationError(
            f"mesh objects collide as their convex decomposition, which needs "
            f"coacd, which is not installed ({exc})",
            hint="pip install 'wsgrasp[sim]'",
        ) from None
    return coacd


def mesh_cache_dir(cache_dir: str | Path | None = None) -> Path:
    """Where decompositions are kept: ``cache_dir``, else
    ``$WSGRASP_CACHE_DIR/meshes``, else ``~/.cache/wsgrasp/meshes``."""
    from wsgrasp.gripper._cache import CACHE_ENV

    if cache_dir is not None:
        return Path(cache_dir).expanduser()
    env = os.environ.get(CACHE_ENV)
    if env:
        return Path(env).expanduser() / "meshes"
    return Path.home() / ".cache" / "wsgrasp" / "meshes"


def _coacd_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("coacd")
    except PackageNotFoundError:
        return "unknown"


def decomposition_key(
    vertices: ArrayLike, faces: ArrayLike, scale: ArrayLike, params: CoacdParams
) -> str:
    """SHA-256 of the mesh's vertices ``(n, 3)`` and faces ``(m, 3)``, the scale
    ``(3,)``, the coacd parameters and versions."""
    h = hashlib.sha256()
    meta = {
        "format": DECOMPOSITION_FORMAT,
        "coacd": _coacd_version(),
        "params": asdict(params),
        "convex_tolerance": CONVEX_TOLERANCE,
    }
    h.update(json.dumps(meta, sort_keys=True).encode())
    for a, dtype in ((scale, np.float64), (vertices, np.float64), (faces, np.int64)):
        arr = np.ascontiguousarray(np.asarray(a, dtype=dtype))
        h.update(b"\0" + str(arr.shape).encode() + b"\0" + arr.tobytes())
    return h.hexdigest()


def _solid(mesh: Any) -> Any | None:
    """The mesh's bodies joined into one closed surface, or None if they are not
    all closed."""
    import trimesh

    bodies = mesh.split(only_watertight=False)
    if len(bodies) <= 1:
        return mesh if mesh.is_volume else None
    if not all(b.is_volume for b in bodies):
        return None
    try:
        solid = trimesh.boolean.union(bodies, engine="manifold")
    except Exception:  # noqa: BLE001 - any boolean failure: coacd remeshes
        return None
    return solid if solid.is_volume else None


def _compute(
    vertices: Array, faces: NDArray[np.int64], params: CoacdParams
) -> tuple[list[Array], bool]:
    """``(hulls, used_coacd)`` of a scaled mesh ``(n, 3)``, ``(m, 3)``."""
    import trimesh

    mesh = trimesh.Trimesh(vertices=vertices, faces=faces)
    solid = _solid(mesh)
    if solid is not None:
        hull = solid.convex_hull
        if float(solid.volume) >= (1.0 - CONVEX_TOLERANCE) * float(hull.volume):
            return [np.asarray(hull.vertices, dtype=np.float64)], False
    coacd = require_coacd()
    coacd.set_log_level("error")
    target = solid if solid is not None else mesh
    parts = coacd.run_coacd(
        coacd.Mesh(
            np.asarray(target.vertices, dtype=np.float64),
            np.asarray(target.faces, dtype=np.int32),
        ),
        preprocess_mode="off" if solid is not None else "on",
        **asdict(params),
    )
    hulls = [np.asarray(v, dtype=np.float64) for v, _ in parts]
    return [h for h in hulls if len(h) >= 4], True


def _read(path: Path, key: str) -> list[Array] | None:
    try:
        with np.load(path, allow_pickle=False) as data:
            if str(data["key"]) != key:
                return None
            vertices = np.asarray(data["vertices"], dtype=np.float64)  # (n, 3)
            counts = np.asarray(data["counts"], dtype=np.int64)  # (k,)
    except (KeyError, *NUMPY_READ_ERRORS):
        return None  # missing, corrupt or old: decompose again
    return list(np.split(vertices, np.cumsum(counts)[:-1]))


def _write(path: Path, key: str, hulls: list[Array]) -> bool:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=path.stem, suffix=".tmp", dir=path.parent)
        with os.fdopen(fd, "wb") as fh:
            np.savez(
                fh,
                key=np.asarray(key),
                vertices=np.concatenate(hulls),  # (sum n_i, 3)
                counts=np.asarray([len(h) for h in hulls], dtype=np.int64),
            )
        os.replace(tmp, path)
    except OSError:
        return False
    return True


def convex_decomposition(
    mesh: Any,
    scale: ArrayLike = 1.0,
    *,
    params: CoacdParams = COACD,
    cache_dir: str | Path | None = None,
) -> Decomposition:
    """The convex parts of ``mesh`` scaled by ``scale``, from the cache if there.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        In its file's units; ``scale`` (a number or ``(3,)``) makes it metres.
    params
        coacd's parameters (part of the cache key).
    cache_dir
        See :func:`mesh_cache_dir`.

    Returns
    -------
    Decomposition
        Hull vertices in the scaled mesh's frame.

    Raises
    ------
    SimulationError
        coacd is not installed (and the mesh is not convex).
    """
    s = np.broadcast_to(np.asarray(scale, dtype=np.float64), (3,))
    v = np.asarray(mesh.vertices, dtype=np.float64)  # (n, 3)
    f = np.asarray(mesh.faces, dtype=np.int64)  # (m, 3)
    return _decompose_arrays(v, f, s, params, str(mesh_cache_dir(cache_dir)))


def _decompose_arrays(
    vertices: Array,
    faces: NDArray[np.int64],
    scale: Array,
    params: CoacdParams,
    cache: str,
) -> Decomposition:
    key = decomposition_key(vertices, faces, scale, params)
    path = Path(cache) / f"{key[:32]}.npz"
    hulls = _read(path, key)
    if hulls is not None:
        return Decomposition(hulls, "hit")
    t0 = time.perf_counter()
    hulls, used_coacd = _compute(vertices * scale, faces, params)
    seconds = time.perf_counter() - t0
    written = _write(path, key, hulls)  # convex ones too: no pool for them next time
    status = ("miss" if written else "off") if used_coacd else "convex"
    return Decomposition(hulls, status, seconds)


def _cached_only(
    vertices: Array,
    faces: NDArray[np.int64],
    scale: Array,
    params: CoacdParams,
    cache: str,
) -> Decomposition | None:
    key = decomposition_key(vertices, faces, scale, params)
    hulls = _read(Path(cache) / f"{key[:32]}.npz", key)
    return None if hulls is None else Decomposition(hulls, "hit")


def decompose_meshes(
    sources: Sequence[MeshSource],
    *,
    workers: int = 0,
    progress: bool = False,
    params: CoacdParams = COACD,
    cache_dir: str | Path | None = None,
) -> list[Decomposition]:
    """:func:`convex_decomposition` of each source, cache misses in ``workers``
    processes (0: one per CPU core) with a rich progress bar on stderr."""
    cache = str(mesh_cache_dir(cache_dir))
    jobs = []
    for src in sources:
        v = np.asarray(src.mesh.vertices, dtype=np.float64)  # (n, 3)
        f = np.asarray(src.mesh.faces, dtype=np.int64)  # (m, 3)
        s = np.broadcast_to(np.asarray(src.scale, dtype=np.float64), (3,)).copy()
        jobs.append((v, f, s, params, cache))
    out: list[Decomposition | None] = [_cached_only(*job) for job in jobs]
    todo = [i for i, d in enumerate(out) if d is None]
    if not todo:
        return [d for d in out if d is not None]
    n = max(1, min(workers or (os.cpu_count() or 1), len(todo)))

    def done(i: int, d: Decomposition) -> None:
        out[i] = d
        advance(sources[i].name)

    with progress_bar(progress, "convex decomposition (coacd)", len(todo)) as advance:
        if n == 1:
            for i in todo:
                done(i, _decompose_arrays(*jobs[i]))
        else:
            # largest meshes first, so that the last worker does not finish alone
            order = sorted(todo, key=lambda i: -len(jobs[i][1]))
            run_in_processes(_decompose_arrays, jobs, n, done, order=order)
    return [d for d in out if d is not None]
