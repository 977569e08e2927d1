"""Smoke test of benchmarks/bench_solver.py: its signorini side runs in --quick mode on tiny scenes
and prints one table with a finite row per scene (timing is printed, never asserted)."""

import math

import numpy as np
import pytest
from helpers import load_benchmark



FIGURES = ("ms", "q1", "q3", "displacement", "penetration", "kinetic_energy", "residual",
           "max_penetration_velocity", "max_complementarity", "max_cone_violation",
           "max_dissipation_violation", "iterations", "converged_pct")


def test_quick_tiny_signorini_side_prints_a_finite_row_per_scene(capsys):
    bench = load_benchmark("bench_solver")
    rows = bench.main(["--quick", "--tiny", "--no-pybullet"])
    out = capsys.readouterr().out

    assert [(r["scene"], r["engine"]) for r in rows] == [
        ("pyramid", "signorini"), ("rain", "signorini"), ("hull_pile", "signorini")]
    for row in rows:
        assert row["steps"] == 120 and row["bodies"] > 0 and row["ratio"] is None
        for key in FIGURES:
            assert math.isfinite(row[key]), (row["scene"], key)
        assert 0 < row["iterations"] <= bench.SWEEPS
        assert row["displacement"] >= 0 and row["penetration"] >= 0 and row["kinetic_energy"] >= 0

    # the table: a header and one line per scene, each with every column filled
    lines = out.splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("scene"))
    table = lines[header + 1:header + 4]
    assert [line.split()[:2] for line in table] == [
        ["pyramid", "signorini"], ["rain", "signorini"], ["hull_pile", "signorini"]]
    assert all(len(line.split()) == len(bench.COLUMNS) for line in table)
    # the tiny pyramid stands: the benchmark says so from its figures
    assert "pyramid, signorini: stands" in out


def test_pybullet_twin_mirrors_the_signorini_world():
    pytest.importorskip("pybullet")
    bench = load_benchmark("bench_solver")
    from signorini import scenes

    for build in (lambda: scenes.pyramid(base=3), lambda: scenes.rain(spheres=6, boxes=2),
                  lambda: scenes.hull_pile(hulls=3)):
        world = build().world
        twin = bench.PybulletRun(world, *bench.load_pybullet())
        try:
            pb = twin.pb
            dynamic = np.flatnonzero(~np.asarray(world.is_static))
            assert len(twin.ids) == world.num_bodies and len(twin.dynamic_ids) == len(dynamic)
            for i, body in zip(dynamic, twin.dynamic_ids):
                mass, _, inertia = pb.getDynamicsInfo(body, -1)[:3]
                assert mass == pytest.approx(world.masses[i], rel=1e-12)
                # the same principal moments (pybullet's are in the hull's principal axes)
                np.testing.assert_allclose(sorted(inertia), np.linalg.eigvalsh(world.inertias[i]), rtol=1e-9)
                np.testing.assert_allclose(pb.getBasePositionAndOrientation(body)[0], world.positions[i],
                                           atol=1e-12)
            # nothing has moved yet and Bullet's frictions multiply to signorini's sqrt(mu_A mu_B)
            quality = twin.quality()
            assert quality["displacement"] == 0.0 and quality["kinetic_energy"] == 0.0
            assert pb.getDynamicsInfo(twin.ids[0], -1)[1] ** 2 == pytest.approx(0.5)
        finally:
            twin.close()


def test_pybullet_twin_combines_spinning_friction_as_signorini_does():
    # Bullet's s_A f_B + s_B f_A for two bodies of friction 0.5 and spinning friction 2 mm: 2 mm
    pytest.importorskip("pybullet")
    bench = load_benchmark("bench_solver")
    from signorini import scenes

    world = scenes.pyramid(base=2).world
    for i in range(world.num_bodies):
        world.set_material(i, spinning_friction=0.002)
    twin = bench.PybulletRun(world, *bench.load_pybullet())
    try:
        (f0, s0), (f1, s1) = [(twin.pb.getDynamicsInfo(b, -1)[1], twin.pb.getDynamicsInfo(b, -1)[7])
                              for b in twin.ids[:2]]
        assert s0 * f1 + s1 * f0 == pytest.approx(0.002, rel=1e-12)
    finally:
        twin.close()
