"""Smoke test of benchmarks/bench_scale.py: every scene runs at its --tiny size for a fraction of a
second and the script returns and prints a row per scene and engine with finite figures (timing
is printed, never asserted). The peers run when installed; the test passes without them."""

import math
import re

import numpy as np
import pytest
from helpers import load_benchmark



TIMES = ("ms", "q1", "q3", "ratio")
QUALITY = ("penetration", "kinetic_energy")
CERTIFICATE = ("residual", "max_penetration_velocity", "max_complementarity", "max_cone_violation",
               "max_dissipation_violation", "iterations", "converged_pct")
KEYS = {"scene", "engine", "size", "bodies", "steps", "threads2", "sleep", "displacement", *TIMES, *QUALITY}


def check_rows(bench, rows, engines, out):
    scenes = list(bench.SCENES)
    assert [(r["scene"], r["engine"]) for r in rows] == [(s, e) for s in scenes for e in engines]
    for row in rows:
        assert KEYS <= set(row), (row["scene"], row["engine"])
        # 0.25 s at the scene's dt: Box3D's 1/60, box_bin's 1/240
        assert row["bodies"] > 0 and row["steps"] == (60 if row["scene"] == "box_bin" else 15)
        for key in TIMES + QUALITY:
            assert math.isfinite(row[key]) and row[key] >= 0, (row["scene"], row["engine"], key)
        assert row["q1"] <= row["ms"] <= row["q3"]
        # bodies released during the run have no start; the others report their largest move
        if bench.SCENES[row["scene"]](tiny=True).releases:
            assert row["displacement"] is None
        else:
            assert math.isfinite(row["displacement"]) and row["displacement"] >= 0
        if row["engine"].startswith("signorini"):
            for key in CERTIFICATE:
                assert math.isfinite(row[key]), (row["scene"], key)
    signorini = [r for r in rows if r["engine"] == "signorini"]
    assert all(r["ratio"] == 1.0 for r in signorini)
    # the table: a header and one line per row with every column filled
    lines = out.splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("scene"))
    table = lines[header + 1:header + 1 + len(rows)]
    assert [re.split(r"\s{2,}", line.strip())[:2] for line in table] == [[r["scene"], r["engine"]] for r in rows]
    assert all(len(re.split(r"\s{2,}", line.strip())) == len(bench.COLUMNS) for line in table)


def test_tiny_scenes_signorini_alone_give_a_finite_row_each(capsys):
    bench = load_benchmark("bench_scale")
    rows = bench.main(["--tiny", "--seconds", "0.25", "--chunks", "3", "--engines", "signorini,soft",
                       "--sweeps", "10", "--substeps", "1"])
    out = capsys.readouterr().out
    check_rows(bench, rows, ["signorini", "signorini soft", "signorini fast"], out)
    # columns for features the World lacks say so, so the table keeps its shape
    for row in rows:
        if not bench.world_supports("threads", 1):
            assert row["threads2"] == bench.NA and row["threads2_ms"] is None
        if row["scene"] == "sleep" and not bench.world_supports("sleeping", False):
            assert row["sleep"] == bench.NA
        # the settled pile's cost with sleeping on over off, for the PGS and the soft rows
        if row["scene"] == "sleep" and row["engine"] in ("signorini", "signorini soft") \
                and bench.world_supports("sleeping", False):
            assert math.isfinite(row["sleep_ratio"]) and row["sleep_ratio"] > 0
    assert "pybullet: skipped (--engines)" in out
    # the tiny pyramids stand with the defaults, and the script says so from its figures
    assert "large_pyramid, signorini: stands" in out and "many_pyramids, signorini: stands" in out


