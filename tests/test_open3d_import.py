"""open3d as wsgrasp imports it: without plotly and dash, and still whole."""

from __future__ import annotations

import json
import subprocess
import sys

CHILD = """
import json, sys
from wsgrasp._open3d import load_open3d
o3d = load_open3d()
out = {"dash": "dash" in sys.modules, "plotly": "plotly" in sys.modules,
       "stand_in_left": "open3d.visualization.draw_plotly" in sys.modules,
       "same": load_open3d() is o3d}
import numpy as np
cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.eye(3)))
out["points"] = len(cloud.points)
viewer = o3d.visualization.draw_plotly
out["viewer"] = viewer.__name__
# the viewer's module, asked for by name, is the real one, plotly and all
fig = o3d.visualization.get_plotly_fig([cloud])
out["figure"] = type(fig).__name__
out["dash_after"] = "plotly" in sys.modules
print(json.dumps(out))
"""


def test_open3d_loads_without_its_plotly_viewer_which_still_works() -> None:
    # a fresh process: this one may have imported open3d already
    run = subprocess.run(
        [sys.executable, "-c", CHILD], capture_output=True, text=True, check=True
    )
    out = json.loads(run.stdout.strip().splitlines()[-1])
    assert out == {
        "dash": False,
        "plotly": False,
        "stand_in_left": False,
        "same": True,
        "points": 3,
        "viewer": "draw_plotly",
        "figure": "Figure",
        "dash_after": True,
    }
