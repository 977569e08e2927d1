"""Offscreen pictures of a recorded run: a default camera, a small flat-shaded renderer and an MP4.

Everything works from a ``trajectory.Record`` alone (no simulator, no display, no GPU):

- ``default_camera(record)``: a dict with ``target`` (3,) m, ``eye`` (3,) m, ``up`` (3,) unit and
  ``fov`` (vertical, degrees), framing the dynamic bodies (following them when they travel far),
  looking down 25 degrees against gravity (the HTML player starts from the same camera);
- ``render_frame(record, f, camera, size)``: an (H, W, 3) uint8 RGB picture of frame f: triangles
  projected with a pinhole camera, back faces of closed bodies culled, painted far to near (the
  painter's algorithm, exact enough for separate convex-ish bodies), flat Lambert shading from a
  light at the camera, contact points and force arrows on top; drawn with Pillow at twice the size
  and downsampled for smooth edges;
- ``write_video(path, record, fps, size)``: an H.264 MP4 through imageio-ffmpeg (the ffmpeg binary
  ships in its wheel), one picture every 1/fps s of simulated time, with a progress bar.
"""

from __future__ import annotations

import contextlib
import math
from pathlib import Path

import numpy as np

from . import progress as progress_bars
from .codec import quat_to_matrix
from .trajectory import Record

__all__ = ["default_camera", "camera_at", "render_frame", "write_video", "video_frames", "PALETTE"]

# body colours (RGB 0..255), cycled over the dynamic bodies; static bodies are grey
PALETTE = [(31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189),
           (140, 86, 75), (227, 119, 194), (188, 189, 34), (23, 190, 207), (127, 127, 127)]
STATIC_COLOUR = (178, 178, 178)


def body_colours(record: Record) -> list[tuple[int, int, int]]:
    """One RGB colour per body: the palette over the dynamic bodies in order, grey for static ones."""
    colours, k = [], 0
    for i in range(record.num_bodies):
        if record.is_static[i]:
            colours.append(STATIC_COLOUR)
        else:
            colours.append(PALETTE[k % len(PALETTE)])
            k += 1
    return colours


def _up(record: Record) -> np.ndarray:
    from .output import up_direction

    return up_direction(record)


def default_camera(record: Record, fov: float = 40.0, follow: bool | None = None) -> dict:
    """A camera that keeps every dynamic body in view (every body when none moves).

    Bodies are boxed by their centres of mass plus their reach (the farthest draw-mesh vertex).
    With ``follow`` (default: when the run's whole box is more than three times the largest box of
    one frame, as for the torus sliding metres down its slope) the camera moves with the bodies:
    ``targets`` holds one target per frame; otherwise it stays put, framing the whole run.
    Output dict: target (3,) m (frame 0's), targets (F, 3) m, eye (3,) m (frame 0's), offset (3,)
    m (eye - target, the same for every frame), up (3,) unit, fov (vertical, degrees), follow.
    The eye looks 25 degrees down, from the side a tilted plane faces, turned 60 degrees about up.
    """
    up = _up(record)
    drawn = record.dynamic or list(range(record.num_bodies))
    reach = np.array([float(np.linalg.norm(record.draw_meshes[i][0], axis=1).max())
                      if len(record.draw_meshes[i][0]) else 0.0 for i in drawn])
    centres = record.positions[:, drawn]                                # (F, n, 3)
    lo = (centres - reach[None, :, None]).min(axis=1)                   # (F, 3) per frame
    hi = (centres + reach[None, :, None]).max(axis=1)
    frame_radius = 0.5 * float(np.linalg.norm(hi - lo, axis=1).max())
    run_radius = 0.5 * float(np.linalg.norm(hi.max(axis=0) - lo.min(axis=0)))
    if follow is None:
        follow = run_radius > 3.0 * frame_radius
    if follow:
        targets = 0.5 * (lo + hi)
        radius = 1.3 * frame_radius
    else:
        targets = np.repeat((0.5 * (lo.min(axis=0) + hi.max(axis=0)))[None], record.frames, axis=0)
        radius = run_radius
    radius = max(radius, 1e-3)

    # horizontal direction towards the eye: where a tilted plane faces, else any
    h = np.zeros(3)
    for p in record.shapes:
        if p["type"] == "plane":
            n = np.asarray(p["normal"], dtype=np.float64)
            h = n - (n @ up) * up
            if np.linalg.norm(h) > 0.1:
                break
    if np.linalg.norm(h) <= 0.1:
        h = np.cross(up, [1.0, 0.0, 0.0] if abs(up[0]) < 0.9 else [0.0, 1.0, 0.0])
    h /= np.linalg.norm(h)
    turn = math.radians(-60.0)
    h = math.cos(turn) * h + math.sin(turn) * np.cross(up, h)
    elevation = math.radians(25.0)
    direction = math.cos(elevation) * h + math.sin(elevation) * up
    # the bounding sphere just fits the view's height (a box's corners rarely all face the eye)
    offset = 0.9 * radius / math.sin(math.radians(0.5 * fov)) * direction
    return {"target": targets[0], "targets": targets, "eye": targets[0] + offset, "offset": offset,
            "up": up, "fov": float(fov), "follow": bool(follow)}


