"""sg.decompose: CoACD in a worker process, with an estimate and a progress bar on stderr, a cache
keyed by the mesh and every setting, Ctrl-C that stops the worker, and pieces saved with the mesh.

CoACD runs for real here, on meshes it cuts in about a second (an L-shaped prism of 20 triangles)
or is stopped early on (a torus); nothing asserts on how long anything takes."""
import contextlib
import io
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import signorini as sg
from helpers import ell_arrays
from signorini import decomposition, meshes

pytest.importorskip("coacd")


def ell():
    """A closed, outward L-shaped prism (0.2 x 0.2 x 0.1 m, 20 triangles): not convex."""
    return sg.Mesh(*ell_arrays())


def torus():
    return sg.Mesh(*meshes.torus(0.3, 0.1, 24, 12))


# a convex piece for the stand-ins of the worker below
TETRAHEDRON = np.vstack([np.zeros(3), np.eye(3)]) * 0.1


@pytest.fixture(scope="module")
def first_run(tmp_path_factory):
    """The L decomposed once by CoACD into a fresh cache, with what it printed on stderr."""
    cache = tmp_path_factory.mktemp("cache")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SIGNORINI_CACHE", str(cache))
        printed = io.StringIO()
        with contextlib.redirect_stderr(printed):
            result = sg.decompose(ell())
    return cache, result, printed.getvalue()


@pytest.fixture
def cache(first_run, monkeypatch):
    monkeypatch.setenv("SIGNORINI_CACHE", str(first_run[0]))
    return first_run[0] / "coacd"


def test_the_first_run_prints_an_estimate_then_shows_progress(first_run):
    _, result, printed = first_run
    assert len(result.pieces) >= 2
    # the estimate, before CoACD starts: what runs, with which settings, what it costs, how to stop it
    head, _, bar = printed.partition("\n")
    assert head.startswith("signorini: decomposing a mesh of 20 triangles into convex pieces with CoACD "
                           "(threshold 0.05, max_pieces None, preprocess_resolution 50): expect ")
    assert "Ctrl-C stops it" in head and "cached in" in head
    # the bar: CoACD's rounds, its final pieces, and the count after merging
    assert "CoACD:" in bar and "round 1, cutting 1" in bar and "pieces final" in bar
    assert f"{len(result.pieces)} after merging" in bar
    # stderr here is not a terminal (as in a CI log): plain lines, a round each, no carriage returns
    assert "\r" not in printed and all(line.startswith("CoACD: ") for line in bar.splitlines())


def test_a_cached_mesh_prints_nothing_and_starts_no_worker(first_run, cache, monkeypatch, capsys):
    monkeypatch.setattr(decomposition.subprocess, "Popen", lambda *a, **k: pytest.fail("a worker was started"))
    again = sg.decompose(ell())
    assert all(np.array_equal(a, b) for a, b in zip(again.pieces, first_run[1].pieces))
    assert len(again.pieces) == len(first_run[1].pieces)
    assert capsys.readouterr().err == ""


def test_the_cache_is_keyed_by_the_mesh_and_every_setting(first_run, cache, monkeypatch):
    runs = []

    def fake_worker(vertices, faces, settings, progress):
        runs.append(settings)
        return [TETRAHEDRON]

    monkeypatch.setattr(decomposition, "_run_worker", fake_worker)
    sg.decompose(ell())                       # the first run's settings: read from the cache
    assert runs == []
    variants = [dict(threshold=0.1), dict(max_pieces=1), dict(preprocess_resolution=30), dict(seed=1)]
    for settings in variants:
        sg.decompose(ell(), progress=False, **settings)
    assert [(r["threshold"], r["max_convex_hull"], r["preprocess_resolution"], r["seed"]) for r in runs] == \
        [(0.1, -1, 50, 0), (0.05, 1, 50, 0), (0.05, -1, 30, 0), (0.05, -1, 50, 1)]
    # each setting its own entry, read back the second time
    for settings in variants:
        sg.decompose(ell(), progress=False, **settings)
    assert len(runs) == 4 and len(list(cache.glob("*.npz"))) == 5
    # another mesh (the L moved by 1 mm), and another CoACD version, are other entries too
    moved = sg.Mesh(np.asarray(ell().vertices) + 0.001, ell().faces)
    sg.decompose(moved, progress=False)
    monkeypatch.setattr(decomposition, "_coacd_version", lambda: "99.0")
    sg.decompose(ell(), progress=False)
    assert len(runs) == 6


def test_progress_false_prints_nothing(cache, monkeypatch, capsys):
    monkeypatch.setattr(decomposition, "_run_worker", lambda *a: [TETRAHEDRON])
    sg.decompose(ell(), threshold=0.3, progress=False)
    assert capsys.readouterr().err == ""


def test_decompose_once_save_and_load_the_pieces_with_the_mesh(first_run, cache, tmp_path, monkeypatch):
    decomposed = first_run[1]
    path = sg.save_mesh(decomposed, tmp_path / "ell.npz")
    monkeypatch.setattr(decomposition, "convex_pieces", lambda *a, **k: pytest.fail("decomposed again"))
    loaded = sg.load_mesh(path)
    np.testing.assert_array_equal(loaded.vertices, decomposed.vertices)
    np.testing.assert_array_equal(loaded.faces, decomposed.faces)
    assert len(loaded.pieces) == len(decomposed.pieces)
    assert all(np.array_equal(a, b) for a, b in zip(loaded.pieces, decomposed.pieces))
    w = sg.World(gravity=(0, 0, -9.81))
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    b = w.add_body(loaded, density=500.0, position=(0, 0, 0.3))
    w.step(1 / 240, 240)
    # it lands flat on its pieces: the L's 0.1 m thickness, its centre of mass half of it up
    assert w.positions[b][2] == pytest.approx(0.05, abs=2e-3)


