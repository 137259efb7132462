"""Observers the planner reports each stage to (the MCAP recorder is one).

``planning`` never imports ``record``: a run without observers pays nothing.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    from wsgrasp.gripper.model import GripperModel
    from wsgrasp.perception.types import Scene
    from wsgrasp.planning.result import PlanResult
    from wsgrasp.spec import PipelineSpec

__all__ = ["PlanObserver", "STAGES"]

#: Stages reported through ``on_stage``, in order, with the keys of their data:
#: - ``preprocess``: ``points`` (n, 3) downsampled scene, world frame
#: - ``segmentation``: ``table_normal`` (3,), ``table_offset`` float,
#:   ``table_points`` (m, 3), ``object_points`` (no, 3), ``obstacles`` list of (k, 3)
#: - ``object_frame``: ``T_world_object`` (4, 4), ``extents`` (3,),
#:   ``samples_world`` (ns, 3), ``T_world_table`` (4, 4)
#: - ``fallback``, only where the spec's sampling found no grasp and
#:   ``sampling.fallback`` was searched: ``first_search`` (the first search's
#:   rejections), ``samples_world`` (ns, 3), ``R_world_gwc`` (O, 3, 3)
#: - ``candidates``: ``candidates`` (CandidateSet)
STAGES = ("preprocess", "segmentation", "object_frame", "fallback", "candidates")


class PlanObserver(Protocol):
    """Receives a plan's inputs, each stage's data and the result."""

    def on_start(self, spec: PipelineSpec, gripper: GripperModel, scene: Scene) -> None:
        """Before any processing: the resolved spec, gripper model and inputs."""

    def on_stage(self, stage: str, data: dict[str, Any]) -> None:
        """After each stage in :data:`STAGES` (``fallback`` only where it ran)."""

    def on_result(self, result: PlanResult) -> None:
        """After the plan finished (grasp found or not)."""

    def on_error(self, error: BaseException) -> None:
        """When the plan stopped with an error."""
