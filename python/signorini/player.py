"""A single-file HTML player for a recorded run: open it in any browser, offline.

``write_html(path, record)`` writes one .html file holding everything the page needs: three.js,
the player script (``player.js`` beside this module) and the record's scene and motion. Data
passed to the page (JSON; arrays as base64 little-endian float32 / uint32 / uint8, frame-major):

- ``names`` (N,), ``static`` (N,), ``colours`` (N,) "#rrggbb", ``up`` (3,) unit against gravity;
- ``meshes``: per body {``v``: (n_i * 3) float32 body-frame vertices, m; ``f``: (k_i * 3) uint32};
- ``time`` (F,) s; ``pos`` (F * N * 3) m world; ``quat`` (F * N * 4) (w, x, y, z) world-from-body;
- ``contacts``: null or {``offsets`` (F + 1,), ``point``, ``normal``, ``force`` (C * 3)} (m, unit,
  N); ``force_scale`` m of arrow per N; ``normal_length`` m;
- ``camera``: {``targets`` (F * 3), ``offset`` (3,), ``up``, ``fov``, ``follow``} from
  ``render.default_camera``;
- ``events``: null when the record has none (a file written before them), else the record's
  contact events (``Record.events``) of every kind in one list of E rows, by step and then in the
  order of ``EVENT_KINDS``: ``kinds`` (5,) labels and ``colours`` (5,) "#rrggbb" of the kinds
  (``EVENT_LABELS``, ``EVENT_COLOURS``); ``kind`` (E,) uint8 index into them; ``step`` (E,) uint32,
  the step it happened in (0-based); ``frame`` (E,) uint32, the first frame showing the state after
  that step; ``a``, ``b`` (E,) uint32 bodies; ``point`` (E * 3) m world; ``normal`` (E * 3) unit
  A->B; ``speed`` (E,) m/s; ``impulse`` (E,) N s; ``event_fade`` s, how long after its frame an
  event's marker stays, fading.

The page plays, pauses and scrubs the timeline, orbits (drag), pans (right drag or shift drag) and
zooms (wheel) the camera, and toggles contact points, normals, force arrows and following the
bodies. Keys: space play/pause, arrows one frame, Home / End. With events, the timeline has a tick
per kind at each frame with one (hits in the top row, beginnings in the middle, ends at the
bottom), the 3-D view a cross at each event's point from its frame on, fading over ``event_fade``
s (a hit's larger, with its normal), and the frame's events are listed under the title; an
``events`` box shows or hides the crosses and the list, and ``]`` / ``[`` (or Page Down / Page Up)
go to the next / previous frame with events. ``window.signoriniPlayer`` exposes ``seek(frame)``, ``frame``,
``frames``, ``screenBox(body)``, ``events`` (E), ``ticks()`` (the timeline's ticks: frame, kind,
page x and y) and ``markers()`` (the crosses drawn now: event index, kind, step, frame, bodies,
point, alpha, page x and y) for scripts and tests.

three.js: the page embeds ``static/three.js`` (three.js r97, MIT licence) as shipped inside the
``pythreejs`` package on PyPI, read from the installed package at write time (never fetched from
a CDN); the package is located without importing it.
"""

from __future__ import annotations

import base64
import html
import importlib.util
import json
from importlib import resources
from pathlib import Path

import numpy as np

from .render import body_colours, default_camera, default_force_scale
from .trajectory import EVENT_KINDS, Record

__all__ = ["write_html", "three_js", "frame_data_bytes", "PLAYER_BUDGET", "EVENT_LABELS",
           "EVENT_COLOURS", "EVENT_FADE"]

#: the page's name and colour (RGB 0..255) of each kind of ``trajectory.EVENT_KINDS``, in its order
EVENT_LABELS = ("begin", "end", "hit", "sensor begin", "sensor end")
EVENT_COLOURS = ((0, 150, 60), (230, 120, 0), (210, 0, 160), (0, 170, 200), (130, 60, 200))
#: s of simulated time an event's marker stays after its frame, fading to nothing
EVENT_FADE = 0.25


