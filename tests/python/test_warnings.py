"""SolverWarning: the built-in scenes run without it, it names the user's line, says what to change,
comes once per world, and a filter or ``run --quiet`` silences it (issue 25, "warnings that help")."""

import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import signorini as sg
from signorini import decomposition, meshes, output, scenes
from signorini.trajectory import Recorder


def flagging_stack(**solver):
    """Four boxes stacked on the ground with one sweep a step: every substep ends unconverged with
    the boxes still approaching each other, so it flags under a tiny warn_velocity."""
    w = sg.World(gravity=(0, 0, -9.81), max_iterations=1, tolerance=1e-12, warn_velocity=1e-9, **solver)
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    for k in range(4):
        w.add_body(sg.Box((0.1, 0.1, 0.1)), mass=1.0, position=(0.01 * k, 0, 0.1 + 0.2 * k))
    return w


# the first step at which each pile flagged a substep under the former default, warn_velocity =
# 0.01 m/s (measured: hull_pile 90, pile 68, rain 89); each run below goes past it
PILES = [("hull_pile", 100), ("pile", 100), pytest.param("rain", 100, marks=pytest.mark.slow)]


@pytest.mark.parametrize("name, steps", PILES)
def test_a_built_in_pile_runs_without_a_warning(name, steps):
    scene = scenes.build(name)
    assert scene.world.solver["warn_velocity"] == sg.World().solver["warn_velocity"] == 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any warning fails the test
        output.run(scene, steps=steps, progress=False)
    # the same run warned under the former threshold: this run is one that warned before
    former = scenes.build(name)
    former.world.set_solver(warn_velocity=0.01)
    with pytest.warns(sg.SolverWarning):
        output.run(former, steps=steps, progress=False)


@pytest.mark.parametrize("how", ["World.step", "Recorder.step", "output.run"])
def test_the_warning_names_the_users_line(how):
    w = flagging_stack(solver="pgs")  # the PGS: only it raises the unconverged warning
    with pytest.warns(sg.SolverWarning) as caught:
        if how == "World.step":
            w.step(1 / 240, 10)
        elif how == "Recorder.step":
            Recorder(w).step(1 / 240, 10)
        else:
            output.run(scenes.Scene(name="stack", world=w, dt=1 / 240, steps=10, description="a stack"), progress=False)
    caught = [c for c in caught if c.category is sg.SolverWarning]
    assert len(caught) == 1
    assert caught[0].filename == __file__, caught[0].filename


def test_the_warning_says_what_to_change_and_comes_once_per_world():
    w = flagging_stack(solver="pgs")  # the PGS: only it raises the unconverged warning
    with pytest.warns(sg.SolverWarning) as caught:
        for _ in range(20):
            w.step(1 / 240)
    assert len(caught) == 1
    text = str(caught[0].message)
    for advice in ("raise max_iterations or substeps", "lower dt", "World.unconverged_substeps",
                   "warnings.filterwarnings('ignore', category=signorini.SolverWarning)"):
        assert advice in text
    assert w.unconverged_substeps == 80  # every flagged substep counted, 4 a step
    # new settings warn again, once
    w.set_solver(max_iterations=2)
    with pytest.warns(sg.SolverWarning) as caught:
        w.step(1 / 240, 5)
    assert len(caught) == 1


def test_a_warnings_filter_silences_it_and_the_count_goes_on():
    w = flagging_stack(solver="pgs")  # the PGS: only it flags unconverged substeps
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warnings.filterwarnings("ignore", category=sg.SolverWarning)
        w.step(1 / 240, 10)
    assert caught == [] and w.unconverged_substeps == 40


def run_cli(*args):
    """``python -m signorini *args`` with the package this test imports."""
    env = dict(os.environ)
    root = str(Path(sg.__file__).resolve().parent.parent)
    env["PYTHONPATH"] = os.pathsep.join([root, env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return subprocess.run([sys.executable, "-m", "signorini", *args], capture_output=True, text=True, env=env,
                          timeout=600)


@pytest.mark.slow
def test_run_quiet_prints_nothing_of_the_warning(tmp_path):
    path = tmp_path / "stack.toml"
    flagging_stack(solver="pgs").save_scene(path)  # the file says solver = "pgs": only it raises the warning
    loud = run_cli("run", str(path), "--steps", "20", "--out", str(tmp_path / "loud"), "--no-html", "--no-plot")
    assert loud.returncode == 0 and "SolverWarning" in loud.stderr
    quiet = run_cli("run", str(path), "--steps", "20", "--out", str(tmp_path / "quiet"), "--no-html", "--no-plot",
                    "--quiet")
    assert quiet.returncode == 0 and quiet.stderr == ""
    assert "written" in quiet.stdout


def test_quiet_decomposition_prints_no_estimate(tmp_path, monkeypatch, capsys):
    """Inside decomposition.quiet() (run --quiet) a decomposition prints neither its estimate nor
    its bar; outside it prints the estimate. CoACD's worker is replaced by a stand-in here."""
    monkeypatch.setenv("SIGNORINI_CACHE", str(tmp_path))
    seen = []

    def worker(vertices, faces, settings, progress):
        seen.append(progress)
        return [np.asarray(vertices)]

    monkeypatch.setattr(decomposition, "_run_worker", worker)
    mesh = sg.Mesh(*meshes.torus(0.3, 0.1, 12, 6))
    with decomposition.quiet():
        decomposition.convex_pieces(mesh, threshold=0.2)
    assert capsys.readouterr().err == "" and seen == [False]
    decomposition.convex_pieces(mesh, threshold=0.3)
    assert "decomposing a mesh" in capsys.readouterr().err and seen == [False, True]
