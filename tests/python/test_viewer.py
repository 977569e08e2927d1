"""The interactive viewer: a real viser server on a local port, showing a recorded run of the core
and a scene simulated live; a real headless Chromium connects to it."""

import socket
import threading
import urllib.request

import numpy as np
import pytest
from playwright import sync_api as playwright

from signorini import output, scenes
from signorini.viewer import Viewer

from browser import launch


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def record():
    return output.run(scenes.build("boxes"), steps=60, progress=False, stride=2)


@pytest.fixture
def replay(record):
    viewer = Viewer(record, port=free_port())
    yield viewer
    viewer.stop()


def test_serves_the_client_and_builds_one_handle_per_body(replay, record):
    with urllib.request.urlopen(f"http://127.0.0.1:{replay.port}/", timeout=10) as response:
        assert response.status == 200
        assert b"<html" in response.read().lower()
    assert [h.name for h in replay.bodies] == [f"/bodies/{n}" for n in record.names]
    assert replay.frames == record.frames

    # scrubbing poses every body as recorded and draws that frame's contacts
    f = record.frames - 1
    replay.show(f)
    for i, handle in enumerate(replay.bodies):
        np.testing.assert_allclose(handle.position, record.positions[f, i], atol=1e-6)
        np.testing.assert_allclose(handle.wxyz, record.orientations[f, i], atol=1e-6)
    points = record.frame_contacts(f)["point"]
    np.testing.assert_allclose(replay.points.points, points, atol=1e-6)
    assert replay.forces.points.shape == (len(points), 2, 3)
    assert replay.timeline.value == f

    # single step moves one frame; clicking a body shows its state
    replay.show(3)
    replay.step_once()
    assert replay.frame == 4
    replay.select(1)
    assert record.names[1] in replay.info.content
    assert f"{record.positions[4, 1, 2]:.4f}" in replay.info.content


def test_live_scene_steps_the_simulator_and_can_be_scrubbed_back():
    viewer = Viewer(scenes.build("boxes"), port=free_port())
    try:
        world = viewer.scene.world
        assert viewer.live and viewer.frames == 1
        for _ in range(5):
            viewer.step_once()
        assert viewer.frames == 6 and world.time == pytest.approx(5 * viewer.dt)
        np.testing.assert_allclose(viewer.bodies[1].position, world.positions[1], atol=1e-6)
        viewer.show(2)   # back in time: the world stays where it is
        assert viewer.frame == 2 and viewer.frames == 6
        viewer.step_once()
        assert viewer.frame == 3 and world.time == pytest.approx(5 * viewer.dt)
    finally:
        viewer.stop()


@pytest.mark.slow
def test_a_browser_connects_to_the_viewer(replay):
    with playwright.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page()
            errors = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(f"http://127.0.0.1:{replay.port}/")
            for _ in range(100):
                if replay.server.get_clients():
                    break
                page.wait_for_timeout(100)
            assert len(replay.server.get_clients()) == 1
            assert errors == []
        finally:
            browser.close()


@pytest.mark.slow
def test_the_view_command_serves_a_trajectory_until_stopped(tmp_path, record):
    """``python -m signorini view FILE`` as a user runs it: it serves, then Ctrl-C ends it cleanly."""
    import os
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    import signorini

    path = record.save(tmp_path / "boxes.npz")
    port = free_port()
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(Path(signorini.__file__).resolve().parent.parent),
                                         env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    # the child gets Ctrl-C's default action even where pytest runs with SIGINT ignored (started in
    # the background by a non-interactive shell: its children inherit the ignore, and Python then
    # installs no KeyboardInterrupt handler, so the viewer would never stop)
    process = subprocess.Popen([sys.executable, "-m", "signorini", "view", str(path), "--port", str(port)],
                               stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=env,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    # the command prints its address once the viewer is built, then serves until Ctrl-C
    lines = []
    reader = threading.Thread(target=lambda: lines.extend(process.stdout), daemon=True)
    reader.start()
    try:
        deadline = time.monotonic() + 60
        while not any("Ctrl-C stops" in line for line in lines):
            assert process.poll() is None, "".join(lines)
            assert time.monotonic() < deadline, "the viewer did not start"
            time.sleep(0.1)
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=10) as response:
            assert response.status == 200
    finally:
        process.send_signal(signal.SIGINT)
        process.wait(timeout=30)
        reader.join(timeout=5)
    assert process.returncode == 0, "".join(lines)
    assert any(f"http://127.0.0.1:{port}" in line for line in lines)


# who may connect: the websocket controls the simulation, so only the viewer's own page may open it
def ws_connect(viewer, origin):
    """Opens the viewer's websocket as a page of `origin` would (None: no Origin header); returns
    the first message's size, or the HTTP status the server refused the handshake with."""
    import viser
    from websockets.exceptions import InvalidStatus
    from websockets.sync.client import connect

    try:
        with connect(f"ws://127.0.0.1:{viewer.port}", origin=origin, open_timeout=10,
                     subprotocols=[f"viser-v{viser.__version__}"]) as ws:
            return len(ws.recv(timeout=10))
    except InvalidStatus as e:
        return e.response.status_code


