"""benchmarks/bench_joints.py runs end to end at its --tiny size in a child process (its figures are
printed, never asserted on time): a table row per scene and engine with finite figures, and a
line per signorini and MuJoCo row on its energy. pybullet's rows are there when it is installed,
MuJoCo's (joint_grid only) when it is; its MJCF twin is the same grid as signorini's."""
import importlib.util
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import load_benchmark

import signorini

ROOT = Path(__file__).resolve().parents[2]


def test_tiny_run_prints_its_table():
    env = dict(os.environ, PYTHONPATH=str(Path(signorini.__file__).resolve().parent.parent))
    got = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_joints.py"), "--tiny", "--chunks", "2"],
                         capture_output=True, text=True, env=env, timeout=600)
    assert got.returncode == 0, got.stderr
    lines = got.stdout.splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("scene"))
    columns = re.split(r"\s{2,}", lines[header].strip())
    assert columns[:8] == ["scene", "engine", "bodies", "joints", "steps", "ms/step", "25-75 %", "sg/this"]
    engines = ["signorini", "signorini soft", "signorini soft60"]
    if importlib.util.find_spec("pybullet") is not None:
        engines.append("pybullet")
    mujoco = ["mujoco"] if importlib.util.find_spec("mujoco") is not None else []
    expected = [(scene, engine) for scene in ("joint_grid", "ragdolls")
                for engine in engines + (mujoco if scene == "joint_grid" else [])]
    table = [dict(zip(columns, re.split(r"\s{2,}", line.strip()))) for line in lines[header + 1:header + 1 + len(expected)]]
    assert [(row["scene"], row["engine"]) for row in table] == expected
    for row in table:
        assert int(row["steps"]) == 10 and int(row["joints"]) > 0
        for key in ("ms/step", "sg/this", "sep end m", "KE end J"):
            assert math.isfinite(float(row[key])) and float(row[key]) >= 0, (row["scene"], row["engine"], key)
        if row["engine"] != "pybullet":
            assert math.isfinite(float(row["E rise J"])), row
    for scene, engine in expected:
        if engine != "pybullet":
            assert any(line.startswith(f"{scene}, {engine}: energy ") for line in lines), (scene, engine)


def test_the_mujoco_twin_is_the_same_grid():
    # every moving sphere once with its mass and inertia, every ball joint once (a tree joint down
    # each column, a connect for each sideways link), all in signorini's places, the same energy
    mujoco = pytest.importorskip("mujoco")
    bench = load_benchmark("bench_joints")
    n = 5
    scene = bench.joint_grid(n=n)
    world = scene.world
    twin = bench.MujocoGrid(scene, mujoco)
    m, d = twin.model, twin.data
    moving = ~np.asarray(world.is_static)
    assert m.nbody - 1 == len(twin.ids) == np.count_nonzero(moving) == n * (n - 1)
    assert m.body_mass.sum() == pytest.approx(world.masses[moving].sum(), rel=1e-14)
    np.testing.assert_allclose(m.body_mass[twin.ids], world.masses[moving], rtol=1e-14)
    np.testing.assert_allclose(m.body_inertia[twin.ids], np.diagonal(world.inertias[moving], axis1=1, axis2=2),
                               rtol=1e-12)
    assert m.njnt == n * (n - 1) and set(m.jnt_type.tolist()) == {int(mujoco.mjtJoint.mjJNT_BALL)}
    assert m.neq == (n - 1) ** 2 and set(m.eq_type.tolist()) == {int(mujoco.mjtEq.mjEQ_CONNECT)}
    assert m.njnt + m.neq == world.num_joints == len(scene.ball_joints)
    mujoco.mj_forward(m, d)
    np.testing.assert_allclose(d.xpos[twin.ids], world.positions[moving], atol=1e-12)
    # the world anchors: the tree joints' and the connects' (anchor on body1, in its frame)
    tree = [tuple(np.round(y, 9)) for y in d.xanchor]
    loops = [tuple(np.round(d.xpos[b] + d.xmat[b].reshape(3, 3) @ m.eq_data[k, :3], 9))
             for k, b in enumerate(m.eq_obj1id)]
    assert sorted(tree + loops) == sorted(tuple(np.round(y, 9)) for _, _, y in scene.ball_joints)
    # E = KE + sum m g z at rest: MuJoCo's -sum m g . x of the same bodies
    assert twin.energy0 == pytest.approx(world.kinetic_energy() + world.potential_energy(), rel=1e-12)
    assert twin.separation() < 1e-12
