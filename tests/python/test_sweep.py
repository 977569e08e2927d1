"""Sweeps (signorini.sweeps, issue 22): rows bit for bit equal to the same runs done serially,
failing runs recorded without sinking the sweep, resuming, bad input refused before any run, and
a real Ray cluster (a head started by its own command, inside a loopback-only network namespace)."""
import math
import os
import shutil
import socket
import subprocess
import sys
import textwrap
from pathlib import Path

import pandas as pd
import pytest

import signorini as sg
from helpers import SLOPE_ANGLE, down_slope_speed, slope_box
from signorini import sweeps as sw

G = 9.81
ANGLE = SLOPE_ANGLE
slope, along_slope = slope_box, down_slope_speed


def failing(seed: int, friction: float):
    """slope(), except friction 0.2 raises in build and friction 0.3 goes non-finite (a force that
    overflows the velocity: the core undoes the step and raises)."""
    if friction == 0.2:
        raise RuntimeError("no such box")
    w = slope(seed, friction)
    if friction == 0.3:
        w.set_external_wrench(1, force=(1.7e308, 0.0, 0.0))
    return w


def no_ray(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` raises ImportError


def test_rows_equal_serial_runs_bit_for_bit_and_friction_gives_its_acceleration(tmp_path, monkeypatch):
    no_ray(monkeypatch)
    grid = {"friction": [0.04, 0.09, 0.16]}   # sqrt(1 mu): 0.2, 0.3, 0.4 (all below tan 25 = 0.466: it slides)
    steps, dt = 120, 1.0 / 240.0
    with pytest.warns(RuntimeWarning, match="Ray is not installed"):
        table = sg.sweep(slope, grid, steps=steps, dt=dt, seeds=2, metrics=along_slope, out=tmp_path / "r.parquet",
                         processes=2)
    assert list(table["friction"]) == [0.04, 0.04, 0.09, 0.09, 0.16, 0.16]
    assert list(table["seed"]) == [0, 1] * 3
    assert (table["status"] == "ok").all() and (table["error"] == "").all()
    assert (table["steps_done"] == steps).all()
    for _, row in table.iterrows():
        serial = sw.run_one(slope, {"friction": row["friction"]}, int(row["seed"]), steps, dt, along_slope)
        assert serial["state_hash"] == row["state_hash"]
        assert serial["positions"] == [list(p) for p in row["positions"]]
        # g (sin - mu cos) over the run (the box starts at rest on the slope)
        mu = math.sqrt(row["friction"])
        expected = G * (math.sin(ANGLE) - mu * math.cos(ANGLE)) * steps * dt
        assert row["speed"] == pytest.approx(expected, rel=0.01)
    assert table["state_hash"].nunique() == 6   # the seed moves the start
    assert pd.read_parquet(tmp_path / "r.parquet")["state_hash"].tolist() == table["state_hash"].tolist()
    assert not (tmp_path / "r.parquet.parts").exists()


def test_a_run_that_raises_and_one_that_goes_nonfinite_are_rows_and_the_rest_completes(monkeypatch):
    no_ray(monkeypatch)
    with pytest.warns(RuntimeWarning):
        table = sg.sweep(failing, {"friction": [0.1, 0.2, 0.3, 0.4]}, steps=30, dt=1 / 240, processes=2)
    status = dict(zip(table["friction"], table["status"]))
    assert status == {0.1: "ok", 0.2: "build_error", 0.3: "nonfinite", 0.4: "ok"}
    error = dict(zip(table["friction"], table["error"]))
    assert "RuntimeError: no such box" in error[0.2]
    assert "non-finite" in error[0.3]


def pushed_sphere(seed: int, force: float):
    """A free sphere pushed by a constant force: at 1e307 N its velocity overflows at step 2945."""
    w = sg.World(gravity=(0, 0, 0))
    w.add_body(sg.Sphere(0.1), density=1000.0, position=(0, 0, 1))
    w.set_external_wrench(0, force=(force, 0.0, 0.0))
    return w


def test_a_run_that_fails_mid_way_names_the_step_and_keeps_the_state_single_steps_would():
    # run_one steps in blocks; the row must still be that of stepping one step at a time
    world = pushed_sphere(0, 1e307)
    for k in range(3000):
        try:
            world.step(1 / 240)
        except RuntimeError as e:
            failed, message = k, str(e)
            break
    assert 0 < failed < 3000 and "non-finite" in message
    row = sw.run_one(pushed_sphere, {"force": 1e307}, 0, 3000, 1 / 240)
    assert row["status"] == "nonfinite" and row["steps_done"] == failed
    assert row["error"].startswith(f"step {failed} (t = {world.time:.6g} s): RuntimeError: ")
    assert row["state_hash"] == sw.state_hash(world)


def test_a_timeout_is_a_row(monkeypatch):
    no_ray(monkeypatch)
    row = sw.run_one(slope, {"friction": 0.5}, 0, steps=10 ** 7, dt=1 / 240, timeout=0.2)
    assert row["status"] == "timeout" and 0 < row["steps_done"] < 10 ** 7
    assert "still running after 0.2 s" in row["error"]


def test_a_sweep_started_again_runs_only_what_is_missing(tmp_path, monkeypatch):
    no_ray(monkeypatch)
    out = tmp_path / "r.parquet"
    grid = {"friction": [0.1, 0.5]}
    with pytest.warns(RuntimeWarning):
        full = sg.sweep(slope, grid, steps=20, dt=1 / 240, seeds=2, chunk=1, processes=1)
    # an interrupted sweep: the parts of two runs on disk, no table yet
    parts = tmp_path / "r.parquet.parts"
    parts.mkdir()
    done = full[full["friction"] == 0.1].to_dict("records")
    for k, row in enumerate(done):
        pd.DataFrame([row]).to_parquet(parts / f"runs-{k:08d}.parquet", index=False)
    calls = []

    def counting(seed, friction):
        calls.append((friction, seed))
        return slope(seed, friction)

    with pytest.warns(RuntimeWarning):
        again = sg.sweep(counting, grid, steps=20, dt=1 / 240, seeds=2, out=out, chunk=1, processes=1)
    # the forked workers called it: count by the rows instead (the driver's list stays empty)
    assert calls == []
    assert again["state_hash"].tolist() == full["state_hash"].tolist()
    assert not parts.exists() and out.exists()
    # a third start finds everything done: nothing runs (a build that would fail is never called)
    third = sg.sweep(failing, {"friction": [0.1, 0.5]}, steps=20, dt=1 / 240, seeds=2, out=out)
    assert (third["status"] == "ok").all()
    assert third["state_hash"].tolist() == full["state_hash"].tolist()


def test_task_sizes_amortise_the_per_task_cost_and_shrink_towards_the_end():
    # before any run is measured: a few runs, to learn what a run costs
    assert sw.task_size(1000, 2, None) == sw._FIRST_TASK_RUNS
    assert sw.task_size(1, 2, None) == 1
    # 3 ms runs: a quarter per worker of what is left, but never below 0.1 s of runs
    assert sw.task_size(1000, 2, 0.003) == 125
    assert sw.task_size(200, 2, 0.003) == math.ceil(0.1 / 0.003)
    assert sw.task_size(10, 2, 0.003) == 10             # never more than is left
    # long runs: never above 10 s of runs a task (progress and resumable parts keep coming)
    assert sw.task_size(10 ** 6, 2, 1.0) == 10
    assert sw.task_size(10 ** 6, 2, 60.0) == 1


def test_the_scheduler_gives_every_job_once_in_order_and_keeps_two_tasks_per_worker():
    jobs = [(i, {"run": i}, 0) for i in range(1000)]
    queued, sizes, most, got = [], [], [0], []

    def submit(some):
        queued.append(some)
        sizes.append(len(some))
        most[0] = max(most[0], len(queued))

    def wait_one():
        return [{"_index": i, "wall": 0.003} for i, _, _ in queued.pop(0)]

    sw._schedule(jobs, 2, None, submit, wait_one, got.extend)
    assert [r["_index"] for r in got] == list(range(1000))
    assert sizes[:4] == [sw._FIRST_TASK_RUNS] * 4 and max(sizes) == 124 and min(sizes[4:]) == sizes[-1]
    assert most[0] == 2 * sw._IN_FLIGHT
    got.clear()
    sizes.clear()
    sw._schedule(jobs, 2, 300, submit, wait_one, got.extend)    # chunk given: that many
    assert sizes == [300, 300, 300, 100] and len(got) == 1000


@pytest.mark.parametrize("kwargs, message", [
    ({"grid": {"friction": []}}, "grid parameter 'friction': the list of values is empty"),
    ({"grid": {"friction": 0.5}}, "grid parameter 'friction': give a list of values"),
    ({"grid": [0.1]}, "grid must map parameter names"),
    ({"grid": {"status": [1]}}, "grid parameter 'status': the name is taken"),
    ({"seeds": 0}, "seeds must be >= 1"),
    ({"seeds": [1, 1]}, "seeds has duplicates"),
    ({"seeds": [0.5]}, "seeds must be a count >= 1 or a non-empty list of integers"),
    ({"steps": 0}, "steps must be an integer >= 1"),
    ({"dt": float("nan")}, "dt must be a finite number > 0"),
    ({"out": "results.csv"}, "out must be a .parquet file"),
    ({"metrics": 3}, "metrics must be callable"),
    ({"address": "nohost"}, "address must be HOST:PORT"),
])
def test_bad_input_is_refused_before_any_run(kwargs, message):
    called = []

    def build(seed, friction):
        called.append(seed)
        return slope(seed, friction)

    args = {"build": build, "grid": {"friction": [0.5]}, "steps": 10, "dt": 1 / 240, **kwargs}
    with pytest.raises(sg.SweepError, match=message.replace("(", r"\(").replace(")", r"\)")):
        sg.sweep(**args)
    assert called == []


def test_an_address_that_does_not_answer_is_named():
    with socket.socket() as s:   # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with pytest.raises(sg.SweepError, match=f"no Ray cluster answers at address '127.0.0.1:{port}'"):
        sg.sweep(slope, {"friction": [0.5]}, steps=10, dt=1 / 240, address=f"127.0.0.1:{port}")


def test_parse_values():
    assert sw.parse_values("0.1:0.9:5", "x") == pytest.approx([0.1, 0.3, 0.5, 0.7, 0.9])
    assert sw.parse_values("1,2.5,pgs,true", "x") == [1, 2.5, "pgs", True]
    with pytest.raises(sg.SweepError, match="--set a: 'a:b:n' needs two numbers and a count"):
        sw.parse_values("0:x:3", "--set a")
    with pytest.raises(sg.SweepError, match="an empty value"):
        sw.parse_values("1,,2", "x")


def package_path(*first: str) -> str:
    """A PYTHONPATH with `first`, then the folder of the signorini package this test imports."""
    root = str(Path(sg.__file__).resolve().parent.parent)
    return os.pathsep.join([*first, root, *filter(None, [os.environ.get("PYTHONPATH")])])


def run_cli(*args, cwd, env=None):
    return subprocess.run([sys.executable, "-m", "signorini", *args], cwd=cwd, capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": package_path(), **(env or {})}, timeout=600)


def test_cli_sweep_of_a_scene_file_and_its_errors(tmp_path):
    # without Ray (a stand-in module that fails to import), in local processes
    stub = tmp_path / "noray"
    stub.mkdir()
    (stub / "ray.py").write_text("raise ImportError('ray hidden by the test')\n")
    env = {"PYTHONPATH": package_path(str(stub))}
    got = run_cli("sweep", "boxes", "--set", "bodies.flat_box.friction=0.1,0.9", "--set", "world.gravity.2=-9.81,-1.62",
                  "--seeds", "2", "--steps", "120", "--chunk", "3", "--out", str(tmp_path / "r.parquet"), "--quiet",
                  cwd=tmp_path, env=env)
    assert got.returncode == 0, got.stderr
    assert "8 runs (8 ok)" in got.stdout
    table = pd.read_parquet(tmp_path / "r.parquet")
    assert list(table.columns[:2]) == ["bodies.flat_box.friction", "world.gravity.2"]
    assert len(table) == 8 and table["state_hash"].nunique() == 8
    # errors name the parameter and change nothing
    for settings, message in [(["--set", "bodies.nobody.friction=0.1"], "'bodies.nobody' is not there"),
                              (["--set", "world.nothing.x=1"], "'world.nothing' is not there"),
                              (["--set", "bodies.flat_box.friction=-1"], "friction"),
                              (["--set", "friction"], "give PATH=SPEC")]:
        bad = run_cli("sweep", "boxes", *settings, "--steps", "2", "--out", str(tmp_path / "bad.parquet"),
                      cwd=tmp_path, env=env)
        assert bad.returncode == 2 and message in bad.stderr, bad.stderr
        assert not (tmp_path / "bad.parquet").exists()


RAY_DRIVER = '''
import math, os, signal, subprocess, sys, time
import numpy as np
sys.path.insert(0, {tests!r})
import signorini as sg
from signorini import sweeps as sw
from helpers import slope_box as slope, down_slope_speed as along_slope

port = {port}
# the workers the head starts import tests/python/helpers.py (slope, along_slope are pickled by name)
env = dict(os.environ, RAY_USAGE_STATS_ENABLED="0", RAY_AUTH_MODE="disabled",
           PYTHONPATH=os.pathsep.join([{tests!r}, os.environ["PYTHONPATH"]]))
subprocess.run(["ip", "link", "set", "lo", "up"], check=True)
subprocess.run(["ray", "start", "--head", "--port", str(port), "--num-cpus", "2", "--node-ip-address", "127.0.0.1",
                "--include-dashboard", "false", "--disable-usage-stats"], check=True, env=env,
               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
try:
    marker = {marker!r}

    def dies_once(world):
        # the first run to get here kills its own worker process (as an OOM killer or a lost node
        # would): Ray retries the task, and the retried run gives the same row
        if not os.path.exists(marker):
            open(marker, "w").close()
            os.kill(os.getpid(), signal.SIGKILL)
        return along_slope(world)

    grid = {{"friction": [0.04, 0.09, 0.16, 0.25]}}
    table = sg.sweep(slope, grid, steps=60, dt=1 / 240, seeds=2, metrics=dies_once,
                     address=f"127.0.0.1:{{port}}", chunk=1)
    assert os.path.exists(marker)
    assert (table["status"] == "ok").all(), table[["status", "error"]]
    for _, row in table.iterrows():
        serial = sw.run_one(slope, {{"friction": row["friction"]}}, int(row["seed"]), 60, 1 / 240, along_slope)
        assert serial["state_hash"] == row["state_hash"], (row["friction"], row["seed"])
        assert serial["speed"] == row["speed"]
    print("RAY SWEEP OK", len(table))
finally:
    subprocess.run(["ray", "stop", "--force"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
'''


@pytest.mark.slow
def test_a_real_ray_cluster_gives_the_serial_rows_and_survives_a_killed_worker(tmp_path):
    if shutil.which("ray") is None or shutil.which("unshare") is None or os.geteuid() != 0:
        pytest.skip("needs the ray command, unshare and root (README command 2 installs Ray; CI runs as root)")
    driver = tmp_path / "driver.py"
    driver.write_text(textwrap.dedent(RAY_DRIVER.format(tests=str(Path(__file__).parent), port=6391,
                                                        marker=str(tmp_path / "killed"))))
    # a network namespace of the test's own with only loopback up: every address Ray binds and
    # dials is 127.0.0.1; and a process namespace of its own (its own /proc): `ray stop --force`
    # stops every Ray process it can see, which would otherwise be every Ray on the machine (another
    # test's, a benchmark's, a user's)
    got = subprocess.run(["unshare", "-n", "-p", "-f", "--mount-proc", sys.executable, str(driver)],
                         capture_output=True, text=True, timeout=600, cwd=tmp_path,
                         env={**os.environ, "PYTHONPATH": package_path(), "RAY_USAGE_STATS_ENABLED": "0",
                              "RAY_AUTH_MODE": "disabled"})
    assert got.returncode == 0, got.stdout[-3000:] + got.stderr[-3000:]
    assert "RAY SWEEP OK 8" in got.stdout


LOCAL_RAY_DRIVER = '''
import subprocess, sys
sys.path.insert(0, {tests!r})
import signorini as sg
from signorini import sweeps as sw
from helpers import slope_box as slope, down_slope_speed as along_slope

subprocess.run(["ip", "link", "set", "lo", "up"], check=True)
grid = {{"friction": [0.04, 0.16]}}
table = sg.sweep(slope, grid, steps=60, dt=1 / 240, seeds=3, metrics=along_slope)
assert (table["status"] == "ok").all(), table[["status", "error"]]
for _, row in table.iterrows():
    serial = sw.run_one(slope, {{"friction": row["friction"]}}, int(row["seed"]), 60, 1 / 240, along_slope)
    assert serial["state_hash"] == row["state_hash"], (row["friction"], row["seed"])
print("LOCAL RAY SWEEP OK", len(table))
'''


@pytest.mark.slow
def test_without_an_address_a_sweep_starts_its_own_local_ray_whatever_ray_address_says(tmp_path):
    pytest.importorskip("ray")
    if shutil.which("unshare") is None or os.geteuid() != 0:
        pytest.skip("needs unshare and root (a local Ray only in a loopback-only network namespace)")
    with socket.socket() as s:   # a port nobody listens on: a cluster that has gone
        s.bind(("127.0.0.1", 0))
        gone = f"127.0.0.1:{s.getsockname()[1]}"
    driver = tmp_path / "driver.py"
    driver.write_text(textwrap.dedent(LOCAL_RAY_DRIVER.format(tests=str(Path(__file__).parent))))
    got = subprocess.run(["unshare", "-n", sys.executable, str(driver)], capture_output=True, text=True,
                         timeout=600, cwd=tmp_path,
                         env={**os.environ, "PYTHONPATH": package_path(str(Path(__file__).parent)),
                              "RAY_USAGE_STATS_ENABLED": "0", "RAY_AUTH_MODE": "disabled", "RAY_ADDRESS": gone})
    assert got.returncode == 0, got.stdout[-3000:] + got.stderr[-3000:]
    assert "LOCAL RAY SWEEP OK 6" in got.stdout
