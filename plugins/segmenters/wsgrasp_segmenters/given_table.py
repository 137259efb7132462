"""``given_table``: the object is already segmented and the table plane is known."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from wsgrasp.errors import InputError
from wsgrasp.perception.types import Array, Plane, Segmentation

Vec3 = tuple[float, float, float]


class GivenTableOptions(BaseModel):
    """The table plane ``normal · p + offset = 0`` in the input frame."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    normal: Vec3 = Field(description="table normal (need not be unit; either sign)")
    offset: float | None = Field(None, description="plane offset (m), or give point")
    point: Vec3 | None = Field(None, description="a point on the table (m)")
    min_height: float = Field(
        0.005,
        ge=0.0,
        description="points lower than this above the table (m) are table points "
        "and are removed",
    )

    @model_validator(mode="after")
    def _plane(self) -> GivenTableOptions:
        if (self.offset is None) == (self.point is None):
            raise ValueError("give exactly one of offset or point")
        if float(np.linalg.norm(self.normal)) < 1e-9:
            raise ValueError("normal must not be zero")
        return self


class GivenTable:
    """The input is the object (optionally with some table points, which are
    removed); the table plane comes from the options. The normal is turned towards
    the object."""

    Options: ClassVar[type[BaseModel]] = GivenTableOptions

    def segment(
        self, points: Array, options: GivenTableOptions, *, seed: int
    ) -> Segmentation:
        """Remove the table points and return the rest as the one object."""
        p = np.asarray(points, dtype=np.float64)
        n = np.asarray(options.normal, dtype=np.float64)
        norm = float(np.linalg.norm(n))
        n = n / norm
        if options.point is not None:
            offset = -float(n @ np.asarray(options.point, dtype=np.float64))
        else:
            offset = float(options.offset) / norm  # type: ignore[arg-type]
        h = p @ n + offset
        # the object is where most points are far from the plane
        far = np.abs(h) > options.min_height
        if far.any() and float(np.median(h[far])) < 0.0:
            n, offset, h = -n, -offset, -h
        above = h > options.min_height
        if not above.any():
            raise InputError(
                f"given_table: none of the {p.shape[0]} points lies more than "
                f"{options.min_height:g} m above the given table plane",
                hint="check the segmenter's normal and offset/point (input frame, "
                "metres), or lower min_height",
            )
        return Segmentation(
            table=Plane(normal=n, offset=offset),
            table_points=p[np.abs(h) <= options.min_height],
            clusters=[p[above]],
            info={"removed_below": int((~above).sum())},
        )