def camera_at(camera: dict, f: int) -> dict:
    """The camera for frame f (it moves with the bodies when it follows them)."""
    target = camera["targets"][f]
    return {**camera, "target": target, "eye": target + camera["offset"]}


def _view(camera: dict, width: int, height: int):
    """World-to-camera rotation (3, 3) (rows: right, up, backwards), eye (3,), focal length in pixels."""
    eye = np.asarray(camera["eye"], dtype=np.float64)
    back = eye - np.asarray(camera["target"], dtype=np.float64)
    back /= np.linalg.norm(back)
    right = np.cross(camera["up"], back)
    right /= np.linalg.norm(right)
    up = np.cross(back, right)
    focal = 0.5 * height / math.tan(math.radians(0.5 * camera["fov"]))
    return np.stack([right, up, back]), eye, focal


def render_frame(record: Record, f: int, camera: dict | None = None, size=(640, 480),
                 contacts: bool = True, forces: bool = True, supersample: int = 2,
                 force_scale: float | None = None) -> np.ndarray:
    """Picture of frame f as (height, width, 3) uint8 RGB; see the module docstring.

    ``camera`` defaults to ``default_camera(record)`` and ``force_scale`` (m per N) to
    ``default_force_scale(record)``; pass both when drawing many frames, they cost a pass over the run.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import LineCollection, PolyCollection
    from matplotlib.figure import Figure
    from PIL import Image

    camera = camera_at(camera or default_camera(record), f)
    width, height = int(size[0]), int(size[1])
    s = int(supersample)
    W, H = width * s, height * s
    rotation, eye, focal = _view(camera, W, H)
    colours = body_colours(record)

    def project(points):
        """(n, 3) world points -> (n, 2) pixels and (n,) depth along the view (m, > 0 in front)."""
        c = (np.asarray(points) - eye) @ rotation.T
        depth = -c[:, 2]
        safe = np.where(depth > 1e-6, depth, 1e-6)
        return np.stack([0.5 * W + focal * c[:, 0] / safe, 0.5 * H - focal * c[:, 1] / safe], axis=1), depth

    # every triangle of every body, with its depth, colour and facing
    polygons, depths, fills = [], [], []
    for i in range(record.num_bodies):
        vertices, faces = record.draw_meshes[i]
        if len(faces) == 0:
            continue
        R = quat_to_matrix(record.orientations[f, i])
        world = vertices @ R.T + record.positions[f, i]
        tri = world[faces]                                          # (k, 3, 3)
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        length = np.linalg.norm(normal, axis=1)
        keep = length > 0
        tri, normal = tri[keep], normal[keep] / length[keep, None]
        # a directional light along the view: the same shade over a flat face
        facing = normal @ rotation[2]
        # closed dynamic bodies: back faces hidden; open static meshes and patches: both sides lit
        if not record.is_static[i]:
            front = facing > 0
            tri, facing = tri[front], facing[front]
        pixels, depth = project(tri.reshape(-1, 3))
        pixels, depth = pixels.reshape(-1, 3, 2), depth.reshape(-1, 3)
        visible = np.all(depth > 1e-3, axis=1)
        shade = 0.35 + 0.65 * np.abs(facing[visible])
        polygons.append(pixels[visible])
        # scenery is painted first: a floor's few large triangles would otherwise cover what stands on it
        depths.append(depth[visible].mean(axis=1) + (1e9 if record.is_static[i] else 0.0))
        fills.append(np.clip(np.array(colours[i]) / 255.0 * shade[:, None], 0.0, 1.0))

    # painted far to near in one call (Agg), on a canvas of W x H pixels with y down
    figure = Figure(figsize=(W / 100.0, H / 100.0), dpi=100)
    FigureCanvasAgg(figure)
    axes = figure.add_axes((0.0, 0.0, 1.0, 1.0))
    axes.set_xlim(0, W)
    axes.set_ylim(H, 0)
    axes.set_axis_off()
    if polygons:
        order = np.argsort(np.concatenate(depths))[::-1]
        colour = np.concatenate(fills)[order]
        axes.add_collection(PolyCollection(np.concatenate(polygons)[order], facecolors=colour, edgecolors=colour,
                                           linewidths=0.3, antialiaseds=False))

    # contact points and force arrows on top
    c = record.frame_contacts(f)
    if len(c["gap"]):
        scale = default_force_scale(record) if force_scale is None else force_scale
        if forces and scale > 0:
            start, _ = project(c["point"])
            end, _ = project(c["point"] + scale * c["force"])
            axes.add_collection(LineCollection(np.stack([start, end], axis=1), colors=(0.8, 0.0, 0.0),
                                               linewidths=0.6 * s))
        if contacts:
            points, _ = project(c["point"])
            axes.scatter(points[:, 0], points[:, 1], s=(2.0 * s) ** 2, c="black", linewidths=0)
    figure.canvas.draw()
    rgba = np.asarray(figure.canvas.buffer_rgba())
    image = Image.fromarray(rgba[:, :, :3].copy())
    if s > 1:
        image = image.resize((width, height), Image.LANCZOS)
    return np.asarray(image, dtype=np.uint8)


def default_force_scale(record: Record) -> float:
    """Metres of arrow per newton: the 90th percentile of the run's contact forces is drawn a fifth
    of the view's half height (0 when there are no forces)."""
    if record.contacts is None or len(record.contacts["gap"]) == 0:
        return 0.0
    magnitude = np.linalg.norm(record.contacts["force"], axis=1)
    magnitude = magnitude[magnitude > 0]
    if magnitude.size == 0:
        return 0.0
    # impacts are brief and large: scale by the 90th percentile so resting forces stay visible
    typical = float(np.percentile(magnitude, 90))
    camera = default_camera(record)
    size = float(np.linalg.norm(camera["offset"])) * math.sin(math.radians(0.5 * camera["fov"]))
    return 0.2 * size / typical