def three_js() -> str:
    """The three.js source shipped inside the ``pythreejs`` package (UMD build, defines THREE)."""
    spec = importlib.util.find_spec("pythreejs")
    if spec is None or not spec.submodule_search_locations:
        raise RuntimeError("the HTML player needs three.js from the 'pythreejs' package: pip install pythreejs")
    for folder in spec.submodule_search_locations:
        path = Path(folder) / "static" / "three.js"
        if path.is_file():
            return path.read_text(encoding="utf-8")
    raise RuntimeError("the 'pythreejs' package has no static/three.js: reinstall pythreejs")


def _b64(a, dtype) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype=dtype).tobytes()).decode("ascii")


def _event_frames(record: Record, steps) -> np.ndarray:
    """The frame showing the state right after each given step (0-based), (E,) int64: the first
    frame with ``frame_step`` >= step + 1 (frame f shows the state after ``frame_step[f]`` steps; the
    last step is always a frame, so every step of the run has one)."""
    return np.searchsorted(record.frame_step, np.asarray(steps, dtype=np.int64) + 1, side="left").astype(np.int64)


def _events(record: Record) -> dict | None:
    """The events the page reads (see the module docstring); None when the record has none."""
    kinds = [record.events[k] for k in EVENT_KINDS]
    if not sum(len(e["step"]) for e in kinds):
        return None
    kind = np.concatenate([np.full(len(e["step"]), i, np.uint8) for i, e in enumerate(kinds)])
    step = np.concatenate([e["step"] for e in kinds])
    order = np.argsort(step, kind="stable")  # by step, then by kind, each kind in its own order

    def column(field):
        return np.concatenate([e[field] for e in kinds])[order]

    return {"kinds": list(EVENT_LABELS), "colours": ["#%02x%02x%02x" % c for c in EVENT_COLOURS],
            "kind": _b64(kind[order], "u1"), "step": _b64(step[order], "<u4"),
            "frame": _b64(_event_frames(record, step[order]), "<u4"),
            "a": _b64(column("body_a"), "<u4"), "b": _b64(column("body_b"), "<u4"),
            "point": _b64(column("point"), "<f4"), "normal": _b64(column("normal"), "<f4"),
            "speed": _b64(column("speed"), "<f4"), "impulse": _b64(column("impulse"), "<f4")}


def _data(record: Record, title: str) -> dict:
    """The JSON object the page reads; see the module docstring."""
    camera = default_camera(record)
    size = float(np.linalg.norm(camera["offset"]))
    contacts = None
    if record.contacts is not None:
        c = record.contacts
        contacts = {"offsets": _b64(c["offsets"], "<u4"), "point": _b64(c["point"], "<f4"),
                    "normal": _b64(c["normal"], "<f4"), "force": _b64(c["force"], "<f4")}
    return {
        "title": title,
        "scene": record.scene,
        "dt": record.dt,
        "stride": record.stride,
        "names": list(record.names),
        "static": [bool(x) for x in record.is_static],
        "colours": ["#%02x%02x%02x" % c for c in body_colours(record)],
        "masses": [float(m) if np.isfinite(m) else None for m in record.masses],
        "meshes": [{"v": _b64(v, "<f4"), "f": _b64(f, "<u4")} for v, f in record.draw_meshes],
        "frames": record.frames,
        "time": _b64(record.time, "<f4"),
        "pos": _b64(record.positions, "<f4"),
        "quat": _b64(record.orientations, "<f4"),
        "vel": _b64(record.velocities, "<f4"),
        "contacts": contacts,
        "force_scale": default_force_scale(record),
        "normal_length": 0.06 * size,
        "camera": {"targets": _b64(camera["targets"], "<f4"), "offset": [float(x) for x in camera["offset"]],
                   "up": [float(x) for x in camera["up"]], "fov": camera["fov"], "follow": camera["follow"]},
        "events": _events(record),
        "event_fade": EVENT_FADE,
    }


PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title}</title>
<style>
html, body {{ margin: 0; height: 100%; overflow: hidden; font: 13px system-ui, sans-serif; background: #fff; }}
#view {{ position: absolute; inset: 0 0 44px 0; }}
#view canvas {{ display: block; }}
#bar {{ position: absolute; left: 0; right: 0; bottom: 0; height: 44px; display: flex; align-items: center;
        gap: 10px; padding: 0 10px; box-sizing: border-box; background: #f2f2f2; border-top: 1px solid #ccc; }}
#track {{ flex: 1; position: relative; display: flex; align-items: center; height: 100%; }}
#timeline {{ flex: 1; }}
#ticks {{ position: absolute; left: 0; top: 1px; width: 100%; height: 12px; pointer-events: none; }}
#clock {{ font-variant-numeric: tabular-nums; min-width: 9em; }}
#title {{ position: absolute; left: 10px; top: 8px; color: #333; pointer-events: none; }}
#info {{ position: absolute; right: 10px; top: 8px; color: #333; white-space: pre; text-align: right;
         font: 12px ui-monospace, monospace; pointer-events: none; }}
#event-list {{ position: absolute; left: 10px; top: 28px; color: #333; white-space: pre;
               font: 12px ui-monospace, monospace; pointer-events: none; }}
label {{ user-select: none; }}
</style>
</head>
<body>
<div id="view"></div>
<div id="title">{title}</div>
<div id="info"></div>
<div id="event-list"></div>
<div id="bar">
  <button id="play" title="play / pause (space)">play</button>
  <div id="track">
    <input id="timeline" type="range" min="0" max="0" value="0" step="1" title="timeline (arrows, Home, End)">
    <canvas id="ticks" hidden></canvas>
  </div>
  <span id="clock"></span>
  <select id="speed" title="playback speed">
    <option value="0.25">0.25x</option><option value="0.5">0.5x</option><option value="1" selected>1x</option>
    <option value="2">2x</option><option value="4">4x</option>
  </select>
  <label><input id="show-contacts" type="checkbox" checked> contacts</label>
  <label><input id="show-normals" type="checkbox"> normals</label>
  <label><input id="show-forces" type="checkbox" checked> forces</label>
  <label><input id="follow" type="checkbox"> follow</label>
  <label id="events-toggle" title="contact events: ] / [ next / previous" hidden><input id="show-events" type="checkbox" checked> events</label>
</div>
<script>
{three}
</script>
<script id="signorini-data" type="application/json">{data}</script>
<script>
{player}
</script>
</body>
</html>
"""


#: the most bytes of frame data (times, poses, velocities, camera targets, contacts) a page holds
#: before base64, which adds a third: 24 MB of it make a page of about 33 MB with three.js
PLAYER_BUDGET = 24_000_000


def frame_data_bytes(record: Record) -> int:
    """Bytes of the frame data the page of this record holds before base64: per frame its time
    (4), camera target (12) and contact offset (4), per body and frame its position, orientation
    and velocity (40, float32), per contact its point, normal and force (36)."""
    contacts = len(record.contacts["gap"]) if record.contacts is not None else 0
    return record.frames * (20 + 40 * record.num_bodies) + 36 * contacts


def write_html(path, record: Record, title: str | None = None, max_frame_bytes: float = PLAYER_BUDGET) -> Path:
    """Write the single-file player of a record to path (.html); returns the path.

    When the frames would hold more than ``max_frame_bytes`` of data (``frame_data_bytes``,
    contacts included), every k-th frame and the last are kept, k the smallest that fits, so a
    thousand bodies over thousands of frames still give a page a browser opens quickly.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    title = title or f"signorini: {record.scene}"
    # the smallest k that fits: the frames' share alone asks for at least total / budget
    total = frame_data_bytes(record)
    k = max(1, int(total // max_frame_bytes) - 1)
    while total > max_frame_bytes and record.frames > 2:
        k += 1
        keep = list(range(0, record.frames, k))
        if keep[-1] != record.frames - 1:
            keep.append(record.frames - 1)
        thinned = record.select_frames(keep)
        if frame_data_bytes(thinned) <= max_frame_bytes or len(keep) <= 2:
            record = thinned
            break
    data = json.dumps(_data(record, title), separators=(",", ":")).replace("</", "<\\/")
    player = resources.files("signorini").joinpath("player.js").read_text(encoding="utf-8")
    page = PAGE.format(title=html.escape(title), three=three_js(), data=data, player=player)
    path.write_text(page, encoding="utf-8")
    return path
