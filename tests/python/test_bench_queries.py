"""Smoke test of benchmarks/bench_queries.py: a small run prints signorini's rays per second at each
thread count, pybullet's beside them (when installed) and the overlap queries' rate. The figures
are printed, never asserted."""
import pytest

from helpers import load_benchmark


def test_a_small_run_prints_every_figure(capsys):
    bench = load_benchmark("bench_queries")
    bench.main(["--bodies", "40", "--rays", "300", "--threads", "1,2", "--repeats", "1", "--overlaps", "20"])
    out = capsys.readouterr().out
    assert out.count("signorini cast_rays") == 2
    assert "overlap_aabb (1 m boxes)" in out
    try:
        import pybullet  # noqa: F401
    except ImportError:
        pytest.skip("pybullet is not installed")
    assert out.count("pybullet rayTestBatch") == 2 and "agreement: same body" in out