def test_tiny_scenes_with_the_installed_peers():
    bench = load_benchmark("bench_scale")
    engines = ["signorini", "signorini soft"] + [e for e, load in (("pybullet", bench.peers.load_pybullet),
                                                 ("rapier3d", bench.peers.load_rapier)) if load() is not None]
    if len(engines) == 2:
        pytest.skip("neither pybullet nor rapier3d is installed")
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        rows = bench.main(["--tiny", "--seconds", "0.25", "--chunks", "3"])
    check_rows(bench, rows, engines, out.getvalue())
    for row in rows:
        if row["engine"] == "rapier3d":
            assert math.isfinite(row["threads2_ms"])
        if row["scene"] == "sleep" and (not row["engine"].startswith("signorini")
                                        or bench.world_supports("sleeping", False)):
            assert math.isfinite(row["sleep_ratio"])


def test_peer_twins_start_as_the_signorini_world():
    bench = load_benchmark("bench_scale")
    mods = {"pybullet": bench.peers.load_pybullet(), "rapier3d": bench.peers.load_rapier()}
    if not any(mods.values()):
        pytest.skip("neither pybullet nor rapier3d is installed")
    for name, build in bench.SCENES.items():
        scene = build(tiny=True)
        world = scene.world
        enabled = np.asarray(world.enabled)[~np.asarray(world.is_static)]
        twins = []
        if mods["pybullet"]:
            twins.append(bench.peers.PybulletTwin(world, scene.dt, 10, scene.sleeping, mods["pybullet"]))
        if mods["rapier3d"]:
            twins.append(bench.peers.RapierTwin(world, scene.dt, 1, scene.sleeping, mods["rapier3d"]))
        expected = world.positions[~np.asarray(world.is_static)][enabled]
        for twin in twins:
            positions, energy = twin.state()
            # bodies released later are not in the peer's simulation yet
            assert np.isnan(positions[~enabled]).all(), name
            np.testing.assert_allclose(positions[enabled], expected, atol=1e-5, err_msg=name)
            assert energy == pytest.approx(0.0, abs=1e-9), name
            twin.close()
        if mods["rapier3d"] and name != "convex_pile":
            # boxes, spheres and capsules keep their body axes (capsules lie along x in rain)
            twin = bench.peers.RapierTwin(world, scene.dt, 1, scene.sleeping, mods["rapier3d"])
            bodies = twin.rw.rigid_bodies
            for i in twin.dynamic:
                x, y, z, w = bodies[twin.handles[i]].rotation.to_tuple()
                np.testing.assert_allclose(np.abs(np.dot((w, x, y, z), world.orientations[i])), 1.0, atol=1e-6)


def test_convex_pile_points_lie_on_the_two_metre_sphere():
    bench = load_benchmark("bench_scale")
    points = bench.convex_pile_points()
    assert points.shape == (32, 3)
    np.testing.assert_allclose(np.linalg.norm(points, axis=1), 2.0, rtol=1e-12)
    # a fixed generator: the same hull on every run
    np.testing.assert_array_equal(points, bench.convex_pile_points())


def test_rain_releases_follow_box3d_schedule():
    bench = load_benchmark("bench_scale")
    assert bench.rain_release_steps(400) == [0, 16, 64, 80, 128, 144, 192, 208, 256, 272, 320, 336, 384]
    scene = bench.rain(tiny=True)
    # tiny: 2 columns of 2 cells, one stack of 14 capsules each; the third release re-drops column 0
    assert len(scene.releases[0]) == 28 and scene.releases[64] == scene.releases[0]
    assert not np.asarray(scene.world.enabled)[scene.releases[0]].any()


def test_chunk_ratios_pair_each_chunk_with_the_box3d_runs_beside_it():
    bench = load_benchmark("bench_scale")
    # the app ran before chunk 0 and after each chunk; a failed run (None) leaves its neighbour alone
    beside = [10.0, 20.0, None, 40.0]
    assert bench.chunk_ratios([30.0, 40.0, 80.0], beside) == pytest.approx([2.0, 2.0, 2.0])
    assert bench.chunk_ratios([5.0], [None, None]) == []
