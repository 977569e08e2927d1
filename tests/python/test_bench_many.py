"""benchmarks/bench_many.py runs end to end in a tiny configuration (its figures are printed,
never asserted), so that the benchmark cannot rot: every method's row is printed."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

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


@pytest.mark.slow
def test_bench_many_prints_rays_start_up_overhead_and_break_even():
    if shutil.which("unshare") is None or os.geteuid() != 0:
        pytest.skip("the Ray sweep runs in a loopback-only network namespace: needs unshare and root")
    pytest.importorskip("ray")
    env = dict(os.environ, PYTHONPATH=str(Path(signorini.__file__).resolve().parent.parent))
    got = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_many.py"), "--runs", "40", "--repeats", "1",
                          "--no-peers"], capture_output=True, text=True, env=env, timeout=600)
    assert got.returncode == 0, got.stdout[-3000:] + got.stderr[-3000:]
    for name in ("start-up included", "already running"):
        line = next(line for line in got.stdout.splitlines() if name in line)
        assert line.rstrip().endswith("x"), line
    for text in ("start-up", "ray.init", "per-task overhead", "steady state", "1.6x including start-up"):
        assert text in got.stdout, got.stdout
