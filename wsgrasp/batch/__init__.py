"""Scale out: many plans to Parquet (``wsgrasp batch``), grasp datasets with
simulated labels (``wsgrasp dataset``), on a local process pool or on Ray.

See :mod:`wsgrasp.batch.engine` for the engines, :mod:`wsgrasp.batch.sink` for
how rows reach Parquet and survive a crash.
"""

from __future__ import annotations

from wsgrasp.batch.dataset import DatasetSummary, dataset_schemas, run_dataset
from wsgrasp.batch.engine import (
    ENGINES,
    Engine,
    LocalEngine,
    RayEngine,
    make_engine,
    require_ray,
    shared,
)
from wsgrasp.batch.plans import (
    BatchSpec,
    BatchSummary,
    plan_row,
    plan_schema,
    run_batch,
    scene_paths,
)
from wsgrasp.batch.sink import PartSink, require_pyarrow
from wsgrasp.batch.trials import TrialSummary, run_trials, trial_schema

__all__ = [
    "ENGINES",
    "BatchSpec",
    "BatchSummary",
    "DatasetSummary",
    "Engine",
    "LocalEngine",
    "PartSink",
    "RayEngine",
    "TrialSummary",
    "dataset_schemas",
    "make_engine",
    "plan_row",
    "plan_schema",
    "require_pyarrow",
    "require_ray",
    "run_batch",
    "run_dataset",
    "run_trials",
    "scene_paths",
    "shared",
    "trial_schema",
]
