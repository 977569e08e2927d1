"""The interactive viewer: a live view of a scene or a recording in the browser, served by viser.

    python -m signorini view torus              # simulate live: play, pause, single step, scrub
    python -m signorini view out/torus.npz      # replay a recorded trajectory, no simulator

``Viewer(source)`` takes a ``scenes.Scene`` (stepped live through a ``trajectory.Recorder``, one
frame per step, so everything already simulated can be scrubbed back) or a ``trajectory.Record``
(replayed). The scene in the browser: one mesh per body (``/bodies/<name>``, body-frame draw mesh
posed by position (m) and quaternion (w, x, y, z)), the contact points of the shown frame
(``/contacts/points``), their normals (``/contacts/normals``, unit length scaled for view) and force
arrows (``/contacts/forces``, m per N as in the HTML player). The panel: play / pause, step (one
frame; a live scene takes one more step at the end), a timeline slider, speed, toggles for contact
points, normals and forces, and the state of the body last clicked (name, mass, position,
velocity, angular velocity, its contacts). ``serve_forever()`` blocks until Ctrl-C.

Who may connect: the page's websocket controls the simulation, so the server accepts it only from
its own page. A websocket request whose ``Origin`` is not the address the viewer serves (for a
loopback bind: http://127.0.0.1:PORT, http://localhost:PORT or http://[::1]:PORT; for a wildcard
bind 0.0.0.0 or ::, the address the browser asked for, if it is an IP address, a loopback name or
this machine's name) is refused with HTTP 403 before the handshake, so a page of another site open
in the same browser cannot connect. viser has no hook for this: ``_origin_checked`` wraps
``websockets.asyncio.server.serve`` while the viser server starts (its ``process_request`` sees
every request first), and the viewer refuses to run if viser did not start through it. viser's
share URL (a public tunnel through viser's relay) is off: the share button is hidden and a share
request from a page is refused, so the server never contacts anything outside this machine.
"""

from __future__ import annotations

import contextlib
import functools
import http
import inspect
import ipaddress
import math
import re
import socket
import threading
import time as _time
from urllib.parse import urlsplit

import numpy as np

from .render import body_colours, default_camera, default_force_scale
from .trajectory import CONTACT_KEYS, Record, Recorder

__all__ = ["Viewer"]


