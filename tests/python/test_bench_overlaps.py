"""Smoke test of benchmarks/bench_overlaps.py: a short run prints one row per thickness, dt and
solver, with a figure per mass ratio (the figures themselves are issue 21's measurement, printed;
test_deep_overlaps.py asserts what is met)."""
from helpers import load_benchmark


def test_one_row_per_case_with_a_figure_per_ratio(capsys):
    bench = load_benchmark("bench_overlaps")
    bench.main(["--thickness", "10", "--dts", "240", "--solvers", "pgs,soft", "--ratios", "1,10", "--seconds", "0.1"])
    lines = capsys.readouterr().out.strip().splitlines()
    assert [line.split(": ")[0] for line in lines] == ["light box 40 x 40 x 10 mm, dt 1/240, pgs",
                                                      "light box 40 x 40 x 10 mm, dt 1/240, soft"]
    for line in lines:
        assert [part.split()[0] for part in line.split(": ")[1].split(", ")] == ["1:1", "1:10"]
        assert all(part.split()[1].endswith("%") for part in line.split(": ")[1].split(", "))
