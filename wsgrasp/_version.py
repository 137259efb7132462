"""The package version (read by every layer without importing the root package),
and the versions of the libraries that decide what a run measures."""

from __future__ import annotations

import platform
from importlib import metadata

__version__ = "0.1.0"

#: the installed distributions whose versions change measured figures: the
#: simulator and what builds its objects (contacts, convex pieces, meshes), the
#: random object set, and what perception and the search compute with. Between
#: two MuJoCo releases (3.17.0 and 4.0.1) 26 of 297 single-object trials of one
#: five-finger hand changed outcome (`random:000-299`, lift protocol)
LIBRARIES = (
    "mujoco",
    "coacd",
    "manifold3d",
    "trimesh",
    "pybullet",
    "numpy",
    "scipy",
    ("open3d", "open3d-cpu"),
    "numba",
)


def cpu() -> str:
    """The machine and the widest vector extension numpy dispatches to (e.g.
    ``x86_64 AVX512F``): OpenBLAS and the compiled libraries pick their kernels
    by it, and the last bits of a plan's arithmetic with them."""
    from numpy._core._multiarray_umath import __cpu_features__ as features

    level = next(
        (k for k in ("AVX512F", "AVX2", "ASIMD", "SSE42") if features.get(k)),
        "baseline",
    )
    return f"{platform.machine()} {level}"


def library_versions() -> dict[str, str | None]:
    """Python's and each of :data:`LIBRARIES`' installed version (``None``: not
    installed), with wsgrasp's own and the processor's vector extension
    (:func:`cpu`): what a result file records beside its commit, so that a
    figure can be reproduced with the same libraries on the same kind of
    processor. The gripper table's five-finger hands held other totals on the
    AVX2 machine that measured them first than on an AVX-512 one with the same
    numpy, scipy, open3d and numba (that machine's MuJoCo and CoACD were not
    recorded)."""
    out: dict[str, str | None] = {
        "cpu": cpu(),
        "python": platform.python_version(),
        "wsgrasp": __version__,
    }
    for entry in LIBRARIES:
        names = entry if isinstance(entry, tuple) else (entry,)
        found = None
        for name in names:
            try:
                found = metadata.version(name)
                break
            except metadata.PackageNotFoundError:
                continue
        out[names[0]] = found
    return out
