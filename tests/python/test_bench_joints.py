"""benchmarks/bench_joints.py runs end to end at its --tiny size in a child process (its figures are
printed, never asserted on time): a table row per scene and engine with finite figures, and a
line per signorini row on its energy. pybullet's rows are there when it is installed."""
import importlib.util
import math
import os
import re
import subprocess
import sys
from pathlib import Path

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
    engines = ["signorini", "signorini soft"]
    if importlib.util.find_spec("pybullet") is not None:
        engines.append("pybullet")
    expected = [(scene, engine) for scene in ("joint_grid", "ragdolls") for engine in engines]
    table = [dict(zip(columns, re.split(r"\s{2,}", line.strip()))) for line in lines[header + 1:header + 1 + len(expected)]]
    assert [(row["scene"], row["engine"]) for row in table] == expected
    for row in table:
        assert int(row["steps"]) == 10 and int(row["joints"]) > 0
        for key in ("ms/step", "sg/this", "sep end m", "KE end J"):
            assert math.isfinite(float(row[key])) and float(row[key]) >= 0, (row["scene"], row["engine"], key)
        if row["engine"].startswith("signorini"):
            assert math.isfinite(float(row["E rise J"])), row
    for scene, engine in expected:
        if engine.startswith("signorini"):
            assert any(line.startswith(f"{scene}, {engine}: energy ") for line in lines), (scene, engine)
