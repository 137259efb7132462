"""A recorded run as a self-contained interactive 3D page, drawn by plotly.

One HTML file with plotly.js inlined (no network): drag to rotate, scroll to
zoom, hover for what a point or pose is, click a legend entry to hide or show a
layer, and step through the plan's alternatives from the sidebar. The sidebar
has a fixed width and the plot takes the rest (a CSS grid whose plot column may
shrink, ``minmax(0, 1fr)``), from 1024 to 1920 px wide.

plotly replaced a canvas renderer of the project's own: plotly draws the
gripper's shape as shaded meshes, depth-sorts with WebGL, and gives legend
toggles and hover for free. Its price is the inlined plotly.js, 4.6 MB per
page (measured with plotly 7.1); ``include_plotlyjs="cdn"`` would save that but
would not open offline.
"""

from __future__ import annotations

import html
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.view._run import COLOURS, REASON_COLOURS, RunLayers, _focus, run_layers

if TYPE_CHECKING:
    from wsgrasp.record import Run

__all__ = ["render_html", "page_figure", "SIDEBAR_PX"]

Array = NDArray[np.float64]
#: sidebar width; the plot takes the rest of the window
SIDEBAR_PX = 300
AXIS_COLOURS = ("#e41a1c", "#4daf4a", "#377eb8")


def _r(x: Any) -> Any:
    """Round to 0.1 mm (keeps the page small)."""
    return np.round(np.asarray(x, dtype=np.float64), 4)


def _points(name: str, p: Array, colour: str, size: float, **kw: Any) -> Any:
    import plotly.graph_objects as go

    p = _r(p).reshape(-1, 3)
    return go.Scatter3d(
        x=p[:, 0],
        y=p[:, 1],
        z=p[:, 2],
        mode="markers",
        name=name,
        marker={"size": size, "color": colour},
        hoverinfo="name",
        **kw,
    )


def _mesh(name: str, v: Array, faces: NDArray[np.int64], colour: str, **kw: Any) -> Any:
    import plotly.graph_objects as go

    v = _r(v)
    return go.Mesh3d(
        x=v[:, 0],
        y=v[:, 1],
        z=v[:, 2],
        i=faces[:, 0],
        j=faces[:, 1],
        k=faces[:, 2],
        color=colour,
        name=name,
        showlegend=kw.pop("showlegend", True),
        flatshading=True,
        lighting={"ambient": 0.55, "diffuse": 0.7, "specular": 0.1},
        hoverinfo="name",
        **kw,
    )


def _lines(name: str, segments: Array, colour: str, width: float, **kw: Any) -> Any:
    """``(k, 2, 3)`` segments as one broken line (a None gap after each)."""
    import plotly.graph_objects as go

    seg = _r(segments)
    gap = np.full((len(seg), 1, 3), np.nan)
    p = np.concatenate([seg, gap], axis=1).reshape(-1, 3)  # (3k, 3)
    return go.Scatter3d(
        x=p[:, 0],
        y=p[:, 1],
        z=p[:, 2],
        mode="lines",
        name=name,
        line={"color": colour, "width": width},
        hoverinfo="name",
        connectgaps=False,
        **kw,
    )


def _triad(name: str, T: Array, size: float) -> list[Any]:
    import plotly.graph_objects as go

    o = T[:3, 3]
    out = []
    for k in range(3):
        end = o + size * T[:3, k]
        p = _r(np.stack([o, end]))
        out.append(
            go.Scatter3d(
                x=p[:, 0],
                y=p[:, 1],
                z=p[:, 2],
                mode="lines+text",
                text=["", f"{name} {'xyz'[k]}"],
                textfont={"color": AXIS_COLOURS[k], "size": 11},
                line={"color": AXIS_COLOURS[k], "width": 6},
                name=name,
                legendgroup=name,
                showlegend=k == 0,
                hoverinfo="name",
            )
        )
    return out