class Viewer:
    """A viser server showing a scene (live) or a record (replay); see the module docstring.

    Inputs: source (a Scene or a Record), host and port of the server (viser moves to the next free
    port when this one is taken: ``viewer.port`` tells), verbose (viser's own log lines).
    """

    def __init__(self, source, *, host: str = "127.0.0.1", port: int = 8080, verbose: bool = False):
        import viser

        if isinstance(source, Record):
            self.record, self.recorder, self.scene = source, None, None
            self.dt = source.dt * source.stride
            base = source
        else:
            self.scene = source
            self.record = None
            self.recorder = Recorder(source.world, contacts=True, names=getattr(source, "names", None),
                                     scene=source.name)
            self.dt = source.dt
            base = self.recorder.record()  # the scene at frame 0: names, meshes, masses
        self.base = base
        self.names = list(base.names)
        self.frame = 0
        self.playing = False
        self.speed = 1.0
        self.selected = None
        self._lock = threading.RLock()
        self._stop = threading.Event()
        self._thread = None

        camera = default_camera(base)
        self.force_scale = _force_scale_of(base, camera)
        self._normal_length = 0.06 * float(np.linalg.norm(camera["offset"]))

        with _origin_checked(host) as applied:
            self.server = _local_server_class()(host=host, port=port, verbose=verbose)
        if not applied:
            self.server.stop()
            raise RuntimeError(f"viser {viser.__version__} did not start its server through "
                               "websockets.asyncio.server.serve: the viewer will not serve without its Origin check")
        self.server.gui.configure_theme(show_share_button=False)
        self.port = self.server.get_port()
        self.server.scene.set_up_direction(tuple(float(x) for x in camera["up"]))

        # bodies
        colours = body_colours(base)
        self.bodies = []
        for i, name in enumerate(self.names):
            vertices, faces = base.draw_meshes[i]
            handle = self.server.scene.add_mesh_simple(
                f"/bodies/{name}", vertices.astype(np.float32), faces.astype(np.uint32), color=colours[i],
                flat_shading=True, side="double" if base.is_static[i] else "front",
                opacity=0.8 if base.is_static[i] else None,
                position=tuple(base.positions[0, i]), wxyz=tuple(base.orientations[0, i]))
            handle.on_click(lambda event, i=i: self.select(i))
            self.bodies.append(handle)

        # contacts: placeholders replaced by each frame's
        empty = np.zeros((1, 3), dtype=np.float32)
        self.points = self.server.scene.add_point_cloud("/contacts/points", empty, (0, 0, 0),
                                                        point_size=0.01 * np.linalg.norm(camera["offset"]),
                                                        point_shape="circle", precision="float32")
        self.normals = self.server.scene.add_line_segments("/contacts/normals", np.zeros((1, 2, 3), np.float32),
                                                           (0, 119, 255), thickness=2.0, thickness_units="screen",
                                                           visible=False)
        self.forces = self.server.scene.add_line_segments("/contacts/forces", np.zeros((1, 2, 3), np.float32),
                                                          (208, 0, 0), thickness=3.0, thickness_units="screen")

        # the panel
        gui = self.server.gui
        self.play_button = gui.add_button("play / pause")
        self.step_button = gui.add_button("step")
        self.timeline = gui.add_slider("frame", min=0, max=max(self.frames - 1, 1), step=1, initial_value=0)
        self.speed_slider = gui.add_slider("speed", min=0.1, max=4.0, step=0.1, initial_value=1.0)
        self.show_points = gui.add_checkbox("contact points", True)
        self.show_normals = gui.add_checkbox("normals", False)
        self.show_forces = gui.add_checkbox("forces", True)
        self.clock = gui.add_markdown("")
        self.info = gui.add_markdown("*click a body to see its state*")
        self.play_button.on_click(lambda _: self.toggle())
        self.step_button.on_click(lambda _: self.step_once())
        self.timeline.on_update(self._scrub)
        self.speed_slider.on_update(lambda _: setattr(self, "speed", float(self.speed_slider.value)))
        for box in (self.show_points, self.show_normals, self.show_forces):
            box.on_update(lambda _: self.show(self.frame))
        self.show(0)

    # frames ------------------------------------------------------------------------------------
    @property
    def frames(self) -> int:
        """Frames available to show (a live scene gains one per step)."""
        return self.record.frames if self.record is not None else self.recorder.frames

    @property
    def live(self) -> bool:
        return self.recorder is not None

    def frame_data(self, f: int) -> dict:
        """time, positions, orientations, velocities, angular_velocities and contacts of frame f."""
        if self.record is not None:
            r = self.record
            return {"time": float(r.time[f]), "positions": r.positions[f], "orientations": r.orientations[f],
                    "velocities": r.velocities[f], "angular_velocities": r.angular_velocities[f],
                    "contacts": r.frame_contacts(f) if r.contacts is not None else None}
        return self.recorder.frame(f)

    def show(self, f: int) -> None:
        """Pose every body and draw the contacts of frame f."""
        with self._lock:
            f = int(max(0, min(self.frames - 1, f)))
            self.frame = f
            d = self.frame_data(f)
            with self.server.atomic():
                for i, handle in enumerate(self.bodies):
                    handle.position = tuple(float(x) for x in d["positions"][i])
                    handle.wxyz = tuple(float(x) for x in d["orientations"][i])
                c = d["contacts"] or {k: np.zeros((0, 3)) for k in CONTACT_KEYS}
                k = len(c["point"])
                self.points.visible = bool(self.show_points.value and k)
                self.normals.visible = bool(self.show_normals.value and k)
                self.forces.visible = bool(self.show_forces.value and k and self.force_scale > 0)
                if k:
                    p = np.asarray(c["point"], dtype=np.float32)
                    self.points.points = p
                    self.points.colors = np.zeros((k, 3), dtype=np.uint8)
                    self.normals.points = np.stack([p, p + self._normal_length * c["normal"]], axis=1).astype(np.float32)
                    self.forces.points = np.stack([p, p + self.force_scale * c["force"]], axis=1).astype(np.float32)
                self.timeline.max = max(self.frames - 1, 1)
                self.timeline.value = f  # calls _scrub with no client: ignored there
                self.clock.content = f"t = {d['time']:.3f} s, frame {f + 1} / {self.frames}, {k} contacts"
                self._describe()

    def _scrub(self, event) -> None:
        """The timeline moved: by a person (pause and show it) or by ``show`` itself (no client)."""
        if event.client is None:
            return
        self.playing = False
        self.show(int(self.timeline.value))

    def step_once(self) -> None:
        """One frame forward; at the last frame a live scene takes one more step of the simulator."""
        with self._lock:
            if self.frame < self.frames - 1:
                self.show(self.frame + 1)
            elif self.live:
                self.recorder.step(self.dt, 1)
                self.show(self.frames - 1)

    def toggle(self) -> None:
        """Play or pause."""
        self.playing = not self.playing
        if self.playing and not self.live and self.frame >= self.frames - 1:
            self.show(0)

    def select(self, i: int | None) -> None:
        """Show body i's state in the panel (None clears it)."""
        self.selected = i
        self._describe()

    def _describe(self) -> None:
        i = self.selected
        if i is None:
            return
        d = self.frame_data(self.frame)
        c = d["contacts"]
        touching = 0 if c is None else int(np.count_nonzero((c["body_a"] == i) | (c["body_b"] == i)))
        mass = self.base.masses[i]

        def vec(v):
            return "(" + ", ".join(f"{x:.4f}" for x in v) + ")"

        self.info.content = "\n".join([
            f"**{self.names[i]}** ({self.base.shapes[i]['type']}, "
            + ("static" if self.base.is_static[i] else f"{mass:.4g} kg") + ")",
            "",
            f"- position {vec(d['positions'][i])} m",
            f"- orientation (w, x, y, z) {vec(d['orientations'][i])}",
            f"- velocity {vec(d['velocities'][i])} m/s",
            f"- angular velocity {vec(d['angular_velocities'][i])} rad/s",
            f"- contacts {touching}",
        ])

    # serving -------------------------------------------------------------------------------------
    def _loop(self) -> None:
        """Advance one frame per frame interval / speed while playing."""
        while not self._stop.is_set():
            if self.playing:
                start = _time.perf_counter()
                if not self.live and self.frame >= self.frames - 1:
                    self.playing = False
                else:
                    self.step_once()
                wait = self.dt / max(self.speed, 1e-3) - (_time.perf_counter() - start)
                self._stop.wait(max(wait, 0.001))
            else:
                self._stop.wait(0.02)

    def start(self) -> None:
        """Start the playback thread (the server itself runs from construction)."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._loop, name="signorini-viewer", daemon=True)
            self._thread.start()

    def stop(self) -> None:
        """Stop playback and the server."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        self.server.stop()

    def serve_forever(self) -> None:
        """Serve until Ctrl-C."""
        self.start()
        try:
            while True:
                _time.sleep(0.5)
        except KeyboardInterrupt:
            pass
        finally:
            self.stop()


