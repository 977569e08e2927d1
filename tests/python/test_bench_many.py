"""benchmarks/bench_many.py runs end to end in a tiny configuration (its figures are printed,
never asserted), so that the benchmark cannot rot: every method's row is printed."""
import os
import subprocess
import sys
from pathlib import Path

import signorini

ROOT = Path(__file__).resolve().parents[2]


def test_bench_many_prints_every_method():
    env = dict(os.environ, PYTHONPATH=str(Path(signorini.__file__).resolve().parent.parent))
    got = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_many.py"), "--runs", "6", "--repeats", "1",
                          "--no-ray"], capture_output=True, text=True, env=env, timeout=600)
    assert got.returncode == 0, got.stderr
    for name in ("signorini serial", "signorini Batch, 2 threads", "pybullet DIRECT", "MuJoCo rollout"):
        line = next(line for line in got.stdout.splitlines() if name in line)
        assert line.rstrip().endswith("x"), line        # runs/s and the ratio were printed
    assert "per core: Batch" in got.stdout
