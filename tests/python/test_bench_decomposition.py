"""Smoke test of benchmarks/bench_decomposition.py: what load_mesh gives for pybullet_data's files
(no CoACD), and one real CoACD run on a small non-convex OBJ; times are printed, never asserted."""

import pytest
import trimesh
from helpers import ell_arrays, load_benchmark



def test_what_load_mesh_gives_for_pybullet_data(capsys):
    pytest.importorskip("pybullet_data")
    rows = load_benchmark("bench_decomposition").main(["--meshes", "cube.obj,sphere_smooth.obj,bunny.obj,duck_vhacd.obj", "--coacd", "none"])
    assert [(r["mesh"], r["triangles"], r["gives"], r["coacd_s"]) for r in rows] == [
        ("cube.obj", 12, "convex", None),
        ("sphere_smooth.obj", 1792, "its own hull (convex within tolerance)", None),
        ("bunny.obj", 902, "non-convex: CoACD cuts it", None),
        ("duck_vhacd.obj", 396, "5 convex pieces from the file", None)]
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("mesh") and len(out) == 5 and out[4].startswith("duck_vhacd.obj")


@pytest.mark.slow
def test_coacd_cuts_a_non_convex_mesh_into_pieces(tmp_path, capsys):
    pytest.importorskip("coacd")
    # an L-shaped prism (the decomposition tests' mesh): CoACD cuts it in about a second
    trimesh.Trimesh(*ell_arrays(), process=False).export(tmp_path / "ell.obj")
    rows = load_benchmark("bench_decomposition").main(["--meshes", "ell.obj", "--coacd", "all", "--data", str(tmp_path)])
    assert rows[0]["gives"] == "non-convex: CoACD cuts it" and rows[0]["pieces"] >= 2 and rows[0]["coacd_s"] > 0
    assert f"{rows[0]['pieces']} pieces" in capsys.readouterr().out
