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
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wsgrasp._names import gripper_ref
from wsgrasp.errors import InputError, PluginError, WsgraspError
from wsgrasp.geometry import plane_basis
from wsgrasp.gripper.model import GripperModel
from wsgrasp.perception.footprint import Footprint, narrowest_width
from wsgrasp.perception.sides import mirror_hidden
from wsgrasp.perception.types import Plane, Scene
from wsgrasp.planning.candidates import Orientations, far_side, orientation_set
from wsgrasp.planning.evaluate import FingerSpheres, TableSE
from wsgrasp.planning.observer import PlanObserver
from wsgrasp.planning.result import PlanResult
from wsgrasp.planning.search import (
    SearchInput,
    SearchOutput,
    no_grasp_hint,
    run_search,
)
from wsgrasp.planning.targets import grasp_targets, pregrasp_pose
from wsgrasp.spec import PipelineSpec, Sampling, load_spec

__all__ = ["Pipeline", "Prepared", "plan", "load_spec", "as_scene"]

Array = NDArray[np.float64]


def as_scene(
    source: Scene | ArrayLike | str | Path | Sequence[str | Path],
    *,
    icp: bool = False,
) -> Scene:
    """Turn points ``(N, 3)`` (or a structured array with fields x, y, z),
    ``(points, T_world_camera)`` pairs, a ``Scene``, or cloud/scene files into
    a ``Scene`` (view poses refined with ICP when ``icp``)."""
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
    # points (N, 3), a structured array read by field name (x, y, z), or
    # (points, T_world_camera) pairs
    return scene_from_arrays(source, icp=icp)  # type: ignore[arg-type]


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
            name = gripper_ref(spec.gripper, base)
            gripper = load_gripper(name, registry=self.registry)
        self.gripper = gripper
        self._spheres = FingerSpheres(gripper)
        # the workspace spheres' extent along the approach, GWC frame
        z = (gripper.sphere_centers - gripper.T_gripper_gwc[:3, 3]) @ (
            gripper.T_gripper_gwc[:3, 2]
        )
        self._reach = (float(z.min()), float(z.max())) if len(z) else (0.0, 0.0)
        # the side of its approach axis the body reaches farther along, GWC x
        T = gripper.T_gripper_gwc
        self._side = far_side((gripper.cloud - T[:3, 3]) @ T[:3, :3])
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
        choose: int | None = None,
    ) -> PlanResult:
        """Plan a grasp on a scene (points ``(N, 3)`` in any frame, a ``Scene`` or
        cloud files). "No grasp" is a result with ``found=False`` and a hint.

        ``choose`` takes feasible candidate ``choose`` (an index into
        ``result.candidates``, as ``result.alternatives`` give them) as the
        grasp instead of the best-scored one, finished as the plan finishes its
        own choice: backed off from the table, its contacts, pre-grasp pose and
        joint targets; the alternatives are the candidates ranked after it. The
        same scene and spec give the same candidates, so an index from one plan
        names the same candidate in the next. An index out of range or naming a
        rejected candidate raises :class:`~wsgrasp.errors.InputError`.
        """
        return self.plan_and_choices(
            scene, lambda _result: [], observers=observers, choose=choose
        )[0]

    def prepare(self, scene: Scene, observers: Sequence[PlanObserver] = ()) -> Prepared:
        """Run the stages before the search: cropping (``preprocess.crop_radius``)
        and downsampling, segmentation, target choice, object frame, samples and
        table; report each to ``observers``."""
        from wsgrasp.perception.frame import (
            object_frame,
            sample_box,
            table_frame,
            table_superellipsoid,
        )
        from wsgrasp.perception.io import units_hint
        from wsgrasp.perception.process import preprocess, select_target, thin

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

        points, flying = preprocess(scene, spec.preprocess)
        _check_spread(scene.points, points, spec.preprocess.voxel_size)
        pre: dict[str, Any] = {"points": points, "flying_pixels": len(flying)}
        if len(flying):
            pre["flying_points"] = flying  # drawn in Foxglove
        lap("preprocess", pre)

        viewpoints = scene.viewpoints()
        kwargs: dict[str, Any] = {}
        if len(viewpoints) and _accepts(self._segmenter.segment, "viewpoints"):
            kwargs["viewpoints"] = viewpoints

        def segmented(cloud: Array) -> tuple[Any, Array, list[Array]]:
            """The segmentation of ``cloud`` and its target and obstacles."""
            try:
                seg = self._segmenter.segment(
                    cloud, self._segmenter_options, seed=spec.seed, **kwargs
                )
            except InputError as exc:
                from wsgrasp.perception.flying import pixel_grid

                image = any(pixel_grid(v.points) is not None for v in scene.views)
                units = units_hint(cloud, image)
                if units is None:
                    raise
                hint = f"{exc.hint}; or {units}" if exc.hint else units
                raise InputError(exc.message, hint=hint) from exc
            except WsgraspError:
                raise
            except Exception as exc:  # noqa: BLE001 - a plugin's failure, reported
                raise PluginError(
                    f"segmenter {spec.segmenter.name!r} raised "
                    f"{type(exc).__name__}: {exc}",
                    hint="check the segmenter's options in the spec, or report it "
                    "to the plugin's authors",
                ) from exc
            return (seg, *select_target(seg, spec.target))

        segmentation, object_points, obstacles = segmented(points)
        # a target far out in a wide view (a room's noisy far floor) while the
        # cameras see much of the scene near them: the near scene alone, if its
        # target is nearer
        near_crop = None
        radius = _near_radius(viewpoints, object_points, points)
        if radius is not None and spec.preprocess.crop_radius is None:
            near = _within(points, viewpoints, radius)
            try:
                again = segmented(points[near])
            except WsgraspError:
                again = None
            if again is not None and _range(viewpoints, again[1]) <= radius:
                near_crop = (_range(viewpoints, object_points), radius)
                points = points[near]
                segmentation, object_points, obstacles = again
        _check_table_side(segmentation.table, object_points, viewpoints, spec)
        object_points, obstacles = _one_object(
            segmentation, object_points, obstacles, spec
        )
        names, segments = _instances(segmentation, object_points, obstacles, spec)
        if spec.object_frame.mirror_hidden:
            object_points = mirror_hidden(
                object_points, segmentation.table.normal, viewpoints
            )
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
                **({"obstacle_names": names, "segments": segments} if names else {}),
            },
        )

        frame = object_frame(object_points, spec.object_frame.method)
        T_world_table = table_frame(segmentation.table, frame.centroid)
        up = T_world_table[:3, 2]
        footprint = Footprint.from_points(
            up, -float(up @ T_world_table[:3, 3]), segmentation.table_points
        )
        se_center, se_axes, se_exp = table_superellipsoid(spec.table)
        table = TableSE(T_world_table, se_center, se_axes, se_exp)

        def sampled(sampling: Sampling) -> tuple[Array, Orientations, str]:
            """The box samples and orientations of ``sampling`` (no samples
            where no pose of them can span the object), and why not."""
            samples = sample_box(frame, sampling)
            orientations = orientation_set(
                sampling,
                frame.T_world_object,
                up,
                self._reach,
                self._side,
                object_points,
            )
            # (O, 3) the direction each orientation's fingers close along, world
            closing = (
                orientations.R_object_gwc[:, :, 1] @ frame.T_world_object[:3, :3].T
            )
            too_large = _too_large(
                object_points,
                self.gripper,
                closing,
                lambda: _depth_noise(points, segmentation.table, object_points),
                up=up,
            )
            # no pose can span the object: no candidates, and the result says so
            return (samples[:0] if too_large else samples), orientations, too_large

        samples_object, orientations, too_large = sampled(spec.sampling)
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
            viewpoints=viewpoints,
        )
        return Prepared(
            search_input=search_input,
            near_crop=near_crop,
            downsampled=points,
            table_plane=segmentation.table,
            obstacles=obstacles,
            timing_ms=timing,
            too_large=too_large,
            table_footprint=footprint,
            obstacle_names=names,
            segments=segments,
            depth_noise=_float_or_none(segmentation.info.get("depth_noise")),
            standing_sides=_sides(segmentation.info.get("standing_sides")),
            under_surface=bool(segmentation.info.get("under_surface", False)),
            sampled=sampled,
        )

    def search(self, prepared: Prepared) -> SearchOutput:
        """The vectorised search on prepared inputs, with every feasible
        candidate whose fingers would sweep through the table before reaching
        the object rejected (``finger_sweeps_table``) where backing it off
        cannot clear them (:func:`_sweeps_cleared`)."""
        centroid = prepared.search_input.T_world_object[:3, 3]
        out = run_search(
            prepared.search_input,
            self._scorers,
            top_k=self.spec.top_k,
            spheres=self._spheres,
            normals_fn=lambda p: _normals(p, centroid),
            normals_of=lambda p, rows: _normals(p, centroid, rows),
        )
        out = _sweeps_cleared(
            out, self.gripper, prepared.search_input, self._spheres, self.spec.top_k
        )
        return _clear_of_neighbours(
            out, prepared, self.gripper, self._spheres, self.spec.top_k
        )

    def plan_choices(
        self,
        scene: Scene | ArrayLike | str | Path | Sequence[str | Path],
        choices: Sequence[int],
    ) -> list[PlanResult]:
        """One plan per candidate index in ``choices``, each the one
        ``plan(scene, choose=i)`` gives, from one preparation and search of the
        scene (nothing is recorded). Raises as ``plan`` does for an index that
        is out of range or names a rejected candidate."""
        scene = as_scene(scene, icp=self.spec.preprocess.icp)
        prep, out, shared_ms = self._searched(scene)
        return [self._finish(scene, prep, out, i, (), shared_ms) for i in choices]

    def plan_and_choices(
        self,
        scene: Scene | ArrayLike | str | Path | Sequence[str | Path],
        pick: Callable[[PlanResult], Sequence[int]],
        *,
        observers: Sequence[PlanObserver] = (),
        choose: int | None = None,
    ) -> tuple[PlanResult, list[PlanResult]]:
        """The plan ``plan(scene, observers=observers, choose=choose)`` gives,
        and one plan per candidate index that ``pick`` names from it, each the
        one ``plan(scene, choose=i)`` gives, all from one preparation and search
        of the scene: for labelling a plan's alternatives without searching the
        scene twice. ``observers`` see the first plan only. Raises as ``plan``
        does for an index that is out of range or names a rejected candidate."""
        scene = as_scene(scene, icp=self.spec.preprocess.icp)
        for o in observers:
            o.on_start(self.spec, self.gripper, scene)
        try:
            prep, out, shared_ms = self._searched(scene, observers)
            result = self._finish(scene, prep, out, choose, observers, shared_ms)
        except BaseException as exc:
            for o in observers:
                o.on_error(exc)
            raise
        for o in observers:
            o.on_result(result)
        chosen = [
            self._finish(scene, prep, out, int(i), (), shared_ms) for i in pick(result)
        ]
        return result, chosen

    def _searched(
        self, scene: Scene, observers: Sequence[PlanObserver] = ()
    ) -> tuple[Prepared, SearchOutput, float]:
        """The scene prepared and searched, each stage and the candidates told
        to ``observers``, and the time (ms) the two took, for the plans
        finished from them."""
        t_start = time.perf_counter()
        prep = self.prepare(scene, observers)
        out = self.search(prep)
        fallback = self.spec.sampling.fallback
        if fallback is not None and prep.sampled is not None and out.best is None:
            prep, out = self._fallback(prep, out, fallback, observers)
        for o in observers:
            o.on_stage("candidates", {"candidates": out.candidates})
        return prep, out, (time.perf_counter() - t_start) * 1e3

    def _fallback(
        self,
        prep: Prepared,
        out: SearchOutput,
        sampling: Sampling,
        observers: Sequence[PlanObserver],
    ) -> tuple[Prepared, SearchOutput]:
        """The search again with ``sampling`` (``sampling.fallback``), on the
        same object frame, table and neighbours, where the first found no
        grasp; the first search's rejections are told to ``observers`` and kept
        in the result's ``info``."""
        assert prep.sampled is not None
        t = time.perf_counter()
        first: dict[str, Any] = {
            k: v for k, v in out.candidates.histogram().items() if v
        }
        if prep.too_large:
            first["too_large"] = prep.too_large
        samples, orientations, too_large = prep.sampled(sampling)
        inp = replace(
            prep.search_input, samples_object=samples, orientations=orientations
        )
        again = replace(
            prep,
            search_input=inp,
            too_large=too_large,
            blocked_by={},
            timing_ms=dict(prep.timing_ms),
            fallback={"first_search": first},
        )
        out = self.search(again)
        R = inp.T_world_object[:3, :3]
        for o in observers:
            o.on_stage(
                "fallback",
                {
                    "first_search": first,
                    "samples_world": samples @ R.T + inp.T_world_object[:3, 3],
                    "R_world_gwc": R @ orientations.R_object_gwc,
                },
            )
        again.timing_ms["fallback"] = (time.perf_counter() - t) * 1e3
        return again, out

    def _finish(
        self,
        scene: Scene,
        prep: Prepared,
        out: SearchOutput,
        choose: int | None,
        observers: Sequence[PlanObserver],
        shared_ms: float,
    ) -> PlanResult:
        """The plan's result from its search: the choice (the best-scored
        candidate whose pre-grasp pose is clear, or ``choose``), its targets
        and, without a grasp, the hint. ``out`` is not changed, so one search
        can be finished with several choices; ``shared_ms`` is the time its
        preparation and search took, for the total."""
        g = self.gripper
        t_start = time.perf_counter()
        timing = {**prep.timing_ms, **out.timing_ms}
        inp = prep.search_input
        hist = out.candidates.histogram()
        rejections = {k: v for k, v in hist.items() if k != "feasible"}
        distance = self.spec.approach.distance
        hint = ""
        if choose is None:
            best, taken = _with_clear_pregrasp(
                out,
                g,
                inp,
                self._spheres,
                distance,
                prep.table_footprint,
                closing=self.spec.approach.close_to == "closed",
            )
            if best != out.best:
                out = _choose(out, best, g, inp, self._spheres, self.spec.top_k, taken)
        else:
            for o in observers:  # recorded, so that a replay takes it too
                o.on_stage("choice", {"candidate": int(choose)})
            index = _taken(out, choose)
            out = _choose(out, index, g, inp, self._spheres, self.spec.top_k)
            T = out.candidates.ee_at(index)
            if _under_table(g, prep.table_footprint, T, distance):
                out = _choose(out, None, g, inp, self._spheres, self.spec.top_k)
                hint = (
                    f"candidate {index}'s grasp or pre-grasp pose lies under the "
                    "table; choose another"
                )
            elif _hits_table(g, inp.table, pregrasp_pose(g, T, distance)):
                out = _choose(out, None, g, inp, self._spheres, self.spec.top_k)
                hint = (
                    f"candidate {index}'s pre-grasp pose, {distance:g} m back along "
                    "its approach, hits the table; choose another or lower "
                    "approach.distance"
                )
        found = out.best is not None
        T_world_gripper = T_world_gwc = T_world_tcp = T_world_pregrasp = None
        joints_pregrasp: dict[str, float] = {}
        joints_grasp: dict[str, float] = {}
        finger_targets: list[dict[str, Any]] = []
        if out.best is not None:
            T_world_gripper = out.candidates.ee_at(out.best)
            T_world_gwc = out.candidates.gwc_at(out.best)
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
            _guard_table(
                g, inp.table, prep.table_footprint, T_world_gripper, T_world_pregrasp
            )
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
        elif not hint:  # a chosen candidate's hint says why already
            hint = _no_grasp(
                prep, out, hist, g, distance, self.spec.approach.close_to == "closed"
            )
            hint += _what_fits(prep, g)
            if prep.blocked_by:
                hint += "; " + _blockers(prep.blocked_by) + _siblings(prep)
                if self.spec.sampling.mode == "major_axis" and not _from_above(prep):
                    hint += (
                        "; every candidate comes from the side (the object stands "
                        "upright, and sampling.mode major_axis sets the gripper "
                        "across its major axis): sampling.mode approach_sphere "
                        "also approaches from above"
                    )
        timing["total"] = shared_ms + (time.perf_counter() - t_start) * 1e3
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
                "dropped_no_depth": int(scene.dropped_no_depth),
                "sampling_mode": inp.orientations.mode,
                "orientations": len(inp.orientations),
                "table_normal": inp.table.T_world_table[:3, 2].tolist(),
                **({"segments": prep.segments} if prep.segments else {}),
                **({"blocked_by": prep.blocked_by} if prep.obstacle_names else {}),
                **(
                    {"fallback": {"first_search": prep.fallback["first_search"]}}
                    if prep.fallback
                    else {}
                ),
            },
            T_world_pregrasp=T_world_pregrasp,
            joints_pregrasp=joints_pregrasp,
            joints_grasp=joints_grasp,
            finger_targets=finger_targets,
            warnings=_frame_warnings(scene, inp.table.T_world_table[:3, 2])
            + _range_warnings(
                inp.viewpoints, inp.object_points, prep.downsampled, prep.near_crop
            )
            + _origin_warnings(inp.viewpoints, inp.object_points)
            + _noise_warnings(prep.depth_noise)
            + _side_warnings(prep.standing_sides)
            + _under_warnings(prep.under_surface)
            + _calibration_warnings(scene, prep.table_plane, inp.object_points),
        )


