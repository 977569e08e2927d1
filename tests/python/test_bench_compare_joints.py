"""benchmarks/compare_joints.py runs end to end in a child process and prints its table: a row per
figure with both solvers' values, each finite and within the bound its acceptance test sets (the
tests assert the same figures; this checks that the script measures what they do)."""
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import signorini

ROOT = Path(__file__).resolve().parents[2]


def test_the_comparison_prints_every_figure_within_its_bound():
    pytest.importorskip("mujoco")
    pytest.importorskip("pybullet")
    env = dict(os.environ, PYTHONPATH=str(Path(signorini.__file__).resolve().parent.parent))
    got = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "compare_joints.py")],
                         capture_output=True, text=True, env=env, timeout=600)
    assert got.returncode == 0, got.stderr
    lines = got.stdout.splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("model"))
    assert re.split(r"\s{2,}", lines[header].strip())[:5] == ["model", "figure", "test bound", "pgs", "soft"]
    rows = [line for line in lines[header + 1:] if line.strip()][:12]
    models = {re.split(r"\s{2,}", r.strip())[0] for r in rows}
    assert models == {"pendulum", "double_pendulum", "arm7", "kuka_iiwa", "kuka_iiwa horizontal", "kuka_iiwa tilted"}
    for r in rows:
        cells = re.split(r"\s{2,}", r.strip())
        bound, pgs, soft = float(cells[2]), float(cells[3]), float(cells[4])
        assert math.isfinite(pgs) and math.isfinite(soft), r
        assert pgs <= bound and soft <= bound, r
    assert "every figure is within its test's bound" in got.stdout
