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
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wsgrasp.errors import InputError, PluginError, WsgraspError
from wsgrasp.gripper.model import GripperModel
from wsgrasp.perception.types import Plane, Scene
from wsgrasp.planning.candidates import orientation_set
from wsgrasp.planning.evaluate import FingerSpheres, TableSE
from wsgrasp.planning.observer import PlanObserver
from wsgrasp.planning.result import PlanResult
from wsgrasp.planning.search import (
    SearchInput,
    SearchOutput,
    no_grasp_hint,
    run_search,
)
from wsgrasp.planning.targets import grasp_targets
from wsgrasp.spec import PipelineSpec, load_spec

__all__ = ["Pipeline", "Prepared", "plan", "load_spec", "as_scene"]

Array = NDArray[np.float64]


def as_scene(
    source: Scene | ArrayLike | str | Path | Sequence[str | Path],
    *,
    icp: bool = False,
) -> Scene:
    """Turn points ``(N, 3)``, a ``Scene``, or cloud/scene files into a ``Scene``
    (view poses refined with ICP when ``icp``)."""
    from wsgrasp.perception.io import load_scene, scene_from_arrays

    if isinstance(source, Scene):
        return source
    if isinstance(source, (str, Path)):
        return load_scene([source], icp=icp)
    if (
        isinstance(source, (list, tuple))
        and source
        and isinstance(source[0], (str, Path))
    ):
        return load_scene(list(source), icp=icp)
    return scene_from_arrays(np.asarray(source, dtype=np.float64), icp=icp)


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
        # the workspace spheres' extent along the approach, GWC frame
        z = (gripper.sphere_centers - gripper.T_gripper_gwc[:3, 3]) @ (
            gripper.T_gripper_gwc[:3, 2]
        )
        self._reach = (float(z.min()), float(z.max())) if len(z) else (0.0, 0.0)
        # the joint targets' lookups, and open3d's first calls (~1 s once per
        # process): paid here, not in the first plan's timings
        from wsgrasp.planning.targets import prepare

        prepare(gripper)
        from wsgrasp.perception.process import warm_up

        warm_up()
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
        scene = as_scene(scene, icp=self.spec.preprocess.icp)
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

    def prepare(self, scene: Scene, observers: Sequence[PlanObserver] = ()) -> Prepared:
        """Run the stages before the search: downsampling, segmentation, target
        choice, object frame, samples and table; report each to ``observers``."""
        from wsgrasp.perception.frame import (
            object_frame,
            sample_box,
            table_frame,
            table_superellipsoid,
        )
        from wsgrasp.perception.process import downsample, select_target, thin

        spec = self.spec
        timing: dict[str, float] = {}
        t = time.perf_counter()

        def lap(stage: str, data: dict[str, Any]) -> None:
            nonlocal t
            now = time.perf_counter()
            timing[stage] = (now - t) * 1e3
            for o in observers:
                o.on_stage(stage, data)
            t = time.perf_counter()

        points = downsample(scene.points, spec.preprocess.voxel_size)
        lap("preprocess", {"points": points})

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
        # farthest-point thinning keeps the object's shape
        object_points = thin(
            object_points, spec.preprocess.max_object_points, spec.seed
        )
        obstacle_points = np.concatenate(obstacles) if obstacles else np.zeros((0, 3))
        lap(
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
        T_world_table = table_frame(segmentation.table, frame.centroid)
        se_center, se_axes, se_exp = table_superellipsoid(spec.table)
        table = TableSE(T_world_table, se_center, se_axes, se_exp)
        orientations = orientation_set(
            spec.sampling, frame.T_world_object, T_world_table[:3, 2], self._reach
        )
        lap(
            "object_frame",
            {
                "T_world_object": frame.T_world_object,
                "extents": frame.extents,
                "samples_world": samples_object @ frame.T_world_object[:3, :3].T
                + frame.T_world_object[:3, 3],
                "T_world_table": T_world_table,
                "R_world_gwc": frame.T_world_object[:3, :3] @ orientations.R_object_gwc,
            },
        )
        search_input = SearchInput(
            gripper=self.gripper,
            T_world_object=frame.T_world_object,
            extents=frame.extents,
            samples_object=samples_object,
            orientations=orientations,
            object_points=object_points,
            obstacle_points=obstacle_points,
            table=table,
        )
        return Prepared(
            search_input=search_input,
            downsampled=points,
            table_plane=segmentation.table,
            obstacles=obstacles,
            timing_ms=timing,
        )

    def search(self, prepared: Prepared) -> SearchOutput:
        """The vectorised search on prepared inputs."""
        centroid = prepared.search_input.T_world_object[:3, 3]
        return run_search(
            prepared.search_input,
            self._scorers,
            top_k=self.spec.top_k,
            spheres=self._spheres,
            normals_fn=lambda p: _normals(p, centroid),
        )

    def _plan(self, scene: Scene, observers: Sequence[PlanObserver]) -> PlanResult:
        g = self.gripper
        t_start = time.perf_counter()
        prep = self.prepare(scene, observers)
        out = self.search(prep)
        for o in observers:
            o.on_stage("candidates", {"candidates": out.candidates})
        timing = {**prep.timing_ms, **out.timing_ms}

        inp = prep.search_input
        hist = out.candidates.histogram()
        rejections = {k: v for k, v in hist.items() if k != "feasible"}
        found = out.best is not None
        T_world_gripper = T_world_gwc = T_world_tcp = T_world_pregrasp = None
        joints_pregrasp: dict[str, float] = {}
        joints_grasp: dict[str, float] = {}
        finger_targets: list[dict[str, Any]] = []
        hint = ""
        if out.best is not None:
            T_world_gripper = out.candidates.T_world_ee[out.best]
            T_world_gwc = out.candidates.T_world_gwc[out.best]
            T_world_tcp = T_world_gripper @ g.T_gripper_tcp
            t = time.perf_counter()
            targets = grasp_targets(
                g,
                T_world_gripper,
                out.contacts,
                approach_distance=self.spec.approach.distance,
                squeeze=self.spec.approach.squeeze,
                close_to=self.spec.approach.close_to,
            )
            timing["targets"] = (time.perf_counter() - t) * 1e3
            T_world_pregrasp = targets.T_world_pregrasp
            joints_pregrasp = targets.joints_pregrasp
            joints_grasp = targets.joints_grasp
            finger_targets = [
                {
                    "finger": f.finger,
                    "contact": f.contact,
                    "grasp": f.grasp,
                    "pad_world": f.pad_world.tolist(),
                    "gap": f.gap,
                    "squeeze": f.squeeze,
                }
                for f in targets.fingers
            ]
        else:
            heights = prep.table_plane.signed_distance(inp.object_points)
            hint = no_grasp_hint(hist, inp.extents, g, float(heights.max()))
        timing["total"] = (time.perf_counter() - t_start) * 1e3
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
            T_world_object=inp.T_world_object,
            object_extents=inp.extents,
            info={
                "object_points": int(len(inp.object_points)),
                "obstacles": len(prep.obstacles),
                "scene_points": int(len(scene.points)),
                "downsampled_points": int(len(prep.downsampled)),
                "dropped_nonfinite": int(scene.dropped_nonfinite),
                "sampling_mode": inp.orientations.mode,
                "orientations": len(inp.orientations),
                "table_normal": inp.table.T_world_table[:3, 2].tolist(),
            },
            T_world_pregrasp=T_world_pregrasp,
            joints_pregrasp=joints_pregrasp,
            joints_grasp=joints_grasp,
            finger_targets=finger_targets,
        )


@dataclass
class Prepared:
    """The stages before the search, ready for it."""

    search_input: SearchInput
    downsampled: Array
    table_plane: Plane
    obstacles: list[Array]
    timing_ms: dict[str, float]


def _normals(points: Array, centroid: Array) -> Array:
    """Unit normals of the object points ``(n, 3)``, pointing away from the
    object's centroid."""
    from wsgrasp.perception.frame import estimate_normals

    n = estimate_normals(points)
    flip = np.einsum("ij,ij->i", points - centroid, n) < 0.0
    n[flip] *= -1.0
    return n


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
