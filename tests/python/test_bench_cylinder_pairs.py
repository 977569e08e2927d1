"""Smoke test of benchmarks/bench_cylinder_pairs.py: a few pairs of every type give a row each, with
every pair answered and the figures finite (the exactness itself is asserted, per slot, by
test_table_slots.py; the benchmark only prints)."""

import importlib.util
import math
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_cylinder_pairs.py"


@pytest.mark.slow
def test_every_cylinder_pair_type_prints_a_row(capsys):
    spec = importlib.util.spec_from_file_location("bench_cylinder_pairs", BENCH)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    rows = bench.main(["--pairs", "24", "--oracle-every", "12"])
    out = capsys.readouterr().out
    assert [r["kind"] for r in rows] == ["cylinder-" + t for t in bench.TYPES]
    for r in rows:
        assert r["pairs"] >= 20, r
        for key in ("gap", "witness", "normal"):
            assert math.isfinite(r[key]), (r["kind"], key)
        assert r["kind"] in out
    # every type but the plane (exact by construction) is checked against the oracle twice
    assert all(r["ref"] == 2 for r in rows if r["kind"] != "cylinder-plane")
