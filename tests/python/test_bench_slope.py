"""Smoke test of benchmarks/bench_slope.py: its --tiny run builds both tables (static tiles, box
piles) for both solvers, returns finite figures and prints the ratio and slope lines (timing is
printed, never asserted)."""

import math
from helpers import load_benchmark



def test_tiny_run_prints_both_tables(capsys):
    bench = load_benchmark("bench_slope")
    result = bench.main(["--tiny"])
    out = capsys.readouterr().out
    statics, bodies = result["statics"], result["bodies"]
    assert [(r["solver"], r["statics"]) for r in statics] == [(s, n) for s in ("pgs", "soft") for n in (16, 64)]
    assert [r["solver"] for r in bodies] == ["pgs", "pgs", "soft", "soft"]
    assert [r["bodies"] for r in bodies[:2]] == [45, 180]  # columns of 5: 3 x 3 and 6 x 6
    for row in statics + bodies:
        assert math.isfinite(row["ms"]) and row["ms"] > 0
        assert row["q1"] <= row["ms"] <= row["q3"]
    for row in bodies:
        assert row["contacts"] > 0
    for solver in ("pgs", "soft"):
        assert f"large_world, {solver}, 100 spheres: ms/step at 16 / 64 static boxes" in out
        assert f"box pile, {solver}: log-log slope of ms/step against boxes from 45 to 180" in out


def test_slope_of_a_power_law_is_its_exponent():
    bench = load_benchmark("bench_slope")
    sizes = [1000, 3000, 10000, 30000, 50000]
    assert math.isclose(bench.slope(sizes, [2e-3 * n ** 1.25 for n in sizes]), 1.25, rel_tol=1e-12)
    assert math.isclose(bench.slope(sizes, [7.0 * n for n in sizes]), 1.0, rel_tol=1e-12)


def test_one_table_alone():
    bench = load_benchmark("bench_slope")
    result = bench.main(["--tiny", "--only", "bodies", "--solvers", "soft"])
    assert result["statics"] == [] and [r["solver"] for r in result["bodies"]] == ["soft", "soft"]
