"""benchmarks/bench_hold.py runs end to end on the tiny pyramid (its figures are printed, never
asserted on time): a line per simulated second with finite figures, for both solvers."""
import re

import pytest
from helpers import load_benchmark


@pytest.mark.parametrize("solver", ["soft", "pgs"])
def test_the_tiny_pyramid_holds_and_prints_a_line_per_second(solver, capsys):
    bench = load_benchmark("bench_hold")
    bench.main(["--tiny", "--seconds", "2", "--solver", solver, "--threads", "1"])
    out = capsys.readouterr().out
    rows = [line.split() for line in out.splitlines() if re.match(r"^\s+\d+\.\d\d\s", line)]
    assert [float(r[0]) for r in rows] == [1.0, 2.0]
    for t, x, y, sink, ke, kept in rows:
        # a 15-cube pyramid holds under either solver: it sinks by its springs, not sideways
        assert float(x) < 1e-3 and float(y) < 1e-3 and 0 <= float(sink) < 5e-3 and float(ke) < 1e-3
        done, pairs = map(int, kept.split("/"))
        assert pairs > 0 and done == (pairs if solver == "soft" else 0)  # the soft step recycles by default
    assert "ms per step" in out