#: a table tilted more than this (degrees) from the world's z axis, in a scene
#: whose views have poses, gets a warning: a robot's base frame has z up
TABLE_TILT_WARNING_DEG = 20.0


def _frame_warnings(scene: Scene, up: Array) -> list[str]:
    """A warning when the views were given poses, so that the world is likely a
    robot's or a room's frame with z up, and the table's normal ``up`` is
    tilted from that axis by more than :data:`TABLE_TILT_WARNING_DEG`: the
    poses are then likely those of another frame (ROS's camera_link for an
    optical-frame cloud) or inverted, and every pose of the result is in that
    world."""
    tilt = scene.table_tilt(up)
    if tilt is None or tilt <= TABLE_TILT_WARNING_DEG:
        return []
    mistake = _pose_mistake(scene, up)
    likely = (
        f"a T_world_camera is probably {mistake}, which levels the table"
        if mistake
        else "a T_world_camera is probably wrong (the pose of ROS's camera_link "
        "given for a cloud in the optical frame, z forward, or the world's pose "
        "in the camera)"
    )
    return [
        f"the table is tilted {tilt:.0f}° from the world's z axis although the "
        f"views were given camera poses: if the world is a robot's base frame "
        f"(z up), {likely}, and so is every pose of this plan"
    ]