def _force_scale_of(record: Record, camera: dict) -> float:
    """Metres of arrow per newton: the record's own scale, or for a live scene (no forces yet) the
    weight of the heaviest dynamic body drawn a fifth of the view's size."""
    scale = default_force_scale(record)
    if scale > 0:
        return scale
    masses = [m for m, s in zip(record.masses, record.is_static) if not s]
    weight = max(masses, default=1.0) * max(float(np.linalg.norm(record.gravity)), 1.0)
    half_height = float(np.linalg.norm(camera["offset"])) * math.sin(math.radians(0.5 * camera["fov"]))
    return 0.2 * half_height / weight


# who may connect ------------------------------------------------------------------------------------
_LOOPBACK_NAMES = {"localhost", "localhost.localdomain", "ip6-localhost"}
_WILDCARDS = {"", "0.0.0.0", "::"}
_NETLOC = re.compile(r"(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9.-]+)(:[0-9]{1,5})?")  # host[:port], no user
_serving = threading.Lock()  # one viewer at a time wraps websockets' serve


def _is_loopback(name: str) -> bool:
    if name in _LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(name).is_loopback
    except ValueError:
        return False


def _is_address_or_own_name(name: str) -> bool:
    """An IP address, a loopback name or this machine's name: not a name a stranger's DNS serves."""
    try:
        ipaddress.ip_address(name)
        return True
    except ValueError:
        pass
    own = {socket.gethostname().lower(), socket.getfqdn().lower()}
    return _is_loopback(name) or name in own