def video_frames(record: Record, fps: float) -> np.ndarray:
    """The record's frames shown in a video at fps pictures per simulated second: the frame nearest
    to each time t0, t0 + 1/fps, ... up to the end, (M,) int, M = floor(duration fps) + 1."""
    duration = float(record.time[-1] - record.time[0])
    count = int(math.floor(duration * fps + 1e-9)) + 1
    times = record.time[0] + np.arange(count) / fps
    return np.array([record.frame_at(t) for t in times], dtype=np.int64)


def write_video(path, record: Record, fps: float = 30.0, size=(640, 480), progress: bool = True) -> Path:
    """Write an H.264 MP4 of the run (one picture per 1/fps s of simulated time, at real speed).

    Inputs: path (.mp4), record, fps (> 0), size (width, height) pixels, both even (yuv420p),
    progress (once rendering has taken a second: a tqdm bar on a terminal, a few plain lines
    anywhere else, ``signorini.progress``). Output: the path.
    """
    import imageio.v2 as imageio

    width, height = int(size[0]), int(size[1])
    if width < 16 or height < 16 or width % 2 or height % 2:
        raise ValueError(f"video size must be even and at least 16 x 16 pixels, got {width}x{height}")
    if not (math.isfinite(fps) and fps > 0):
        raise ValueError(f"video fps must be a number > 0, got {fps}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    camera = default_camera(record)
    scale = default_force_scale(record)
    frames = video_frames(record, fps)
    writer = imageio.get_writer(path, fps=fps, codec="libx264", quality=7, macro_block_size=2,
                                ffmpeg_log_level="error")
    try:
        with contextlib.ExitStack() as stack:
            bar = stack.enter_context(progress_bars.bar(len(frames), f"video {path.name}", "frame", delay=1.0,
                                                        leave=False)) if progress else None
            for f in frames:
                writer.append_data(render_frame(record, int(f), camera, (width, height), force_scale=scale))
                if bar is not None:
                    bar.update(1)
    finally:
        writer.close()
    return path