#: a table within this (degrees) of the world's z axis once a mistake in the
#: views' poses is undone names that mistake
LEVEL_AFTER_FIX_DEG = 5.0


def _pose_mistake(scene: Scene, up: Array) -> str:
    """The one common mistake in the posed views' ``T_world_camera`` whose undoing
    levels the table (normal ``up`` ``(3,)``, world) in every one of them to
    within :data:`LEVEL_AFTER_FIX_DEG`, said as what the pose was: the world's
    pose in the camera, camera_link's pose for an optical-frame cloud, or a
    quaternion read with its scalar first; ``""`` when none or several do."""
    from scipy.spatial.transform import Rotation

    from wsgrasp.perception.flying import _LINK_TO_OPTICAL

    def swapped(R: Array) -> Array:  # x, y, z, w read where w, x, y, z was meant
        return np.asarray(
            Rotation.from_quat(
                np.roll(Rotation.from_matrix(R).as_quat(), -1)
            ).as_matrix()
        )

    fixes = {
        "the world's pose in the camera (T_camera_world): give its inverse": lambda R: (
            R.T
        ),
        "the pose of ROS's camera_link given for a cloud in the optical frame "
        "(z forward): give the optical frame's": lambda R: R @ _LINK_TO_OPTICAL.T,
        "a quaternion given with its scalar first (w, x, y, z) where x, y, z, w "
        "is read: move w last": swapped,
    }
    n = np.asarray(up, dtype=np.float64) / np.linalg.norm(up)
    level = np.cos(np.radians(LEVEL_AFTER_FIX_DEG))
    rotations = [
        np.asarray(v.T_world_camera, np.float64)[:3, :3] for v in scene.views if v.posed
    ]
    found = [
        what
        for what, fix in fixes.items()
        if rotations
        # the table's normal in each camera's frame, turned by the fixed pose
        and all(abs(float((fix(R) @ (R.T @ n))[2])) >= level for R in rotations)
    ]
    return found[0] if len(found) == 1 else ""


#: an object farther than this (m) from every camera that saw it gets a warning:
#: depth cameras see a tabletop from under 1.5 m, and a depth image read in
#: the wrong unit (TUM RGB-D's 0.2 mm as millimetres) puts it several times
#: farther
FAR_OBJECT_WARNING_M = 2.0


def _range(cameras: Array, points: Array) -> float:
    """The distance (m) from the centre of ``points`` to the nearest of
    ``cameras`` ``(k, 3)``."""
    centre = np.asarray(points, dtype=np.float64).mean(axis=0)
    return float(np.linalg.norm(np.asarray(cameras) - centre, axis=1).min())


def _ranges(cameras: Array, points: Array) -> Array:
    """Each of ``points``' distance (m) to the nearest of ``cameras``."""
    p = np.asarray(points, dtype=np.float64)
    return np.min([np.linalg.norm(p - c, axis=1) for c in np.asarray(cameras)], axis=0)


