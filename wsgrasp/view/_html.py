"""A recorded run as a self-contained interactive 3D page.

The page is one HTML file with the data inlined as JSON and a small canvas
renderer of its own (no library, no network): drag to rotate, shift-drag to pan,
wheel to zoom, a checkbox per layer. It opens offline in any browser.
"""

from __future__ import annotations

import html
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from wsgrasp.view._run import REASON_COLOURS, _focus, run_layers

if TYPE_CHECKING:
    from wsgrasp.record import Run

__all__ = ["render_html", "page_data"]


def _flat(points: Any) -> list[float]:
    """``(n, 3)`` points as a flat list rounded to 0.1 mm (keeps the page small)."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    return [round(float(x), 4) for x in p.ravel()]


def page_data(run: Run) -> dict[str, Any]:
    """The layers of the page, as plain data."""
    L = run_layers(run)
    centre, half = _focus(L)
    layers: list[dict[str, Any]] = [
        {"name": "scene", "color": "#bfbfbf", "size": 1.5, "points": _flat(L.scene)},
        {"name": "table", "color": "#a08060", "size": 1.5, "points": _flat(L.table)},
        {
            "name": "obstacles",
            "color": "#e08020",
            "size": 2,
            "points": _flat(L.obstacles),
        },
        {"name": "object", "color": "#1f66e5", "size": 2.5, "points": _flat(L.object)},
        {"name": "samples", "color": "#ffd91a", "size": 2, "points": _flat(L.samples)},
    ]
    for code, reason in enumerate(L.reason_names):
        sel = L.reasons == code
        if sel.any():
            layers.append(
                {
                    "name": f"candidates: {reason.replace('_', ' ')} "
                    f"({int(sel.sum())})",
                    "color": REASON_COLOURS.get(reason, "#555555"),
                    "size": 4 if reason == "feasible" else 3,
                    "points": _flat(L.candidates[sel]),
                }
            )
    layers += [
        {
            "name": "gripper (chosen)",
            "color": "#404048",
            "size": 2,
            "points": _flat(L.gripper),
        },
        {
            "name": "contacts",
            "color": "#10c030",
            "size": 3.5,
            "points": _flat(L.contacts),
        },
    ]
    spheres = [
        {
            "name": "spheres holding the object",
            "color": "#10c030",
            "spheres": [
                [*map(lambda v: round(float(v), 4), c), round(float(r), 4)]
                for c, r in zip(L.spheres[L.holding], L.radii[L.holding], strict=True)
            ],
        },
        {
            "name": "other workspace spheres",
            "color": "#4d99ff",
            "spheres": [
                [*map(lambda v: round(float(v), 4), c), round(float(r), 4)]
                for c, r in zip(L.spheres[~L.holding], L.radii[~L.holding], strict=True)
            ],
        },
    ]
    axes = []
    for name, T in (
        ("object frame", L.T_world_object),
        ("gripper frame", L.T_world_ee),
    ):
        if T is not None:
            axes.append({"name": name, "T": np.asarray(T).round(5).tolist()})
    return {
        "title": L.title,
        "notes": L.notes,
        "centre": [float(x) for x in centre],
        "half": float(half),
        "layers": [lay for lay in layers if lay["points"]],
        "spheres": [s for s in spheres if s["spheres"]],
        "axes": axes,
    }


_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>__TITLE__</title>
<style>
 body{margin:0;font:13px system-ui,sans-serif;background:#fafafa;color:#222}
 #wrap{display:flex;height:100vh}
 #side{width:270px;padding:10px;overflow:auto;border-right:1px solid #ddd}
 canvas{flex:1;display:block;cursor:grab;background:#fff}
 label{display:block;margin:2px 0;white-space:nowrap}
 .sw{display:inline-block;width:10px;height:10px;margin-right:5px;border-radius:5px}
 h1{font-size:14px;margin:0 0 6px} .note{color:#a40} #status{color:#777;margin-top:8px}
</style></head><body><div id="wrap"><div id="side">
<h1>__TITLE__</h1><div id="notes"></div><div id="layers"></div>
<p>drag: rotate · shift-drag: pan · wheel: zoom</p>
<button id="reset">reset view</button><div id="status">loading…</div></div>
<canvas id="c"></canvas></div>
<script id="data" type="application/json">__DATA__</script>
<script>
"use strict";
const D = JSON.parse(document.getElementById("data").textContent);
const cv = document.getElementById("c"), ctx = cv.getContext("2d");
const on = {};
let yaw = -0.9, pitch = 0.45, zoom = 1, pan = [0, 0];
function addToggle(name, color) {
  on[name] = true;
  const l = document.createElement("label"), b = document.createElement("input");
  b.type = "checkbox"; b.checked = true;
  b.onchange = () => { on[name] = b.checked; draw(); };
  const s = document.createElement("span");
  s.className = "sw"; s.style.background = color;
  l.append(b, s, document.createTextNode(name));
  document.getElementById("layers").append(l);
}
D.layers.forEach(l => addToggle(l.name, l.color));
D.spheres.forEach(s => addToggle(s.name, s.color));
D.axes.forEach(a => addToggle(a.name, "#e33"));
D.notes.forEach(n => { const p = document.createElement("div"); p.className = "note";
  p.textContent = n; document.getElementById("notes").append(p); });
function project(x, y, z) {
  // world z up; rotate about z (yaw), then tilt (pitch); camera looks along +y
  x -= D.centre[0]; y -= D.centre[1]; z -= D.centre[2];
  const cy = Math.cos(yaw), sy = Math.sin(yaw);
  const cp = Math.cos(pitch), sp = Math.sin(pitch);
  const x1 = cy * x - sy * y, y1 = sy * x + cy * y;
  const y2 = cp * y1 - sp * z, z2 = sp * y1 + cp * z;
  const s = zoom * Math.min(cv.width, cv.height) / (2.2 * D.half);
  return [cv.width / 2 + pan[0] + s * x1, cv.height / 2 + pan[1] - s * z2, y2, s];
}
function draw() {
  cv.width = cv.clientWidth * devicePixelRatio;
  cv.height = cv.clientHeight * devicePixelRatio;
  ctx.clearRect(0, 0, cv.width, cv.height);
  const items = []; let drawn = 0;
  D.layers.forEach(l => { if (!on[l.name]) return; const p = l.points;
    for (let i = 0; i < p.length; i += 3) {
      const q = project(p[i], p[i + 1], p[i + 2]);
      items.push([q[2], 0, q[0], q[1], l.size * devicePixelRatio, l.color]); } });
  D.spheres.forEach(g => { if (!on[g.name]) return;
    g.spheres.forEach(s => { const q = project(s[0], s[1], s[2]);
      items.push([q[2], 1, q[0], q[1], Math.max(1, s[3] * q[3]), g.color]); }); });
  items.sort((a, b) => b[0] - a[0]);  // far to near
  for (const it of items) {
    ctx.beginPath(); ctx.arc(it[2], it[3], it[4], 0, 2 * Math.PI);
    if (it[1]) {
      ctx.strokeStyle = it[5]; ctx.lineWidth = devicePixelRatio; ctx.stroke();
    }
    else { ctx.fillStyle = it[5]; ctx.fill(); }
    drawn++;
  }
  D.axes.forEach(a => { if (!on[a.name]) return; const T = a.T;
    const o = project(T[0][3], T[1][3], T[2][3]);
    ["#e22", "#2a2", "#22e"].forEach((c, k) => { const L = 0.3 * D.half;
      const e = project(T[0][3] + L * T[0][k], T[1][3] + L * T[1][k],
                        T[2][3] + L * T[2][k]);
      ctx.beginPath(); ctx.moveTo(o[0], o[1]); ctx.lineTo(e[0], e[1]);
      ctx.strokeStyle = c; ctx.lineWidth = 2 * devicePixelRatio; ctx.stroke(); }); });
  const st = document.getElementById("status");
  st.textContent = "drew " + drawn + " items";
  st.dataset.ready = "1"; st.dataset.drawn = drawn;
}
let drag = null;
cv.onmousedown = e => { drag = [e.clientX, e.clientY, e.shiftKey]; };
window.onmouseup = () => { drag = null; };
window.onmousemove = e => { if (!drag) return;
  const dx = e.clientX - drag[0], dy = e.clientY - drag[1];
  if (drag[2]) { pan[0] += dx * devicePixelRatio; pan[1] += dy * devicePixelRatio; }
  else { yaw += dx * 0.01; pitch = Math.max(-1.57, Math.min(1.57, pitch + dy * 0.01)); }
  drag[0] = e.clientX; drag[1] = e.clientY; draw(); };
cv.onwheel = e => { e.preventDefault(); zoom *= Math.exp(-e.deltaY * 0.001); draw(); };
document.getElementById("reset").onclick = () => { yaw = -0.9; pitch = 0.45; zoom = 1;
  pan = [0, 0]; draw(); };
window.onresize = draw;
draw();
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
    data = page_data(run)
    # "</" inside the JSON would end the script element early
    text = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    page = _PAGE.replace("__TITLE__", html.escape(data["title"])).replace(
        "__DATA__", text
    )
    out = Path(path)
    out.write_text(page, encoding="utf-8")
    return out