def own_origin(origin: str | None, bind_host: str, port: int, host_header: str | None = None) -> bool:
    """True when a websocket request's ``Origin`` header is the page of this server: scheme http,
    this port, and the host it serves (any loopback name for a loopback bind; for a wildcard bind
    the host of the request's ``Host`` header, when that is an IP address, a loopback name or this
    machine's name: a foreign name could be DNS rebinding). Inputs: the header values (None when
    absent: refused), the host the server was bound to and the port it listens on."""
    if not origin:
        return False
    try:
        parts = urlsplit(origin.strip())
        origin_port = parts.port or 80
    except ValueError:
        return False
    name = (parts.hostname or "").lower()
    if parts.scheme != "http" or not _NETLOC.fullmatch(parts.netloc) or origin_port != port:
        return False
    if parts.path or parts.query or parts.fragment:
        return False
    bind = bind_host.strip("[]").lower()
    if _is_loopback(bind):
        return _is_loopback(name)
    if bind in _WILDCARDS:
        try:
            asked = urlsplit("//" + (host_header or "").strip())
            asked_name, asked_port = (asked.hostname or "").lower(), asked.port or 80
        except ValueError:
            return False
        return name == asked_name and asked_port == port and _is_address_or_own_name(name)
    return name == bind


@contextlib.contextmanager
def _origin_checked(bind_host: str):
    """While the viser server starts: its ``websockets.asyncio.server.serve`` call gets a
    ``process_request`` that answers a websocket request from a foreign ``Origin`` with 403 before
    the handshake (and hands every other request to viser's own). Yields a list that is non-empty
    once viser's serve went through the check."""
    import websockets.asyncio.server as ws_server

    applied = []
    original = ws_server.serve

    def serve(handler, *args, process_request=None, **kwargs):
        async def checked(connection, request):
            if request.headers.get_all("Upgrade"):  # only such a request can become a websocket
                port = connection.local_address[1]
                if not own_origin(request.headers.get("Origin"), bind_host, port, request.headers.get("Host")):
                    return connection.respond(http.HTTPStatus.FORBIDDEN,
                                              "the signorini viewer accepts connections from its own page only\n")
            response = process_request(connection, request) if process_request is not None else None
            return await response if inspect.isawaitable(response) else response

        applied.append(handler)
        return original(handler, *args, process_request=checked, **kwargs)

    with _serving:
        ws_server.serve = serve
        try:
            yield applied
        finally:
            ws_server.serve = original


@functools.lru_cache(maxsize=None)
def _local_server_class():
    """viser.ViserServer without its share URL (built on first use: viser is imported lazily)."""
    import viser

    class LocalServer(viser.ViserServer):
        """A viser server whose share URL is refused: a share request would open a public tunnel
        through viser's relay (share.viser.studio). ``refused_share_requests`` counts them."""

        refused_share_requests = 0

        def request_share_url(self, verbose: bool = True) -> None:
            self.refused_share_requests += 1
            return None

        def disconnect_share_url(self) -> None:
            return None

    return LocalServer
