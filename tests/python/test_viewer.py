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
    process = subprocess.Popen([sys.executable, "-m", "signorini", "view", str(path), "--port", str(port)],
                               stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=env)
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