def _near_radius(
    cameras: Array, object_points: Array, scene_points: Array
) -> float | None:
    """Where the object lies farther than :data:`FAR_OBJECT_WARNING_M` from
    the nearest of ``cameras``: the radius (m) round the cameras that keeps
    the near scene, :data:`_NEAR_MARGIN` times the range within which
    :data:`_NEAR_SHARE` percent of the scene (``scene_points``, at most 20,000
    of them evenly spaced) lies, at least 1 m; None where that radius does not
    fall short of the object's range by a quarter (a depth scale read wrong
    puts the whole scene far).

    A wide view of a room around a desk (87 degrees) sees its far floor and
    walls thick with a stereo camera's noise, which grows with the square of
    the range, and the nearest surfaces seen are the desk and what stands on
    it: a twentieth of a 1280 x 720 view's points lay within 10 % of the
    camera's distance to the object on the desk, 1-3 m away."""
    if not len(cameras) or not len(object_points) or not len(scene_points):
        return None
    far = _range(cameras, object_points)
    if far <= FAR_OBJECT_WARNING_M:
        return None
    pts = np.asarray(scene_points)[:: max(1, len(scene_points) // 20000)]
    near = float(np.percentile(_ranges(cameras, pts), _NEAR_SHARE))
    radius = max(_NEAR_MARGIN * near, 1.0)
    return radius if radius < 0.75 * far else None


def _within(points: Array, cameras: Array, radius: float) -> NDArray[np.bool_]:
    """Which of ``points`` lie within ``radius`` (m) of one of ``cameras``."""
    return _ranges(cameras, points) <= radius  # type: ignore[no-any-return]


def _range_warnings(
    cameras: Array,
    object_points: Array,
    scene_points: Array,
    near_crop: tuple[float, float] | None = None,
) -> list[str]:
    """A warning when the object lies farther than
    :data:`FAR_OBJECT_WARNING_M` from the nearest of the views' cameras
    ``cameras`` (those :meth:`Scene.viewpoints` knows, as the search input
    keeps them): where much of the scene lies near them (:func:`_near_radius`),
    a wide view's far floor may have given the target; else the likely cause
    is a depth scale, and every pose of the plan is as far off as the object.
    Where the near scene was segmented instead (``near_crop``: the first
    target's range and the radius kept), a note that says so and how to choose
    the crop."""
    if near_crop is not None:
        first, radius = near_crop
        return [
            f"the target first found lay {first:.2f} m from the nearest camera, "
            "far out in a wide view (a room's far floor and walls, noisy), while "
            "much of the scene lay near it: the plan is on the points within "
            f"{radius:.1f} m of the cameras; set preprocess.crop_radius (metres "
            "from the world's origin, the camera for a cloud in its frame) to "
            "choose the workspace yourself"
        ]
    if not len(cameras) or not len(object_points):
        return []
    far = _range(cameras, object_points)
    if far <= FAR_OBJECT_WARNING_M:
        return []
    head = f"the object lies {far:.2f} m from the nearest camera, far for a depth "
    near = _near_radius(cameras, object_points, scene_points)
    if near is not None:  # the near scene held no target, or the spec crops
        return [
            head + "camera over a table, while much of the scene lies near it: a "
            "wide view of a room, its far floor and walls noisy, may have given "
            "the target; crop the scene to the workspace, within about "
            f"{near:.1f} m of the cameras (preprocess.crop_radius, metres from "
            "the world's origin, the camera for a cloud in its frame), or give "
            "the table (the given_table segmenter)"
        ]
    return [
        head
        + "camera over a table: if the views are depth images, their depth scale is "
        "probably wrong (a depth image in 0.2 mm units, as TUM RGB-D's, read as "
        "millimetres puts everything 5 times too far and each object 5 times too "
        "large: --depth-scale 0.0002), and so is every pose of this plan"
    ]


#: :func:`_near_radius`: the share (percent) of the scene's points whose range
#: tells the near scene's ...
_NEAR_SHARE = 5.0
#: ... and how far past that range the near scene reaches (times it)
_NEAR_MARGIN = 1.5


def _check_spread(scene_points: Array, downsampled: Array, voxel: float) -> None:
    """Refuse a scene whose points fall into a handful of voxels (one point
    repeated, a cloud a few millimetres across): nothing in it is a table with
    objects, and the segmenter would only say that it found no plane."""
    if len(downsampled) >= _FEWEST_VOXELS or len(scene_points) < _FEWEST_VOXELS:
        return
    across = float(np.ptp(scene_points, axis=0).max())
    if across >= _FEWEST_VOXELS * voxel:  # a wide scene a crop left little of
        return
    raise InputError(
        f"the scene's {len(scene_points)} points lie within {across:.3g} m of each "
        f"other: {len(downsampled)} voxel(s) of {voxel:g} m hold them all, no "
        "table and objects",
        hint="check the capture or export (one point repeated, every pixel at one "
        "depth); for a cloud in other units than metres, scale it to metres",
    )


#: a scene downsampled to fewer voxels than this is no tabletop
_FEWEST_VOXELS = 10


#: a camera farther than this (m) from the world's origin, with the object
#: within FAR_OBJECT_WARNING_M of it, gets a warning: a robot's base frame has
#: its cameras within a few metres
FAR_CAMERA_WARNING_M = 50.0


def _origin_warnings(cameras: Array, object_points: Array) -> list[str]:
    """A warning when the views' cameras ``cameras`` stand farther than
    :data:`FAR_CAMERA_WARNING_M` from the world's origin while the object lies
    near them: one camera alone cannot be checked against another, and a
    translation in millimetres in a scene in metres puts the whole scene, and
    every pose of the plan, a thousand times too far out."""
    if not len(cameras) or not len(object_points):
        return []
    out = float(np.linalg.norm(cameras, axis=1).min())
    near = _range(cameras, object_points)
    if out <= FAR_CAMERA_WARNING_M or near > FAR_OBJECT_WARNING_M:
        return []
    return [
        f"the cameras stand {out:.0f} m from the world's origin, {near:.2f} m from "
        "the object: if the world is a robot's base frame, a T_world_camera's "
        "translation is probably in millimetres (or another unit) while the scene "
        "is in metres, and so is every pose of this plan"
    ]


#: views whose tables, each fitted to what that view sees, lie this far apart
#: (degrees, or metres at the object) get a warning: hand-eye calibrations err
#: by a few tenths of a degree and a few millimetres; a view 2-3 degrees off
#: lifts its side of the table into slivers that pass for objects
TABLE_DISAGREE_DEG = 1.5
TABLE_DISAGREE_M = 0.008


def _calibration_warnings(
    scene: Scene, table: Plane, object_points: Array
) -> list[str]:
    """A warning naming the views whose own table (``Scene.view_tables``) lies
    apart from every other view's by more than :data:`TABLE_DISAGREE_DEG` or
    :data:`TABLE_DISAGREE_M` at the object: their poses are off."""
    if len(scene.views) < 2 or not any(v.posed for v in scene.views):
        return []
    at = np.asarray(object_points, dtype=np.float64).mean(axis=0)
    tables = [t for t in scene.view_tables(table, at) if t is not None]
    off = []
    for i, (name, n, h) in enumerate(tables):
        apart = [
            (
                float(np.degrees(np.arccos(min(1.0, float(n @ m))))),
                abs(h - g),
            )
            for j, (_, m, g) in enumerate(tables)
            if j != i
        ]
        if apart and all(
            deg > TABLE_DISAGREE_DEG or dist > TABLE_DISAGREE_M for deg, dist in apart
        ):
            deg, dist = min(apart)
            off.append(f"{name!r} ({deg:.1f}°, {dist * 1000:.0f} mm)")
    if not off:
        return []
    return [
        "the views see the table apart: "
        + ", ".join(off)
        + " from the nearest other view's, where calibrated cameras agree within "
        "a few tenths of a degree and millimetres; a T_world_camera is off, and "
        "the table seen by one view may stand up as objects beside the others' "
        "(refine the poses with `preprocess: {icp: true}` in the spec, see them "
        "with `wsgrasp scene info --icp`, or calibrate again)"
    ]


#: a scene whose table's points scatter more than this (m) about its plane gets
#: a warning: depth cameras over a tabletop scatter 1-3 mm
NOISY_DEPTH_WARNING_M = 0.005


def _float_or_none(value: Any) -> float | None:
    try:
        return None if value is None else float(value)
    except (TypeError, ValueError):  # a plugin's info that is not a number
        return None


def _noise_warnings(noise: float | None) -> list[str]:
    """A warning when the segmenter measured a depth noise (the deviation of
    the table's points about its plane) over :data:`NOISY_DEPTH_WARNING_M`."""
    if noise is None or not noise > NOISY_DEPTH_WARNING_M:
        return []
    return [
        f"the depth is noisy: the table's points scatter {noise * 1e3:.0f} mm about "
        "its plane, where a depth camera over a tabletop scatters 1-3 mm; the "
        "object's outline, and every pose of this plan, may be off by a few times "
        "that (average several frames, bring the camera closer or filter the "
        "depth images)"
    ]


#: where no view has a pose, objects on the side of the table not taken as up
#: with at least this share of the points on the side taken get a warning
TWO_SIDES_WARNING_SHARE = 0.5


def _sides(value: Any) -> tuple[int, int] | None:
    try:
        taken, other = value
        return int(taken), int(other)
    except (TypeError, ValueError):  # absent, or a plugin's info of another form
        return None


def _side_warnings(sides: tuple[int, int] | None) -> list[str]:
    """A warning when objects stand on both sides of the table and no view has a
    pose to say which side the cameras are on: the side with more standing
    points was taken as up (``sides``: its points and the other side's), and a
    reflection in a glossy table, or a shelf under a glass one, has as many."""
    if sides is None or not sides[1] >= TWO_SIDES_WARNING_SHARE * sides[0] > 0:
        return []
    return [
        f"objects stand on both sides of the table ({sides[0]} points on the side "
        f"taken as up, {sides[1]} on the other) and no view has a camera pose to "
        "say which side the cameras are on: the grasp may be on a reflection in "
        "the table or under it; give the views' poses (T_world_camera) or crop "
        "the other side away"
    ]


def _under_warnings(under_surface: bool) -> list[str]:
    """A warning when every object the segmenter found stands under a surface
    seen above it and nothing stands in the open: the target may be a desk's
    leg (an empty desk, its floor in view) or sit in a shelf's compartment,
    which is not planned for (the boards above are obstacles only where seen)."""
    if not under_surface:
        return []
    return [
        "every object found stands under a flat surface seen above it, and "
        "nothing stands in the open: the target may be a desk's leg (the floor "
        "under an empty desk taken for the table) or stand in a shelf's "
        "compartment, which is not planned for; put the object on the table in "
        "view, crop the scene to it (preprocess.crop_radius) or give the table "
        "(the given_table segmenter)"
    ]


@dataclass
class Prepared:
    """The stages before the search, ready for it."""

    search_input: SearchInput
    downsampled: Array
    table_plane: Plane
    obstacles: list[Array]
    timing_ms: dict[str, float]
    #: why no pose can hold the object, when it is wider than the gripper opens
    too_large: str = ""
    #: the table's outline, under which no grasp or pre-grasp pose may go
    table_footprint: Footprint | None = None
    #: a name for each of ``obstacles`` (``object <id>``, ``unsegmented points``)
    obstacle_names: list[str] = field(default_factory=list)
    #: the scene's instances (:func:`wsgrasp.perception.pile.segments`)
    segments: list[dict[str, Any]] = field(default_factory=list)
    #: per neighbour's name, the candidates it blocked: ``{"body": n, "closing":
    #: m}`` (set by the search)
    blocked_by: dict[str, dict[str, int]] = field(default_factory=dict)
    #: the depth noise about the table's plane (m), where the segmenter gives it
    #: (``Segmentation.info["depth_noise"]``)
    depth_noise: float | None = None
    #: where no view has a pose: the points standing on the side of the table
    #: taken as up and on the other (``Segmentation.info["standing_sides"]``)
    standing_sides: tuple[int, int] | None = None
    #: every object found stands under a surface seen above it (a desk's legs
    #: under its top; ``Segmentation.info["under_surface"]``)
    under_surface: bool = False
    #: another sampling's box samples, orientations and ``too_large``, from the
    #: same object frame (``sampling.fallback``)
    sampled: Callable[[Sampling], tuple[Array, Orientations, str]] | None = None
    #: where the spec's sampling found no grasp and ``sampling.fallback`` was
    #: searched instead: the first search's rejections (``first_search``)
    fallback: dict[str, Any] = field(default_factory=dict)
    #: where the target first found lay far out in a wide view and the near
    #: scene was segmented instead (:func:`_near_radius`): the first target's
    #: range from the nearest camera and the radius kept (m)
    near_crop: tuple[float, float] | None = None


def _instances(
    segmentation: Any, object_points: Array, obstacles: list[Array], spec: PipelineSpec
) -> tuple[list[str], list[dict[str, Any]]]:
    """The obstacles' names and the instances' summaries, where the scene has
    several instances or unsegmented points (empty lists for one object
    alone)."""
    from wsgrasp.perception.pile import cluster_members, obstacle_names, segments

    if not obstacles:
        return [], []
    if spec.target.rule == "cluster":
        ids = cluster_members(segmentation, spec.target)
    else:
        ids = [k for k, c in enumerate(segmentation.clusters) if c is object_points]
    return obstacle_names(segmentation, obstacles), segments(segmentation, ids)


def _clear_of_neighbours(
    out: SearchOutput,
    prep: Prepared,
    g: GripperModel,
    spheres: FingerSpheres | None,
    top_k: int,
) -> SearchOutput:
    """``out`` with every feasible candidate that has a neighbour's points in a
    finger's closing path (:func:`wsgrasp.neighbours.blocked_in_closing`: the
    finger reaches them no later than the target) rejected as
    ``obstacle_collision``, the best of the rest chosen; ``prep.blocked_by``
    counts, per neighbour, the candidates its points rejected in the body
    superellipsoids (the search's own obstacle test) and in the closing paths."""

    from wsgrasp.neighbours import blocked_by_body, blocked_in_closing
    from wsgrasp.planning.result import REASONS, Alternative

    if not prep.obstacles:
        return out
    t0 = time.perf_counter()
    names = prep.obstacle_names
    code = REASONS.index("obstacle_collision")
    cands = out.candidates
    tally = {n: {"body": 0, "closing": 0} for n in names}
    body = blocked_by_body(g, cands.ee_at(cands.reason == code), prep.obstacles)
    for k, n in zip(*np.unique(body[body >= 0], return_counts=True), strict=True):
        tally[names[k]]["body"] += int(n)
    feasible = np.flatnonzero(cands.reason == 0)
    closing = blocked_in_closing(
        g,
        cands.ee_at(feasible),
        prep.obstacles,
        prep.search_input.object_points,
    )
    blocked = feasible[closing >= 0]
    for k, n in zip(*np.unique(closing[closing >= 0], return_counts=True), strict=True):
        tally[names[k]]["closing"] += int(n)
    prep.blocked_by = {n: v for n, v in tally.items() if v["body"] or v["closing"]}
    if len(blocked):
        reason = cands.reason.copy()
        score = cands.score.copy()
        terms = {k: v.copy() for k, v in cands.terms.items()}
        reason[blocked] = code
        score[blocked] = np.nan
        for v in terms.values():
            v[blocked] = np.nan
        c = cands.replaced(reason=reason, score=score, terms=terms)
        out = replace(out, candidates=c)
        kept = np.flatnonzero(reason == 0)
        order = kept[np.argsort(-score[kept], kind="stable")]  # best first
        if out.best is not None and reason[out.best] == 0:
            # the same choice; the alternatives ranked after it, none blocked
            rank = int(np.flatnonzero(order == out.best)[0])
            alternatives = [
                Alternative(
                    index=int(j),
                    T_world_ee=c.ee_at(j),
                    score=float(score[j]),
                    terms={k: float(v[j]) for k, v in terms.items()},
                )
                for j in order[rank + 1 : rank + 1 + top_k]
            ]
            out = replace(out, alternatives=alternatives)
        elif len(order):
            out = _choose(
                replace(out, best=None),
                int(order[0]),
                g,
                prep.search_input,
                spheres,
                top_k,
            )
        else:
            out = _choose(out, None, g, prep.search_input, spheres, top_k)
    ms = (time.perf_counter() - t0) * 1e3
    return replace(out, timing_ms={**out.timing_ms, "neighbours": ms})


#: an approach within this angle (degrees) of straight down comes from above
_ABOVE_DEG = 45.0


def _from_above(prep: Prepared) -> bool:
    """Whether some candidate orientation approaches from above the table
    (within :data:`_ABOVE_DEG` of straight down onto it)."""
    inp = prep.search_input
    approach = inp.orientations.R_object_gwc[:, :, 2] @ inp.T_world_object[:3, :3].T
    up = inp.table.T_world_table[:3, 2]
    return bool((approach @ up < -np.cos(np.deg2rad(_ABOVE_DEG))).any())


def _blockers(blocked_by: dict[str, dict[str, int]]) -> str:
    """The neighbours that blocked candidates, most first, in one clause."""
    rows = sorted(blocked_by.items(), key=lambda kv: -sum(kv[1].values()))
    parts = [
        f"{name} ({v['body']} by the gripper's body, {v['closing']} in the "
        "fingers' closing paths)"
        for name, v in rows
    ]
    return "candidates blocked by neighbours: " + ", ".join(parts)


def _siblings(prep: Prepared) -> str:
    """Where neighbours split from the target's own cluster blocked candidates:
    the clause that says how to plan on them as one object."""
    segs = prep.segments
    target = [s["id"] for s in segs if s["target"]]
    if not target:
        return ""
    group = {s["cluster"] for s in segs if s["target"]}
    near = [
        s["id"]
        for s in segs
        if not s["target"]
        and s["cluster"] in group
        and f"object {s['id']}" in prep.blocked_by
    ]
    if not near:
        return ""
    names = ", ".join(f"object {k}" for k in near)
    return (
        f"; {names} and the target were split from one cluster: if they are one "
        "object (split at a concave seam of its own), plan on them together with "
        f"`target: {{rule: cluster, id: {target[0]}}}`"
    )


def _accepts(method: Any, name: str) -> bool:
    """Whether a callable takes keyword ``name`` (or any keyword)."""
    import inspect

    try:
        params = inspect.signature(method).parameters.values()
    except (TypeError, ValueError):
        return False
    return any(
        p.name == name or p.kind is inspect.Parameter.VAR_KEYWORD for p in params
    )


def _check_table_side(
    table: Plane, object_points: Array, viewpoints: Array, spec: PipelineSpec
) -> None:
    """The table's upper side from the data: the cameras look at it from above,
    and the object stands on it. A plane the data puts the other way round is
    refused, not planned on."""
    n = np.asarray(table.normal, dtype=np.float64)
    if n.shape != (3,) or not np.isfinite(n).all() or not np.isfinite(table.offset):
        raise PluginError(
            f"segmenter {spec.segmenter.name!r} returned a table plane that is not "
            f"finite (normal {n.tolist()}, offset {table.offset})",
            hint="report it to the plugin's authors",
        )
    if abs(float(np.linalg.norm(n)) - 1.0) > 1e-6:
        raise PluginError(
            f"segmenter {spec.segmenter.name!r} returned a table normal of length "
            f"{float(np.linalg.norm(n)):.6g}, expected a unit vector",
            hint="report it to the plugin's authors",
        )
    if len(viewpoints):
        h = table.signed_distance(viewpoints)
        if (h < 0.0).any():
            below = int((h < 0.0).sum())
            raise InputError(
                f"{below} of {len(h)} cameras look at the table plane from below "
                f"(heights {', '.join(f'{x:.3f}' for x in h)} m), so what stands on "
                "it is under the table: no object above the table",
                hint="check the views' T_world_camera poses, or that the object is "
                "in view on the table",
            )
    heights = table.signed_distance(object_points)
    if not len(heights) or float(np.median(heights)) <= 0.0:
        raise InputError(
            "no object above the table: the object the segmenter chose lies below "
            "the table plane",
            hint="check that the object is in view and on the table",
        )
    low = float(np.quantile(heights, _THROUGH_SHARE))
    if low < -_THROUGH_TABLE:
        deepest = -float(heights.min())
        raise InputError(
            "no object above the table: the object the segmenter chose reaches "
            f"{deepest:.3f} m below the table plane ({_THROUGH_SHARE:.0%} of its "
            f"points {-low:.3f} m or more), so it does not stand on it",
            hint="check that the object is in view and on the table, and the "
            "segmenter's options (ransac_dbscan: a cluster_eps over twice "
            "min_height joins what lies under the table to what stands on it)",
        )


#: an object whose lowest ``_THROUGH_SHARE`` of points reach more than
#: ``_THROUGH_TABLE`` (m) below the table plane does not stand on it
_THROUGH_SHARE = 0.05
_THROUGH_TABLE = 0.01


def _one_object(
    segmentation: Any, object_points: Array, obstacles: list[Array], spec: PipelineSpec
) -> tuple[Array, list[Array]]:
    """The target cluster when it is one object. When it is clearly two that
    touch, a ``nearest`` or ``inside_box`` rule picks one of them (the other
    becomes an obstacle); the other rules cannot, and the user is told how."""

    from wsgrasp.perception.process import select_target
    from wsgrasp.perception.touching import find_touching, split_touching

    if spec.target.rule == "cluster":  # planned as one object on purpose
        return object_points, obstacles
    touching = find_touching(object_points, segmentation.table)
    if touching is None:
        return object_points, obstacles
    if spec.target.rule in ("nearest", "inside_box"):
        parts = split_touching(object_points, touching)
        rest = [c for c in segmentation.clusters if c is not object_points]
        return select_target(replace(segmentation, clusters=parts + rest), spec.target)
    where = "; ".join(
        f"one {w * 100:.0f} cm wide with its top at "
        f"[{', '.join(f'{x:.3f}' for x in c)}]"
        for c, w in zip(touching.centers, touching.widths, strict=True)
    )
    c = touching.centers[0]
    raise InputError(
        f"the object cluster is two objects that touch ({where}; they meet "
        f"{touching.neck * 100:.1f} cm wide)",
        hint="pick one with `target: {rule: nearest, point: "
        f"[{', '.join(f'{x:.3f}' for x in c)}]}}` (or rule inside_box with box_min "
        "and box_max around it), or move them apart",
    )


#: an object no wider than the gripper encloses plus this (m; noise on the
#: measured width) may fit between the fingers
_WIDTH_SLACK = 0.002
#: the noise widens an object's cloud by about this many deviations of its
#: depth noise on each side (the extremes of a few hundred points along a
#: direction): a 5 cm box seen with 12 mm of noise measured 8.5 cm across
_WIDTH_NOISE_DEVIATIONS = 3.0
#: far more (m) than rounding moves a width measured over different points
_WIDTH_ROUNDING = 1e-9
#: points deeper than this (m) inside the object's convex hull, beyond what
#: the surface noise puts there, are a concavity (a mug's inside, the gap under
#: a handle) the fingers may hold a wall of
_CONCAVE_DEPTH = 0.01
#: fraction of points deeper than that which makes an object hollow
_CONCAVE_SHARE = 0.02
#: fraction of its outline's hull (seen from above) that must lie that deep in
#: empty space for an object to be concave seen from above
_OUTLINE_SHARE = 0.1
#: the outline's hull is sampled on a grid of at most this many cells a side
_OUTLINE_CELLS = 100
#: the hull of a noisy convex cloud lies up to about 4 noise deviations outside
#: its surface; a concavity must reach this many deviations deeper as well
_NOISE_DEVIATIONS = 5.0
#: the depth noise is measured on the table points within this (m) of its plane
#: ...
_NOISE_BAND = 0.03
#: ... this far (m) or farther from the object's footprint ...
_NOISE_CLEARANCE = 0.02
#: ... on at most this many of them (evenly spaced in the cloud)
_NOISE_POINTS = 4000


def _too_large(
    object_points: Array,
    g: GripperModel,
    closing: Array | None = None,
    noise: float | Callable[[], float] = 0.0,
    up: Array | None = None,
) -> str:
    """Why no pose can hold the object, or ``""``: a convex object wider than the
    gripper encloses (:attr:`GripperModel.enclosure`) along every direction
    ``closing`` ``(k, 3)`` that a candidate's fingers close along (every
    direction, when None) cannot be spanned by any candidate. A concave one may
    still be held by a part narrower than the whole (a wall, a handle), so it is
    left to the search: concave in space (a mug's inside), or, seen from above
    along the table's normal ``up`` ``(3,)``, in its footprint (a hammer lying
    flat, whose handle lies deep inside its outline's hull, but never farther
    than half its thickness from the top or the bottom of its hull in space);
    concave means deeper than the depth ``noise`` (m; or a function that
    measures it, called only for an object that is wide enough to ask) makes a
    convex cloud look; and wide means wider than that noise makes a narrower
    object look (:data:`_WIDTH_NOISE_DEVIATIONS` on each side)."""
    from scipy.spatial import ConvexHull, QhullError

    enclosure = g.enclosure
    if len(object_points) < 4 or enclosure <= 0.0:
        return ""
    if closing is not None:
        directions = np.unique(np.round(np.asarray(closing, np.float64), 9), axis=0)
        if not len(directions):
            return ""
        # the hull's vertices are some of the points, so its width along a
        # direction is at most theirs: an object this narrow fits, and its hull
        # (0.3-0.5 ms on 800 points) is not needed
        proj = directions @ object_points.T  # (k, n)
        narrowest = float((proj.max(axis=1) - proj.min(axis=1)).min())
        if narrowest + _WIDTH_ROUNDING <= enclosure + _WIDTH_SLACK:
            return ""
    try:
        hull = ConvexHull(object_points)
    except QhullError:  # flat or degenerate: the search decides
        return ""
    vertices = object_points[hull.vertices]  # (h, 3)
    if closing is None:
        directions = hull.equations[:, :3]  # (facets, 3)
    proj = directions @ vertices.T  # (k, h)
    width = float((proj.max(axis=1) - proj.min(axis=1)).min())
    if width <= enclosure + _WIDTH_SLACK:
        return ""
    sigma = noise() if callable(noise) else float(noise)
    if width - 2.0 * _WIDTH_NOISE_DEVIATIONS * sigma <= enclosure + _WIDTH_SLACK:
        return ""  # as wide as the noise makes a narrower object look
    deep = _CONCAVE_DEPTH + _NOISE_DEVIATIONS * sigma
    if _concave_share(object_points, hull.equations, deep) >= _CONCAVE_SHARE:
        return ""
    if up is not None and _concave_outline(object_points, up, deep):
        return ""
    along = (
        "in every direction"
        if closing is None
        else f"along each of the {len(directions)} directions its fingers close along"
    )
    return (
        f"object is too large for {g.name}: it is {width:.3f} m across at its "
        f"narrowest {along}, and its fingers' workspaces span at most "
        f"{enclosure:.3f} m"
    )


def _concave_outline(points: Array, up: Array, deep: float) -> bool:
    """Whether the object's outline seen along ``up`` ``(3,)`` (its points
    ``(n, 3)`` projected on the table) leaves ``_OUTLINE_SHARE`` of its convex
    hull's area empty farther than ``deep`` (m) from every point, beyond the
    points' own spacing (their median distance to their nearest neighbour on
    the surface, which the projection of a sparse cloud of a convex object
    leaves empty between them at most; the projection's own spacing is far
    smaller along a side face seen edge-on): the area between a hammer's
    handle and its head's ends."""
    from scipy.spatial import ConvexHull, QhullError, cKDTree

    uv = points @ plane_basis(np.asarray(up, np.float64))  # (n, 2)
    try:
        hull = ConvexHull(uv)
    except QhullError:  # a line seen from above
        return False
    spacing = float(np.median(cKDTree(points).query(points, k=2)[0][:, 1]))
    reach = deep + spacing
    tree = cKDTree(uv)
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    cell = max(reach / 4.0, float(np.max(hi - lo)) / _OUTLINE_CELLS)
    axes = [np.arange(lo[k] + cell / 2.0, hi[k], cell) for k in range(2)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 2)
    inside = (grid @ hull.equations[:, :2].T + hull.equations[:, 2] <= 0.0).all(axis=1)
    if not inside.any():
        return False
    far = tree.query(grid[inside], distance_upper_bound=reach)[0] > reach  # inf: far
    return float(np.mean(far)) >= _OUTLINE_SHARE


def _concave_share(points: Array, equations: Array, deep: float) -> float:
    """The fraction of ``points`` ``(n, d)`` deeper than ``deep`` (m) inside the
    convex hull whose facets are ``equations`` ``(f, d + 1)`` (qhull's: unit
    outward normals and offsets)."""
    depth = -(points @ equations[:, :-1].T + equations[:, -1]).max(axis=1)  # (n,)
    return float(np.mean(depth > deep))


def _depth_noise(points: Array, table: Plane, object_points: Array) -> float:
    """The scene's depth noise (m), measured where the truth is known: the
    robust deviation (1.4826 median absolute deviations) of the heights of the
    table's points (``points`` ``(n, 3)`` within ``_NOISE_BAND`` of the plane
    ``table``, ``_NOISE_CLEARANCE`` or farther from the object's footprint);
    0 with fewer than 30 such points."""
    step = max(1, len(points) // (4 * _NOISE_POINTS))
    p = points[::step]  # (m, 3) evenly spaced
    h = table.signed_distance(p)  # (m,)
    near = np.abs(h) < _NOISE_BAND
    outline = Footprint.from_points(
        table.normal, table.offset, object_points
    )  # the object's footprint on the table
    h = h[near][outline.depths(p[near]) < -_NOISE_CLEARANCE][:_NOISE_POINTS]
    if len(h) < 30:
        return 0.0
    return float(1.4826 * np.median(np.abs(h - np.median(h))))


def _hits_table(g: GripperModel, table: TableSE, T_world_gripper: Array) -> bool:
    from wsgrasp.planning.poses import StructuredPoses
    from wsgrasp.planning.table import table_verdicts

    poses = StructuredPoses.of_transforms(np.asarray(T_world_gripper)[None])
    return bool(table_verdicts(poses, g, table).hit[0])


#: a gripper point this far (m) below the table plane, over the table, is under it
_UNDER_TABLE = 0.01


def _under_table(
    g: GripperModel,
    footprint: Footprint | None,
    T_world_gripper: Array,
    distance: float | None = None,
) -> bool:
    """Whether the gripper at ``T_world_gripper`` (and, given the approach
    ``distance``, at its pre-grasp pose too) reaches under the table: a point of
    its cloud more than ``_UNDER_TABLE`` below the table plane, inside the
    table's outline. The table's superellipsoid covers a patch of the table
    around the object, ``semi_axes[2]`` deep; this covers the whole table, at
    any depth."""
    if footprint is None:
        return False
    poses = [np.asarray(T_world_gripper, dtype=np.float64)]
    if distance is not None:
        poses.append(pregrasp_pose(g, poses[0], distance))
    for T in poses:
        p = g.cloud @ T[:3, :3].T + T[:3, 3]  # (ng, 3) world
        below = footprint.heights(p) < -_UNDER_TABLE
        if below.any() and (footprint.depths(p[below]) > 0.0).any():
            return True
    return False


#: a hand closing to its ``closed`` posture grasps when this many of its fingers
#: (all of them, where it has fewer) reach the object on the way: with fewer,
#: the vendor Allegro URDF's chosen grasps held 0 of 22 objects on random:000-059
#: (lift), with two 5 of 21, with three 8 of 12; a Shadow hand whose thumb
#: closes beside the object holds it with four fingers against the palm
CLOSING_FINGERS = 3
#: candidates whose closing is tested at once (:func:`_closing_reaches`)
_CLOSING_CHUNK = 64


def _closing_reaches(g: GripperModel, T: Array, points: Array) -> NDArray[np.bool_]:
    """Per gripper pose ``(m, 4, 4)``: whether at least :data:`CLOSING_FINGERS`
    of its fingers (all, where there are fewer) reach one of the object
    ``points`` ``(n, 3)`` as they close from the pre-grasp posture to the closed
    one (their sweeps: :func:`wsgrasp.planning.sweeps.reach_steps`). A finger
    whose workspace spheres hold object points may still close beside them:
    the spheres cover every posture of its joints, the closing only the line
    between two. True throughout for a model without finger sweeps."""
    from wsgrasp.planning.sweeps import reach_steps, sweep_steps

    T = np.asarray(T, dtype=np.float64).reshape(-1, 4, 4)
    if not (g.has_sweeps or g.has_configurations) or not g.num_fingers:
        return np.ones(len(T), dtype=bool)
    need = min(g.num_fingers, CLOSING_FINGERS)
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    # the points in each pose's gripper axes: R^T (p - t)
    local = np.einsum("mji,mnj->mni", T[:, :3, :3], p[None] - T[:, None, :3, 3])
    steps = reach_steps(g, local.reshape(-1, 3)).reshape(len(T), len(p), -1)
    reached = steps.min(axis=1) < sweep_steps(g)  # (m, nf)
    return reached.sum(axis=1) >= need  # type: ignore[no-any-return]


def _with_clear_pregrasp(
    out: SearchOutput,
    g: GripperModel,
    inp: SearchInput,
    spheres: FingerSpheres | None,
    distance: float,
    footprint: Footprint | None = None,
    *,
    closing: bool = False,
) -> tuple[int | None, tuple[Array, NDArray[np.bool_] | None] | None]:
    """The best candidate whose pre-grasp pose is clear of the table too, and
    neither it nor its pre-grasp pose under the table (:func:`_under_table`):
    the chosen one, else the first alternative that is (at its pose as it would
    be taken, backed off from the table), else None; with an alternative, its
    pose as taken (:func:`_taken_pose`), for :func:`_choose`.

    With ``closing`` (a hand that closes to its ``closed`` posture), the
    candidate must also close on the object (:func:`_closing_reaches`), and
    every feasible candidate is tried in score order, not the alternatives
    alone."""

    def clear(T: Array) -> bool:
        pregrasp = pregrasp_pose(g, T, distance)
        if _hits_table(g, inp.table, pregrasp) or _under_table(
            g, footprint, T, distance
        ):
            return False
        return not closing or bool(_closing_reaches(g, T[None], inp.object_points)[0])

    if out.best is None:
        return None, None
    if clear(out.candidates.ee_at(out.best)):
        return out.best, None
    if closing:
        c = out.candidates
        feasible = np.flatnonzero(c.feasible & (np.arange(len(c.score)) != out.best))
        order = feasible[np.argsort(-c.score[feasible], kind="stable")]
    else:
        order = np.array([a.index for a in out.alternatives], dtype=np.int64)
    for lo in range(0, len(order), _CLOSING_CHUNK):
        chunk = order[lo : lo + _CLOSING_CHUNK]
        if closing:  # at the poses as generated, first: most fail here
            T = out.candidates.ee_at(chunk)
            chunk = chunk[_closing_reaches(g, T, inp.object_points)]
        for i in chunk:
            if _under_table(g, footprint, out.candidates.ee_at(i), distance):
                continue  # backing off from the table's surface cannot lift it out
            taken = _taken_pose(out, int(i), g, inp, spheres)
            if clear(taken[0]):
                return int(i), taken
    return None, None


def _no_grasp(
    prep: Prepared,
    out: SearchOutput,
    hist: dict[str, int],
    g: GripperModel,
    distance: float,
    closing: bool = False,
) -> str:
    """Why a plan has no grasp, in one sentence a user can act on (``closing``:
    the hand closes to its ``closed`` posture)."""
    if prep.too_large:
        return prep.too_large
    feasible = np.flatnonzero(out.candidates.feasible)
    if len(feasible):
        top = feasible[int(np.argmax(out.candidates.score[feasible]))]
        T_top = out.candidates.ee_at(top)
        if _under_table(g, prep.table_footprint, T_top, distance):
            return (
                "every feasible grasp, or its pre-grasp pose, lies under the table; "
                "check that the segmentation kept the object above the table"
            )
        if closing and not _hits_table(
            g, prep.search_input.table, pregrasp_pose(g, T_top, distance)
        ):
            need = min(g.num_fingers, CLOSING_FINGERS)
            return (
                f"every feasible grasp closes beside the object: fewer than {need} "
                "of the fingers reach it on the way from the pre-grasp to "
                "the closed posture, though their workspaces hold object points; "
                "set approach.close_to: contacts (each finger closes to where it "
                "holds the object), or sample more depths and orientations"
            )
        return (
            f"every feasible grasp's pre-grasp pose, {distance:g} m back along its "
            "approach, hits the table; lower approach.distance"
        )
    inp = prep.search_input
    swept = hist.get("finger_sweeps_table", 0)
    if swept:
        # the last check: every candidate the search found feasible failed it
        from wsgrasp.planning.closing import BACK_OFF_STEPS

        return (
            f"at every pose that holds the object ({swept} of {sum(hist.values())} "
            "poses) the fingers would sweep through the table before reaching it, "
            f"even backed off {BACK_OFF_STEPS[-1] * 100:g} cm along the approach; "
            "the object is too low for these fingers to close round it from "
            "there: sample more approach directions from the side, or more "
            "points along the object"
        )
    heights = prep.table_plane.signed_distance(inp.object_points)
    width = narrowest_width(inp.object_points, prep.table_plane.normal)
    return no_grasp_hint(hist, inp.extents, g, float(heights.max()), width)


#: a top part of the target at least this tall (m) that fits between the
#: fingers may be an object standing on another
_TOP_PART_HEIGHT = 0.02
#: the heights (m) the target is cut at to find that part lie this far apart
_TOP_PART_STEP = 0.005
#: another cluster with fewer points is no object to suggest
_SUGGESTED_POINTS = 20


def _what_fits(prep: Prepared, g: GripperModel) -> str:
    """What in the scene would fit between the fingers of a plan without a
    grasp, and the spec that plans for it (``""`` when nothing does): other
    objects on the table (the one a ``nearest`` rule picks at their centroid:
    the target rule may have picked what is no object to grasp, a robot's arm
    hanging low over the table); else, where the target is wider than the
    gripper encloses seen from above, its own top part, which may be an object
    standing on another (a box on a plate, a book or a tray) that the
    ``clutter`` segmenter splits off."""
    from wsgrasp.perception.pile import UNSEGMENTED

    points = prep.search_input.object_points
    up = np.asarray(prep.table_plane.normal, dtype=np.float64)
    fits = g.enclosure + _WIDTH_SLACK
    if g.enclosure <= 0.0 or len(points) < 4:
        return ""
    others = []
    for name, cloud in zip(prep.obstacle_names, prep.obstacles, strict=False):
        if name == UNSEGMENTED or len(cloud) < _SUGGESTED_POINTS:
            continue
        width = narrowest_width(cloud, up)
        if 0.0 < width <= fits:
            others.append((width, cloud.mean(axis=0)))
    if others:
        width, c = others[0]
        at = ", ".join(f"{x:.3f}" for x in c)
        more = f" ({len(others)} such objects)" if len(others) > 1 else ""
        return (
            f"; another object on the table fits between the fingers{more}: the "
            f"one {width * 100:.1f} cm across at [{at}] is planned for with "
            f"`target: {{rule: nearest, point: [{at}]}}`"
        )
    if narrowest_width(points, up) <= fits:
        return ""
    heights = prep.table_plane.signed_distance(points)
    levels = np.arange(_TOP_PART_STEP, heights.max() - _TOP_PART_HEIGHT, _TOP_PART_STEP)
    # the part above a higher cut is a subset, never wider: the lowest cut
    # whose part fits, by bisection (a part of fewer points is too few to name)
    lo, hi = 0, len(levels)
    while lo < hi:
        mid = (lo + hi) // 2
        if narrowest_width(points[heights > levels[mid]], up) <= fits:
            hi = mid
        else:
            lo = mid + 1
    if lo == len(levels):
        return ""
    top = points[heights > levels[lo]]
    if len(top) < _SUGGESTED_POINTS:
        return ""
    at = ", ".join(f"{x:.3f}" for x in top.mean(axis=0))
    return (
        f"; its top {(heights.max() - levels[lo]) * 100:.0f} cm "
        f"({narrowest_width(top, up) * 100:.1f} cm across, at [{at}]) fits between "
        "the fingers: if that is an object standing on another (on a plate, a "
        "book, a tray), the clutter segmenter plans for it alone: `segmenter: "
        "{name: clutter}` with `target: {rule: highest}`"
    )


def _taken(out: SearchOutput, index: int) -> int:
    """``index`` checked as a candidate a plan can take: it exists and is feasible."""
    from wsgrasp.planning.result import REASONS

    n = len(out.candidates)
    if not 0 <= index < n:
        raise InputError(
            f"candidate {index} does not exist: this plan has {n} candidates "
            f"(0 to {n - 1})",
            hint="choose an index from a plan's alternatives on the same scene "
            "with the same spec",
        )
    reason = int(out.candidates.reason[index])
    if reason != 0:
        raise InputError(
            f"candidate {index} was rejected ({REASONS[reason]}); only a feasible "
            "candidate can be taken",
            hint="choose an index from the plan's alternatives or from "
            "result.candidates.feasible",
        )
    return int(index)


def _taken_pose(
    out: SearchOutput,
    index: int,
    g: GripperModel,
    inp: SearchInput,
    spheres: FingerSpheres | None,
) -> tuple[Array, NDArray[np.bool_] | None]:
    """Candidate ``index``'s pose as a plan takes it, with what its fingers hold
    there: backed off along its approach where its fingers would sweep through
    the table before reaching the object (:func:`_sweeps_cleared` kept only the
    candidates for which that backed-off pose passes every check), as the
    search's best (whose pose the candidate set already holds as moved; None
    for its holdings then)."""
    from wsgrasp.planning.evaluate import evaluate_candidates
    from wsgrasp.planning.sweeps import sweep_back_offs

    T = out.candidates.ee_at(index)
    if index == out.best:
        return T, None
    d = float(
        sweep_back_offs(g, T[None], inp.table.T_world_table, inp.object_points)[0]
    )
    if d > 0.0:
        T = pregrasp_pose(g, T, d)
    ev = evaluate_candidates(
        T[None], g, inp.object_points, inp.obstacle_points, inp.table, spheres
    )
    return T, ev.holding[0]


def _sweeps_cleared(
    out: SearchOutput,
    g: GripperModel,
    inp: SearchInput,
    spheres: FingerSpheres | None,
    top_k: int,
) -> SearchOutput:
    """``out`` with the fingers' closing sweeps kept out of the table.

    Every feasible candidate, at its pose as generated, gets the least back-off
    along its approach that keeps its fingers' sweeps above the table until
    they reach the object (:func:`~wsgrasp.planning.sweeps.sweep_back_offs`);
    one that no back-off clears, or whose backed-off pose fails a check of the
    search (its fingers no longer hold the object, say), is rejected as
    ``finger_sweeps_table``. The best of the rest is the choice, at its pose
    backed off (the candidate set holds it so); the others stay as generated
    and are backed off when taken (:func:`_taken_pose`). Where nothing is
    rejected and the search's own choice needs no back-off, ``out`` is
    returned as it is; else its candidate
    arrays are updated in place (the search's own, which nothing else holds:
    copies of the two (C, 4, 4) pose arrays took a third of this step on the
    Allegro hand's dense search).
    """

    from wsgrasp.planning.evaluate import evaluate_candidates
    from wsgrasp.planning.result import REASONS, Alternative
    from wsgrasp.planning.search import _contacts
    from wsgrasp.planning.sweeps import sweep_back_offs

    t0 = time.perf_counter()
    cands = out.candidates
    feasible = np.flatnonzero(cands.reason == 0)  # (F,)
    if not len(feasible):
        return out
    best = out.best
    # the candidates of one orientation share their rotation
    groups = cands.orientation[feasible] if cands.orientation is not None else None
    R_t = cands.poses()[0].split(feasible, groups)  # no (F, 4, 4) poses
    d = sweep_back_offs(g, R_t, inp.table.T_world_table, inp.object_points)
    rejected = np.isnan(d)
    moved = np.flatnonzero(d > 0.0)
    T_moved = cands.ee_at(feasible[moved])  # (m, 4, 4) a copy
    T_moved[:, :3, 3] -= d[moved, None] * (T_moved[:, :3, :3] @ g.approach_axis)
    if len(moved):
        ev = evaluate_candidates(
            T_moved, g, inp.object_points, inp.obstacle_points, inp.table, spheres
        )
        rejected[moved[ev.reason != 0]] = True

    def taken(i: int) -> Array:
        """Feasible candidate ``i``'s pose as a plan takes it: (4, 4)."""
        if d[i] > 0.0:
            return T_moved[np.searchsorted(moved, i)]  # type: ignore[no-any-return]
        return cands.ee_at(feasible[i])

    kept = feasible[~rejected]
    score = cands.score
    order = kept[np.argsort(-score[kept], kind="stable")]  # best first
    new_best = int(order[0]) if len(order) else None
    if new_best == best and not rejected.any():
        assert best is not None
        i = int(np.searchsorted(feasible, best))
        if np.array_equal(taken(i), cands.ee_at(best)):
            ms = (time.perf_counter() - t0) * 1e3
            return replace(out, timing_ms={**out.timing_ms, "sweeps": ms})
    reason, terms = cands.reason, cands.terms
    reason[feasible[rejected]] = REASONS.index("finger_sweeps_table")
    score[feasible[rejected]] = np.nan
    for v in terms.values():
        v[feasible[rejected]] = np.nan
    contacts = []
    score_terms: dict[str, float] = {}
    alternatives = []
    if new_best is not None:
        i = int(np.searchsorted(feasible, new_best))
        T_best = taken(i)
        if d[i] > 0.0:  # moved back: the candidate set holds the choice as taken
            cands.set_pose(new_best, T_best, T_best @ g.T_gripper_gwc)
        ev = evaluate_candidates(
            T_best[None], g, inp.object_points, inp.obstacle_points, inp.table, spheres
        )
        contacts = _contacts(g, T_best, inp.object_points, ev.holding[0])
        score_terms = {k: float(v[new_best]) for k, v in terms.items()}
        alternatives = [
            Alternative(
                index=int(j),
                T_world_ee=cands.ee_at(j),
                score=float(score[j]),
                terms={k: float(v[j]) for k, v in terms.items()},
            )
            for j in order[1 : top_k + 1]
        ]
    candidates = cands.replaced(reason=reason, score=score, terms=terms)
    return replace(
        out,
        candidates=candidates,
        best=new_best,
        alternatives=alternatives,
        contacts=contacts,
        score_terms=score_terms,
        timing_ms={**out.timing_ms, "sweeps": (time.perf_counter() - t0) * 1e3},
    )


def _choose(
    out: SearchOutput,
    index: int | None,
    g: GripperModel,
    inp: SearchInput,
    spheres: FingerSpheres | None,
    top_k: int,
    taken: tuple[Array, NDArray[np.bool_] | None] | None = None,
) -> SearchOutput:
    """``out`` with feasible candidate ``index`` chosen instead: its pose as
    taken (:func:`_taken_pose`, unless ``taken`` gives it already; in a copy of
    the candidate set, as the search writes its best's into its own), its
    contacts, its score terms, and the ``top_k`` candidates ranked after it as
    the alternatives."""

    from wsgrasp.planning.result import Alternative
    from wsgrasp.planning.search import _contacts

    if index is None:
        return replace(out, best=None, alternatives=[], contacts=[], score_terms={})
    if index == out.best:
        return out
    T, holding = taken or _taken_pose(out, index, g, inp, spheres)
    assert holding is not None
    # a new candidate set: the searched one may be recorded already, as it was
    ee, gwc = out.candidates.poses()
    c = out.candidates.replaced(T_world_ee=ee.copy(), T_world_gwc=gwc.copy())
    c.set_pose(index, T, T @ g.T_gripper_gwc)
    feasible = np.flatnonzero(c.reason == 0)
    order = feasible[np.argsort(-c.score[feasible], kind="stable")]
    rank = int(np.flatnonzero(order == index)[0])
    alternatives = [
        Alternative(
            index=int(j),
            T_world_ee=c.ee_at(j),
            score=float(c.score[j]),
            terms={k: float(v[j]) for k, v in c.terms.items()},
        )
        for j in order[rank + 1 : rank + 1 + top_k]
    ]
    return replace(
        out,
        candidates=c,
        best=int(index),
        alternatives=alternatives,
        contacts=_contacts(g, T, inp.object_points, holding),
        score_terms={k: float(v[index]) for k, v in c.terms.items()},
    )


def _guard_table(
    g: GripperModel,
    table: TableSE,
    footprint: Footprint | None,
    T_world_gripper: Array,
    T_world_pregrasp: Array,
) -> None:
    """The last check of every plan: neither the grasp nor the pre-grasp pose
    enters the table or reaches under it. The search and the choice exclude
    both, so a violation here is a bug, raised as one."""
    for label, T in (("grasp", T_world_gripper), ("pre-grasp", T_world_pregrasp)):
        if _hits_table(g, table, T):
            raise AssertionError(
                f"the chosen {label} pose enters the table; the search should have "
                "rejected it"
            )
        if _under_table(g, footprint, T):
            raise AssertionError(
                f"the chosen {label} pose reaches under the table; the choice should "
                "have passed it over"
            )


def _normals(
    points: Array, centroid: Array, rows: NDArray[np.int64] | None = None
) -> Array:
    """Unit normals of the object points ``(n, 3)`` (of the points ``rows``
    alone, ``(r, 3)``, if given), pointing away from the object's centroid."""
    from wsgrasp.perception.frame import estimate_normals

    n = estimate_normals(points, rows=rows)
    p = points if rows is None else points[rows]
    flip = np.einsum("ij,ij->i", p - centroid, n) < 0.0
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
