"""What the meshes people have cost to load and decompose: pybullet_data's OBJ files as they come.

    python benchmarks/bench_decomposition.py [--meshes bunny.obj,duck_vhacd.obj,...] [--coacd bunny.obj,...]
                                             [--threshold 0.05] [--whole]

For each mesh: ``sg.load_mesh``'s time and what it gives (triangles; the file's own convex pieces,
convex, its own hull within ``meshfile.CONVEX_TOLERANCE``, or a mesh CoACD must cut), then, for the
meshes named by ``--coacd`` (default: the bunny; "all" for every mesh that needs it, "none"),
``sg.decompose``'s time with the defaults (or ``--threshold``) into a fresh cache, and its pieces.
``--whole`` also cuts the V-HACD files taken as one mesh (what decomposing them again cost before
``load_mesh`` read their pieces). One run each, on whatever else the machine is doing: the figures
are printed, never asserted. pybullet_data comes with pybullet (``pip install pybullet``).
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

import signorini as sg
from signorini import decomposition, meshfile

# the files issue 25 names, as people have them: textured (seam-split), V-HACD pieces, non-convex
MESHES = ("cube.obj", "sphere_smooth.obj", "soccerball.obj", "duck.obj", "bunny.obj", "duck_vhacd.obj",
          "teddy2_VHACD_CHs.obj")


def data_dir() -> Path:
    import pybullet_data

    return Path(pybullet_data.getDataPath())


def what(mesh: sg.Mesh) -> str:
    """What a dynamic body of this mesh collides through, without running CoACD."""
    if mesh.pieces:
        return f"{len(mesh.pieces)} convex pieces from the file"
    if mesh.is_convex():
        return "convex"
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    if not meshfile.convex_problem(vertices, np.asarray(mesh.faces, dtype=np.int64)):
        return "its own hull (convex within tolerance)"
    return "non-convex: CoACD cuts it"


def main(argv=None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--meshes", default=",".join(MESHES), help="comma-separated pybullet_data files")
    parser.add_argument("--coacd", default="bunny.obj",
                        help="comma-separated files to decompose with CoACD, 'all' or 'none' (default: the bunny)")
    parser.add_argument("--threshold", type=float, default=decomposition.DEFAULT_THRESHOLD)
    parser.add_argument("--whole", action="store_true", help="also cut the V-HACD files taken as one mesh")
    parser.add_argument("--data", type=Path, default=None, help="the folder of the meshes (default: pybullet_data)")
    args = parser.parse_args(argv)
    folder = args.data or data_dir()
    import trimesh  # noqa: F401  (imported before the clock starts: the first load_mesh would pay for it)
    names = [n for n in args.meshes.split(",") if n]
    rows = []
    print(f"{'mesh':<22} {'triangles':>9} {'load s':>7}  what load_mesh gives; CoACD (threshold {args.threshold:g})")
    with tempfile.TemporaryDirectory(prefix="signorini-bench-cache-") as cache:
        os.environ["SIGNORINI_CACHE"] = cache  # a fresh cache: every decomposition runs
        for name in names:
            start = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", sg.MeshRepairWarning)
                mesh = sg.load_mesh(folder / name)
            load = time.perf_counter() - start
            row = {"mesh": name, "triangles": len(mesh.faces), "load_s": load, "gives": what(mesh),
                   "coacd_s": None, "pieces": None}
            cut = sg.Mesh(mesh.vertices, mesh.faces) if args.whole and mesh.pieces else mesh
            wanted = args.coacd == "all" or name in args.coacd.split(",")
            if wanted and what(cut) == "non-convex: CoACD cuts it":
                start = time.perf_counter()
                part = sg.decompose(cut, threshold=args.threshold, progress=False)
                row["coacd_s"], row["pieces"] = time.perf_counter() - start, len(part.pieces)
            coacd = "" if row["coacd_s"] is None else \
                f"; CoACD {row['coacd_s']:.1f} s, {row['pieces']} pieces" + (" (as one mesh)" if cut is not mesh else "")
            print(f"{name:<22} {row['triangles']:>9,} {load:>7.2f}  {row['gives']}{coacd}", flush=True)
            rows.append(row)
    return rows


if __name__ == "__main__":
    main()