@pytest.mark.parametrize("origin", [None, "null", "http://evil.example", "http://evil.example:{port}",
                                    "http://127.0.0.1:{other}", "https://127.0.0.1:{port}", "http://127.0.0.2.nip.io:{port}",
                                    "http://localhost.evil.example:{port}", "file://", "http://[::1]x:{port}"])
def test_a_page_of_another_origin_is_refused_before_the_handshake(replay, origin):
    origin = None if origin is None else origin.format(port=replay.port, other=replay.port + 1)
    assert ws_connect(replay, origin) == 403
    assert replay.server.get_clients() == {}


@pytest.mark.parametrize("origin", ["http://127.0.0.1:{port}", "http://localhost:{port}", "http://LOCALHOST:{port}"])
def test_the_viewers_own_page_connects(replay, origin):
    assert ws_connect(replay, origin.format(port=replay.port)) > 0


@pytest.mark.parametrize("bind, origin, host, accepted", [
    ("127.0.0.1", "http://[::1]:8080", "[::1]:8080", True),
    ("localhost", "http://127.0.0.1:8080", "127.0.0.1:8080", True),
    ("192.168.1.5", "http://192.168.1.5:8080", "192.168.1.5:8080", True),
    ("192.168.1.5", "http://localhost:8080", "localhost:8080", False),
    ("0.0.0.0", "http://192.168.1.5:8080", "192.168.1.5:8080", True),
    ("0.0.0.0", "http://192.168.1.5:8080", "192.168.1.6:8080", False),
    ("0.0.0.0", "http://rebound.example:8080", "rebound.example:8080", False),  # DNS rebinding
    ("0.0.0.0", "http://192.168.1.5:9090", "192.168.1.5:9090", False),
    ("::", "http://[fe80::1]:8080", "[fe80::1]:8080", True),
])
def test_own_origin_for_each_kind_of_bind(bind, origin, host, accepted):
    from signorini.viewer import own_origin

    assert own_origin(origin, bind, 8080, host) is accepted


@pytest.mark.slow
def test_in_a_browser_only_the_viewers_own_page_opens_the_websocket(replay, tmp_path):
    """Chromium sends the Origin itself: from the viewer's page the websocket opens; from a page of
    another local server (another origin) it is refused and no client appears."""
    import functools
    import http.server

    import viser

    (tmp_path / "index.html").write_text("<html><body>another site</body></html>")
    other = http.server.ThreadingHTTPServer(
        ("127.0.0.1", free_port()), functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(tmp_path)))
    threading.Thread(target=other.serve_forever, daemon=True).start()
    opening = """([url, protocol]) => new Promise(resolve => {
        const ws = new WebSocket(url, [protocol]);
        ws.onopen = () => { ws.close(); resolve("open"); };
        ws.onerror = () => resolve("refused");
    })"""
    args = [f"ws://127.0.0.1:{replay.port}", f"viser-v{viser.__version__}"]
    try:
        with playwright.sync_playwright() as p:
            browser = launch(p)
            try:
                page = browser.new_page()
                page.goto(f"http://127.0.0.1:{other.server_address[1]}/")
                assert page.evaluate(opening, args) == "refused"
                assert replay.server.get_clients() == {}
                page.goto(f"http://127.0.0.1:{replay.port}/")
                assert page.evaluate(opening, args) == "open"
            finally:
                browser.close()
    finally:
        other.shutdown()
        other.server_close()


def test_the_share_url_is_off_and_a_share_request_reaches_nothing(replay, monkeypatch):
    """The served theme hides the share button, and a share request from the page (as the button
    sends it) is refused: no tunnel to viser's relay is ever made."""
    import time

    import msgspec
    import viser
    import viser._viser
    from websockets.sync.client import connect

    tunnels = []
    monkeypatch.setattr(viser._viser, "ViserTunnel", lambda *a, **k: tunnels.append(a) or pytest.fail(f"a tunnel {a}"))
    serializer = replay.server.get_scene_serializer()
    themes = [m for _, m in serializer._messages if m["type"] == "ThemeConfigurationMessage"]
    assert themes and themes[-1]["show_share_button"] is False

    with connect(f"ws://127.0.0.1:{replay.port}", origin=f"http://127.0.0.1:{replay.port}", open_timeout=10,
                 subprotocols=[f"viser-v{viser.__version__}"]) as ws:
        ws.send(msgspec.msgpack.encode({"type": "ShareUrlRequest"}))
        deadline = time.monotonic() + 30
        while replay.server.refused_share_requests == 0:
            assert time.monotonic() < deadline, "the share request was not handled"
            time.sleep(0.05)
    assert replay.server.request_share_url() is None
    assert tunnels == [] and replay.server._share_tunnel is None


def test_view_help_says_what_host_0_0_0_0_exposes(capsys):
    from signorini.cli import make_parser

    with pytest.raises(SystemExit):
        make_parser().parse_args(["view", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "0.0.0.0 serves every network interface: anyone on the network can view and control the simulation" in text
    assert "only the viewer's own page can open its websocket" in text and "share-URL feature (a public tunnel) is off" in text