def _traces(L: RunLayers, half: float) -> tuple[list[Any], list[dict[str, Any]]]:
    """The plot's traces, and the alternatives as ``{label, trace}`` (the index
    of the trace that shows each)."""
    traces: list[Any] = []
    if len(L.table):
        traces.append(_points("table", L.table, COLOURS["table"], 1.5))
    elif len(L.scene):
        traces.append(_points("scene points", L.scene, COLOURS["scene"], 1.5))
    if len(L.object):
        traces.append(_points("object", L.object, COLOURS["object"], 2.5))
    if len(L.obstacles):
        traces.append(_points("obstacles", L.obstacles, COLOURS["obstacles"], 2))
    if len(L.samples):
        traces.append(
            _points(
                "bounding-box samples",
                L.samples,
                COLOURS["samples"],
                2,
                visible="legendonly",
            )
        )
    for code, reason in enumerate(L.reason_names):
        sel = L.reasons == code
        if sel.any():
            traces.append(
                _points(
                    f"candidate: {reason.replace('_', ' ')} ({int(sel.sum())})",
                    L.candidates[sel],
                    REASON_COLOURS.get(reason, "#555555"),
                    3.5 if reason == "feasible" else 2.5,
                    opacity=1.0 if reason == "feasible" else 0.6,
                )
            )
    if len(L.directions):
        traces.append(
            _lines(
                "feasible approach directions",
                L.directions,
                COLOURS["directions"],
                1.5,
                visible="legendonly",
            )
        )
    faces = L.shape_faces
    if len(L.shape_pregrasp):
        traces.append(
            _mesh(
                "gripper at pre-grasp (open)",
                L.shape_pregrasp,
                faces,
                COLOURS["gripper_pregrasp"],
                opacity=0.4,
            )
        )
    if len(L.shape_grasp):
        traces.append(
            _mesh(
                "gripper at grasp (closed)",
                L.shape_grasp,
                faces,
                COLOURS["gripper_grasp"],
            )
        )
    if len(L.approach):
        traces.append(
            _lines(
                "approach: pre-grasp → grasp",
                L.approach[None],
                COLOURS["approach"],
                6,
            )
        )
    if len(L.contacts):
        traces.append(_points("contact points", L.contacts, COLOURS["contacts"], 4))
    if L.holding.any():
        traces.append(
            _points(
                f"workspace spheres holding the object ({int(L.holding.sum())})",
                L.spheres[L.holding],
                COLOURS["holding"],
                3,
            )
        )
    if (~L.holding).any():
        traces.append(
            _points(
                f"other workspace spheres ({int((~L.holding).sum())})",
                L.spheres[~L.holding],
                COLOURS["other_spheres"],
                2,
                visible="legendonly",
            )
        )
    for reason, verts in L.rejected:
        traces.append(
            _mesh(
                f"rejected: {reason.replace('_', ' ')}",
                verts,
                faces,
                REASON_COLOURS[reason],
                opacity=0.35,
                legendgroup=reason,
            )
        )
    if L.T_world_object is not None:
        traces += _triad("object frame", L.T_world_object, 0.35 * half)
    if L.T_world_ee is not None:
        traces += _triad("gripper frame", L.T_world_ee, 0.3 * half)
    # (the frames' axes: x red, y green, z blue, each tip lettered)
    # step 0 is the chosen grasp (no alternative drawn), then each alternative
    alternatives: list[dict[str, Any]] = []
    if L.T_world_ee is not None:
        alternatives.append({"label": "the chosen grasp", "trace": None})
    for label, verts in L.alternatives:
        alternatives.append({"label": label, "trace": len(traces)})
        traces.append(
            _mesh(
                "alternative (open)",
                verts,
                faces,
                "#f28e2b",
                opacity=0.45,
                legendgroup="alternative",
                visible=False,
                showlegend=False,
            )
        )
    return traces, alternatives


def page_figure(run: Run) -> tuple[Any, dict[str, Any]]:
    """The plotly figure of a run, and the sidebar's data (title, notes,
    summary lines, alternatives)."""
    import plotly.graph_objects as go

    L = run_layers(run)
    centre, half = _focus(L)
    traces, alternatives = _traces(L, half)
    fig = go.Figure(data=traces)
    box = {
        f"{name}axis": {
            "range": [float(centre[i] - half), float(centre[i] + half)],
            "title": f"{name} (m)",
        }
        for i, name in enumerate("xyz")
    }
    fig.update_layout(
        scene={**box, "aspectmode": "cube"},
        margin={"l": 0, "r": 0, "t": 0, "b": 0},
        legend={  # along the bottom, clear of the object in the middle
            "orientation": "h",
            "x": 0.0,
            "y": 0.0,
            "yanchor": "bottom",
            "bgcolor": "rgba(255,255,255,0.85)",
            "font": {"size": 11},
            "itemsizing": "constant",
        },
        uirevision="keep",  # stepping keeps the camera where the user put it
    )
    res = run.result
    summary = []
    if res is not None:
        n = len(L.candidates)
        summary.append(f"{int((L.reasons == 0).sum())} of {n} candidates feasible")
        if res.found and res.score is not None:
            summary.append(f"score {res.score:.3f}")
        if not res.found and res.hint:
            summary.append(res.hint)
    side = {
        "title": L.title,
        "notes": L.notes,
        "summary": summary,
        "alternatives": alternatives,
    }
    return fig, side


