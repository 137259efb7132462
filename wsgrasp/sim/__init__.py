"""Physics grasp trials in MuJoCo: the paper's experiment, in simulation.

``wsgrasp eval`` (extra ``sim``) drops objects on a table, renders three noisy
depth views, plans a grasp on them, and executes it with the gripper built from
its URDF and YAML: approach, close, lift 20 cm, then (the ``strict`` protocol,
the default) pull the object along six directions with the grasp executed off the
plan by a seeded error, or (``lift``) hold 10 s. See :mod:`wsgrasp.sim.trial` for
the protocol, :mod:`wsgrasp.sim.params` for every physical parameter and its
source, :mod:`wsgrasp.sim.objects` for the ``paper13`` set and masses.

MuJoCo is imported only when a trial is set up; without it a ``SimulationError``
says ``pip install 'wsgrasp[sim]'``.
"""

from __future__ import annotations

from wsgrasp.sim._mujoco import require_mujoco
from wsgrasp.sim.gripper import SimGripper, load_sim_gripper, sim_gripper_from_files
from wsgrasp.sim.objects import (
    OBJECT_SETS,
    PAPER13,
    Part,
    SimObject,
    load_objects,
    object_from_mesh,
    paper13,
)
from wsgrasp.sim.params import PROTOCOLS, SimParams
from wsgrasp.sim.report import (
    PAPER_TABLE2,
    build_report,
    report_markdown,
    report_table,
)
from wsgrasp.sim.runner import EvalConfig, SpecEntry, run_eval, run_task
from wsgrasp.sim.scene import SimScene, build_scene
from wsgrasp.sim.specs import spec_entries
from wsgrasp.sim.trial import (
    OUTCOMES,
    Execution,
    ExecutionError,
    Settled,
    execute_grasp,
    execution_error,
    render_views,
    settle_object,
)

__all__ = [
    "OBJECT_SETS",
    "OUTCOMES",
    "PAPER13",
    "PAPER_TABLE2",
    "PROTOCOLS",
    "EvalConfig",
    "Execution",
    "ExecutionError",
    "Part",
    "Settled",
    "SimGripper",
    "SimObject",
    "SimParams",
    "SimScene",
    "SpecEntry",
    "build_report",
    "build_scene",
    "execute_grasp",
    "execution_error",
    "load_objects",
    "load_sim_gripper",
    "object_from_mesh",
    "paper13",
    "render_views",
    "report_markdown",
    "report_table",
    "require_mujoco",
    "run_eval",
    "run_task",
    "settle_object",
    "sim_gripper_from_files",
    "spec_entries",
]