def test_bad_settings_are_refused_naming_the_setting():
    for settings, error, words in [(dict(threshold=0.0), ValueError, "threshold"), (dict(threshold=2), ValueError, "threshold"),
                                   (dict(max_pieces=0), ValueError, "max_pieces"),
                                   (dict(max_pieces=2.5), TypeError, "max_pieces"),
                                   (dict(preprocess_resolution=5), ValueError, "preprocess_resolution"),
                                   (dict(seed=-1), ValueError, "seed")]:
        with pytest.raises(error, match=words):
            sg.decompose(ell(), **settings)
    with pytest.raises(TypeError, match="Mesh"):
        sg.decompose(sg.Sphere(1.0))


def test_a_failing_worker_is_a_runtime_error_with_its_last_words(cache, tmp_path, monkeypatch):
    script = tmp_path / "failing_worker.py"
    script.write_text("import sys\nprint('CoACD could not read the mesh')\nsys.exit(1)\n")
    monkeypatch.setattr(decomposition, "_WORKER", script)
    entries = sorted(cache.glob("*.npz"))
    with pytest.raises(RuntimeError, match=r"CoACD failed \(worker exit status 1\): CoACD could not read the mesh"):
        sg.decompose(ell(), threshold=0.5, progress=False)
    # add_body names the body, and adds nothing (a larger L: not in the cache)
    w = sg.World()
    with pytest.raises(RuntimeError, match=r"body 0 \(Mesh\): decompose: CoACD failed"):
        w.add_body(sg.Mesh(2.0 * np.asarray(ell().vertices), ell().faces), density=1.0)
    assert w.num_bodies == 0 and sorted(cache.glob("*.npz")) == entries


def test_keyboard_interrupt_terminates_the_worker_and_caches_nothing(tmp_path, monkeypatch):
    monkeypatch.setenv("SIGNORINI_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    workers = []

    class Recorded(subprocess.Popen):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            workers.append(self)

    feed = decomposition._Progress.feed

    def interrupted(self, line):
        # Ctrl-C as CoACD starts its first round (a torus takes seconds more)
        if "waiting pool" in line:
            raise KeyboardInterrupt
        return feed(self, line)

    monkeypatch.setattr(decomposition.subprocess, "Popen", Recorded)
    monkeypatch.setattr(decomposition._Progress, "feed", interrupted)
    with pytest.raises(KeyboardInterrupt):
        sg.decompose(torus(), progress=False)
    assert len(workers) == 1 and workers[0].returncode == -signal.SIGTERM   # terminated, not finished
    # the same through add_body: the body is not added
    w = sg.World()
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    with pytest.raises(KeyboardInterrupt):
        w.add_body(torus(), density=100.0)
    assert w.num_bodies == 1 and len(workers) == 2 and workers[1].returncode == -signal.SIGTERM
    assert not (tmp_path / "cache").exists()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith("signorini-coacd-")] == []


def children(pid: int) -> list:
    """Process ids whose parent is pid (Linux /proc)."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rpartition(")")[2].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            found.append(int(stat.parent.name))
    return found


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_ctrl_c_in_a_program_stops_its_worker(tmp_path):
    # a program decomposing a torus gets SIGINT (Ctrl-C) once its worker runs: it ends with
    # KeyboardInterrupt, and the worker (in its own session, so only the program can stop it) is gone
    program = ("import signorini as sg\nfrom signorini import meshes\n"
               "sg.decompose(sg.Mesh(*meshes.torus(0.3, 0.1, 24, 12)))\n")
    env = dict(os.environ, SIGNORINI_CACHE=str(tmp_path / "cache"), TMPDIR=str(tmp_path),
               PYTHONPATH=os.pathsep.join([str(Path(sg.__file__).parents[1]), os.environ.get("PYTHONPATH", "")]))
    # the program starts with Ctrl-C's default disposition, as from a terminal: a test run launched
    # in the background (``cmd &`` in a script) ignores SIGINT, and a child would inherit that
    parent = subprocess.Popen([sys.executable, "-c", program], env=env, stderr=subprocess.PIPE, text=True,
                              preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    err = []
    reader = threading.Thread(target=lambda: err.extend(iter(lambda: parent.stderr.read(1), "")))
    reader.start()
    try:
        # the bar appears once the worker has started CoACD and the program reads its progress
        while "CoACD:" not in "".join(err) and parent.poll() is None:
            time.sleep(0.05)
        worker = children(parent.pid)
        assert len(worker) == 1, "no worker running: " + "".join(err)
        parent.send_signal(signal.SIGINT)
        parent.wait(timeout=120)
    finally:
        if parent.poll() is None:
            parent.kill()
        reader.join()
    err = "".join(err)
    assert parent.returncode != 0 and err.rstrip().endswith("KeyboardInterrupt")
    with pytest.raises(ProcessLookupError):
        os.kill(worker[0], 0)
    assert not (tmp_path / "cache").exists()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith("signorini-coacd-")] == []
