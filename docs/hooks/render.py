"""MkDocs hook: the reference and results pages' tables, generated at build time.

A page asks for a table with a marker on a line of its own::

    <!-- render: spec -->

and the hook replaces it with Markdown generated from the code (the pydantic
models, the registered plugins, the CLI's own help, a run recorded on a bundled
scene) or from the result files under ``docs/results/`` that runs write. An
unknown marker, or a renderer that fails, stops the build: a reference page
cannot drift from the code it documents. Charts (SVG) are drawn from the same
result files with matplotlib and added to the site as generated files.

Everything here runs offline and gives the same output for the same inputs.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

from docs_reference import (
    render_channels,
    render_cli,
    render_gripper_yaml,
    render_plugins,
    render_record_proto,
    render_record_topics,
    render_spec,
)
from docs_results import (
    chart_eval,
    chart_grippers,
    eval_files,
    render_across_narrowest_runs,
    render_allegro_closings_runs,
    render_angles_from_runs,
    render_approach_direction_runs,
    render_chart_grippers,
    render_closed_past_meet_runs,
    render_clutter_segments,
    render_contact_fingers_runs,
    render_coupled_jaws_runs,
    render_default_spec_runs,
    render_defaults_effect,
    render_defaults_success,
    render_drive_guess_runs,
    render_flying_pixels_runs,
    render_generic_scorers_runs,
    render_graze_depth_runs,
    render_jaw_drive_runs,
    render_mirror_hidden_runs,
    render_noisy_depth_runs,
    render_on_table_runs,
    render_one_camera_runs,
    render_other_descriptions_runs,
    render_pose_margin_runs,
    render_reach_down_runs,
    render_results_bench,
    render_results_clutter,
    render_results_eval,
    render_results_grippers,
    render_results_grippers_strict,
    render_results_scorers,
    render_room_views,
    render_simulator_versions_runs,
    render_thumb_drive_runs,
    render_thumb_turn_runs,
    render_tune_runs,
)

MARKER = re.compile(r"^<!-- render: ([a-z0-9-]+) -->$", re.M)

RENDERERS: dict[str, Callable[[], str]] = {
    "spec": render_spec,
    "gripper-yaml": render_gripper_yaml,
    "plugins": render_plugins,
    "cli": render_cli,
    "channels": render_channels,
    "record-topics": render_record_topics,
    "record-proto": render_record_proto,
    "results-grippers": render_results_grippers,
    "results-grippers-strict": render_results_grippers_strict,
    "chart-grippers": render_chart_grippers,
    "defaults-success": render_defaults_success,
    "defaults-effect": render_defaults_effect,
    "results-bench": render_results_bench,
    "results-eval": render_results_eval,
    "results-clutter": render_results_clutter,
    "clutter-segments": render_clutter_segments,
    "default-spec-runs": render_default_spec_runs,
    "on-table-runs": render_on_table_runs,
    "reach-down-runs": render_reach_down_runs,
    "pose-margin-runs": render_pose_margin_runs,
    "approach-direction-runs": render_approach_direction_runs,
    "generic-scorers-runs": render_generic_scorers_runs,
    "contact-fingers-runs": render_contact_fingers_runs,
    "angles-from-runs": render_angles_from_runs,
    "across-narrowest-runs": render_across_narrowest_runs,
    "noisy-depth-runs": render_noisy_depth_runs,
    "mirror-hidden-runs": render_mirror_hidden_runs,
    "simulator-versions-runs": render_simulator_versions_runs,
    "drive-guess-runs": render_drive_guess_runs,
    "thumb-drive-runs": render_thumb_drive_runs,
    "thumb-turn-runs": render_thumb_turn_runs,
    "other-descriptions-runs": render_other_descriptions_runs,
    "coupled-jaws-runs": render_coupled_jaws_runs,
    "jaw-drive-runs": render_jaw_drive_runs,
    "graze-depth-runs": render_graze_depth_runs,
    "closed-past-meet-runs": render_closed_past_meet_runs,
    "tune-runs": render_tune_runs,
    "allegro-closings-runs": render_allegro_closings_runs,
    "one-camera-runs": render_one_camera_runs,
    "flying-pixels-runs": render_flying_pixels_runs,
    "room-views": render_room_views,
    "results-scorers": render_results_scorers,
}

#: generated files: site path -> function giving its bytes (None: not made)
GENERATED: dict[str, Callable[[], bytes | None]] = {
    "results/grippers-success.svg": chart_grippers,
}


def render(markdown: str) -> str:
    """Replace every marker in ``markdown``; an unknown one raises."""

    def one(m: re.Match[str]) -> str:
        name = m.group(1)
        if name not in RENDERERS:
            raise KeyError(
                f"unknown render marker {name!r}; known: {sorted(RENDERERS)}"
            )
        return RENDERERS[name]().rstrip() + "\n"

    return MARKER.sub(one, markdown)


# --------------------------------------------------------------------------------
# MkDocs events
# --------------------------------------------------------------------------------


def on_files(files: Any, config: Any) -> Any:
    from mkdocs.structure.files import File

    for uri, make in GENERATED.items():
        data = make()
        if data is not None:
            files.append(File.generated(config, uri, content=data))
    for path in eval_files():
        uri = f"results/eval-{path.stem}.svg"
        files.append(File.generated(config, uri, content=chart_eval(path)))
    return files


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    return render(markdown)