_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>__TITLE__</title>
<style>
 html,body{margin:0;height:100%;font:14px system-ui,sans-serif;color:#222}
 #wrap{display:grid;grid-template-columns:__SIDE__px minmax(0,1fr);height:100vh}
 #side{padding:14px;overflow:auto;border-right:1px solid #ddd;background:#fafafa;
  box-sizing:border-box;min-width:0}
 #side h1{font-size:16px;margin:0 0 8px;overflow-wrap:anywhere}
 #side p{margin:4px 0} .note{color:#a40}
 #steps{display:flex;gap:6px;align-items:center;margin:6px 0}
 #steps button{font-size:14px;padding:2px 10px}
 #main{min-width:0;min-height:0} #plot{width:100%;height:100%}
 .hint{color:#666;font-size:12px;margin-top:14px}
</style></head><body><div id="wrap"><aside id="side">
<h1 id="title">__TITLE__</h1><div id="notes"></div><div id="summary"></div>
<div id="alts"><h2 style="font-size:14px;margin:14px 0 4px">Alternatives</h2>
<div id="steps"><button id="prev" title="previous alternative">◀</button>
<button id="next" title="next alternative">▶</button></div>
<p id="alt-label"></p></div>
<p class="hint">Drag to turn, scroll to zoom, hover for names.
Click a legend entry to hide or show it; double-click to show it alone.</p>
</aside><main id="main">__PLOT__</main></div>
<script id="side-data" type="application/json">__SIDE_DATA__</script>
<script>
"use strict";
(function () {
  const S = JSON.parse(document.getElementById("side-data").textContent);
  const plot = document.getElementById("plot");
  const add = (id, text, cls) => { const p = document.createElement("p");
    p.textContent = text; if (cls) p.className = cls;
    document.getElementById(id).append(p); };
  S.notes.forEach(n => add("notes", n, "note"));
  S.summary.forEach(n => add("summary", n));
  const alts = S.alternatives, label = document.getElementById("alt-label");
  let current = 0;
  const drawn = alts.filter(a => a.trace !== null);
  function show(k) {
    if (!alts.length) return;
    current = (k + alts.length) % alts.length;
    if (drawn.length) {
      const on = drawn.map(a => a === alts[current]);
      Plotly.restyle(plot, {visible: on, showlegend: on}, drawn.map(a => a.trace));
    }
    label.textContent = (current + 1) + " of " + alts.length + ": " +
      alts[current].label;
    label.dataset.step = current;
  }
  if (alts.length) { show(0); } else {
    document.getElementById("steps").hidden = true;
    label.textContent = "none: this run has no grasp";
  }
  document.getElementById("prev").onclick = () => show(current - 1);
  document.getElementById("next").onclick = () => show(current + 1);
  window.addEventListener("resize", () => Plotly.Plots.resize(plot));
  window.wsgraspReady = true;
})();
</script></body></html>
"""


def render_html(run: Run, path: str | Path) -> Path:
    """Write a run as a self-contained interactive 3D page.

    Parameters
    ----------
    run
        From :func:`wsgrasp.record.open_run`.
    path
        Output ``.html``.

    Returns
    -------
    Path
        The file written.
    """
    fig, side = page_figure(run)
    plot = fig.to_html(
        full_html=False,
        include_plotlyjs=True,
        div_id="plot",
        default_width="100%",
        default_height="100%",
        config={"responsive": True, "displaylogo": False},
    )
    # "</" inside the JSON would end the script element early
    data = json.dumps(side, separators=(",", ":")).replace("</", "<\\/")
    page = (
        _PAGE.replace("__TITLE__", html.escape(side["title"]))
        .replace("__SIDE__", str(SIDEBAR_PX))
        .replace("__SIDE_DATA__", data)
        .replace("__PLOT__", plot)
    )
    out = Path(path)
    out.write_text(page, encoding="utf-8")
    return out
