"""The public Python API: ``Pipeline``, ``plan()``, ``load_spec()``.

::

    import wsgrasp
    pipeline = wsgrasp.Pipeline.from_file("examples/specs/franka.yaml")
    result = pipeline.plan(points)          # (N, 3) array, a Scene, or cloud files
    if result.found:
        print(result.T_world_ee)
    else:
        print(result.hint, result.rejections)
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wsgrasp.errors import InputError, PluginError, WsgraspError
from wsgrasp.gripper.model import GripperModel
from wsgrasp.perception.types import Scene
from wsgrasp.planning.candidates import orientation_angles
from wsgrasp.planning.evaluate import FingerSpheres, TableSE
from wsgrasp.planning.observer import PlanObserver
from wsgrasp.planning.result import PlanResult
from wsgrasp.planning.search import SearchInput, no_grasp_hint, run_search
from wsgrasp.spec import PipelineSpec, load_spec

__all__ = ["Pipeline", "plan", "load_spec", "as_scene"]

Array = NDArray[np.float64]


def as_scene(source: Scene | ArrayLike | str | Path | Sequence[str | Path]) -> Scene:
    """Turn points ``(N, 3)``, a ``Scene``, or cloud/scene files into a ``Scene``."""
    from wsgrasp.perception.io import load_scene, scene_from_arrays

    if isinstance(source, Scene):
        return source
    if isinstance(source, (str, Path)):
        return load_scene([source])
    if (
        isinstance(source, (list, tuple))
        and source
        and isinstance(source[0], (str, Path))
    ):
        return load_scene(list(source))
    return scene_from_arrays(np.asarray(source, dtype=np.float64))


class Pipeline:
    """A validated spec with its gripper model and plugins resolved, ready to plan.

    Parameters
    ----------
    spec
        A ``PipelineSpec`` (see ``load_spec``).
    gripper
        A built gripper model; loaded (and cached) from ``spec.gripper`` if omitted.
    registry
        Plugin registry; the process-wide one by default.
    """

    def __init__(
        self,
        spec: PipelineSpec,
        *,
        gripper: GripperModel | None = None,
        registry: Any | None = None,
    ) -> None:
        from wsgrasp.plugins import get_registry

        self.spec = spec
        self.registry = registry if registry is not None else get_registry()
        if gripper is None:
            from wsgrasp.gripper import load_gripper

            base = spec.source.parent if spec.source is not None else Path.cwd()
            name = spec.gripper
            if name.endswith((".yaml", ".yml", ".json", ".toml")) or "/" in name:
                path = Path(name)
                name = str(path if path.is_absolute() else base / path)
            gripper = load_gripper(name, registry=self.registry)
        self.gripper = gripper
        self._spheres = FingerSpheres(gripper)
        seg = self.registry.get("segmenters", spec.segmenter.name)
        self._segmenter = _instantiate(seg)
        self._segmenter_options = seg.obj.Options.model_validate(spec.segmenter.options)
        self._scorers = []
        for ref in spec.scorers:
            entry = self.registry.get("scorers", ref.name)
            options = entry.obj.Options.model_validate(ref.options)
            self._scorers.append((ref.name, _instantiate(entry), options, ref.weight))

    @classmethod
    def from_file(cls, path: str | Path, **kwargs: Any) -> Pipeline:
        """Load a spec file and build the pipeline."""
        return cls(load_spec(path), **kwargs)

    # ---------------------------------------------------------------------------
    def plan(
        self,
        scene: Scene | ArrayLike | str | Path | Sequence[str | Path],
        *,
        observers: Sequence[PlanObserver] = (),
    ) -> PlanResult:
        """Plan a grasp on a scene (points ``(N, 3)`` in any frame, a ``Scene`` or
        cloud files). "No grasp" is a result with ``found=False`` and a hint."""
        scene = as_scene(scene)
        for o in observers:
            o.on_start(self.spec, self.gripper, scene)
        try:
            result = self._plan(scene, observers)
        except BaseException as exc:
            for o in observers:
                o.on_error(exc)
            raise
        for o in observers:
            o.on_result(result)
        return result

    def _plan(self, scene: Scene, observers: Sequence[PlanObserver]) -> PlanResult:
        from wsgrasp.perception.frame import (
            estimate_normals,
            object_frame,
            sample_box,
            table_frame,
            table_superellipsoid,
        )
        from wsgrasp.perception.process import downsample, select_target

        spec, g = self.spec, self.gripper
        timing: dict[str, float] = {}
        t_start = t = time.perf_counter()

        def lap(stage: str) -> None:
            nonlocal t
            now = time.perf_counter()
            timing[stage] = (now - t) * 1e3
            t = now

        def report(stage: str, data: dict[str, Any]) -> None:
            for o in observers:
                o.on_stage(stage, data)

        points = downsample(scene.points, spec.preprocess.voxel_size)
        lap("preprocess")
        report("preprocess", {"points": points})

        try:
            segmentation = self._segmenter.segment(
                points, self._segmenter_options, seed=spec.seed
            )
        except WsgraspError:
            raise
        except Exception as exc:  # noqa: BLE001 - a plugin's failure, reported
            raise PluginError(
                f"segmenter {spec.segmenter.name!r} raised {type(exc).__name__}: {exc}",
                hint="check the segmenter's options in the spec, or report it to "
                "the plugin's authors",
            ) from exc
        object_points, obstacles = select_target(segmentation, spec.target)
        object_points = _thin(
            object_points, spec.preprocess.max_object_points, spec.seed
        )
        obstacle_points = np.concatenate(obstacles) if obstacles else np.zeros((0, 3))
        lap("segmentation")
        report(
            "segmentation",
            {
                "table_normal": segmentation.table.normal,
                "table_offset": float(segmentation.table.offset),
                "table_points": segmentation.table_points,
                "object_points": object_points,
                "obstacles": obstacles,
            },
        )

        frame = object_frame(object_points, spec.object_frame.method)
        samples_object = sample_box(frame, spec.sampling)
        T_world_table = table_frame(segmentation.table, frame.T_world_object[:3, 3])
        se_center, se_axes, se_exp = table_superellipsoid(spec.table)
        table = TableSE(T_world_table, se_center, se_axes, se_exp)
        lap("object_frame")
        report(
            "object_frame",
            {
                "T_world_object": frame.T_world_object,
                "extents": frame.extents,
                "samples_world": samples_object @ frame.T_world_object[:3, :3].T
                + frame.T_world_object[:3, 3],
                "T_world_table": T_world_table,
            },
        )

        thetas = orientation_angles(
            spec.sampling.orientations, spec.sampling.angle_range_deg
        )
        out = run_search(
            SearchInput(
                gripper=g,
                T_world_object=frame.T_world_object,
                extents=frame.extents,
                samples_object=samples_object,
                thetas=thetas,
                object_points=object_points,
                obstacle_points=obstacle_points,
                table=table,
            ),
            self._scorers,
            top_k=spec.top_k,
            spheres=self._spheres,
            normals_fn=lambda p: estimate_normals(p, frame.T_world_object[:3, 3]),
        )
        timing.update(out.timing_ms)
        t = time.perf_counter()
        report("candidates", {"candidates": out.candidates})
        timing["total"] = (time.perf_counter() - t_start) * 1e3

        hist = out.candidates.histogram()
        rejections = {k: v for k, v in hist.items() if k != "feasible"}
        found = out.best is not None
        T_world_gripper = T_world_gwc = T_world_tcp = None
        hint = ""
        if found:
            assert out.best is not None
            T_world_gripper = out.candidates.T_world_ee[out.best]
            T_world_gwc = out.candidates.T_world_gwc[out.best]
            T_world_tcp = T_world_gripper @ g.T_gripper_tcp
        else:
            heights = segmentation.table.signed_distance(object_points)
            hint = no_grasp_hint(hist, frame.extents, g, float(heights.max()))
        return PlanResult(
            found=found,
            gripper=g.name,
            T_world_ee=T_world_gripper,
            T_world_gwc=T_world_gwc,
            T_world_tcp=T_world_tcp,
            pregrasp=dict(g.pregrasp),
            closed=dict(g.closed),
            contacts=out.contacts,
            score=None if out.best is None else float(out.candidates.score[out.best]),
            score_terms=out.score_terms,
            best_index=out.best,
            alternatives=out.alternatives,
            candidates=out.candidates,
            rejections=rejections,
            timing_ms=timing,
            hint=hint,
            T_world_object=frame.T_world_object,
            object_extents=frame.extents,
            info={
                "object_points": int(len(object_points)),
                "obstacles": len(obstacles),
                "scene_points": int(len(scene.points)),
                "downsampled_points": int(len(points)),
                "dropped_nonfinite": int(scene.dropped_nonfinite),
            },
        )


def _instantiate(entry: Any) -> Any:
    obj = entry.obj
    try:
        return obj() if isinstance(obj, type) else obj
    except Exception as exc:  # noqa: BLE001 - a plugin's failure, reported
        raise PluginError(
            f"{entry.kind[:-1]} {entry.name!r} from {entry.plugin.distribution} "
            f"could not be created: {type(exc).__name__}: {exc}",
            hint="report it to the plugin's authors",
        ) from exc


def _thin(points: Array, limit: int, seed: int) -> Array:
    """At most ``limit`` points, a seeded uniform subset in original order."""
    if len(points) <= limit:
        return points
    rng = np.random.default_rng(seed)
    keep = np.sort(rng.choice(len(points), size=limit, replace=False))
    return points[keep]


def plan(
    scene: Scene | ArrayLike | str | Path | Sequence[str | Path],
    spec: PipelineSpec | str | Path | dict[str, Any],
    *,
    gripper: GripperModel | None = None,
    observers: Sequence[PlanObserver] = (),
) -> PlanResult:
    """Plan a grasp in one call.

    ``wsgrasp.plan(points, "examples/specs/franka.yaml")``
    """
    if not isinstance(spec, PipelineSpec):
        spec = load_spec(spec)
    if scene is None:
        raise InputError("no scene given", hint="pass points (N, 3) or cloud files")
    return Pipeline(spec, gripper=gripper).plan(scene, observers=observers)
