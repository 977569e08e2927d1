"""Ray casts and overlap queries (issue 24): signorini's batch against pybullet's rayTestBatch on the
same scene, in the same process; printed figures, no asserts.

    python benchmarks/bench_queries.py [--bodies 3000] [--rays 100000] [--threads 1,2] [--repeats 3]
        [--overlaps 2000] [--floor mesh|plane] [--seed 0]

The scene: a floor (`--floor mesh`: a bumpy triangle-mesh terrain of 3,600 triangles over the square;
`plane`: a ground plane) and `--bodies` static bodies (boxes, spheres, capsules and convex hulls in
equal numbers, random sizes of 0.1-0.5 m and orientations) scattered over a 60 x 60 m square between
0.5 and 6 m up; mirrored body for body into a pybullet DIRECT client (benchmarks/_peers.py). The
rays start 10 m up over the square, point down with a random tilt of up to 0.5 rad, and are 30 m
long. Printed: rays per second (best of `--repeats`) for signorini's ``World.cast_rays`` at each
thread count and pybullet's ``rayTestBatch`` (its numThreads the same; 16,000 rays a call: it drops
rays beyond 16,383 silently), their ratio, and how the hits agree (same body; the distance difference where both
hit the same body, per shape kind: pybullet's convex ray test is an iterative cast on shapes with a
collision margin, its triangle test in single precision, while signorini's are exact to 1e-12
relative or 1e-9 m, tests/python/test_queries.py). Then overlap queries
per second (``overlap_aabb`` of random 1 m boxes, ``overlap`` of random spheres).
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

import signorini as sg

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _peers import PybulletTwin, load_pybullet  # noqa: E402

HALF = 30.0  # the scene's half width (m)


def terrain(cells: int = 30):
    """(vertices, faces) of a bumpy terrain over the square: cells x cells squares, 2 triangles each."""
    xs = np.linspace(-HALF - 1, HALF + 1, cells + 1)
    X, Y = np.meshgrid(xs, xs, indexing="ij")
    Z = 0.3 * np.sin(0.4 * X) * np.cos(0.3 * Y)
    V = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    idx = lambda i, j: i * (cells + 1) + j  # noqa: E731
    F = [[idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)] for i in range(cells) for j in range(cells)]
    F += [[idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)] for i in range(cells) for j in range(cells)]
    return V, np.array(F)


def scene(bodies: int, seed: int, floor: str = "plane") -> sg.World:
    """The bodies (and, for floor "plane", the ground plane; a mesh floor is added after the
    pybullet twin is made, as the twin mirrors no triangle mesh)."""
    rng = np.random.default_rng(seed)
    w = sg.World()
    if floor == "plane":
        w.add_static(sg.Plane((0, 0, 1), 0.0))
    for k in range(bodies):
        s = rng.uniform(0.1, 0.5)
        kind = k % 4
        if kind == 0:
            shape = sg.Box(rng.uniform(0.1, 0.5, 3))
        elif kind == 1:
            shape = sg.Sphere(s)
        elif kind == 2:
            shape = sg.Capsule(0.4 * s, s)
        else:
            shape = sg.ConvexHull(rng.normal(size=(12, 3)) * s)
        q = rng.normal(size=4)
        w.add_static(shape, position=(*rng.uniform(-HALF, HALF, 2), rng.uniform(0.5, 6.0)), orientation=q / np.linalg.norm(q))
    return w


def rays(n: int, seed: int):
    rng = np.random.default_rng(seed + 1)
    origins = np.column_stack([rng.uniform(-HALF, HALF, (n, 2)), np.full(n, 10.0)])
    tilt, turn = rng.uniform(0, 0.5, n), rng.uniform(0, 2 * np.pi, n)
    directions = np.column_stack([np.sin(tilt) * np.cos(turn), np.sin(tilt) * np.sin(turn), -np.cos(tilt)])
    return origins, directions, 30.0


def best_time(f, repeats: int) -> float:
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t0)
    return best


CHUNK = 16000  # pybullet answers at most 16,383 rays a call (it drops the rest silently)


def pybullet_batch(pb, origins, ends, threads: int):
    out = []
    for k in range(0, len(origins), CHUNK):
        out += pb.rayTestBatch(origins[k:k + CHUNK].tolist(), ends[k:k + CHUNK].tolist(), numThreads=threads)
    if len(out) != len(origins):
        raise RuntimeError(f"pybullet answered {len(out)} of {len(origins)} rays")
    return out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bodies", type=int, default=3000)
    parser.add_argument("--rays", type=int, default=100000)
    parser.add_argument("--threads", default="1,2")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--overlaps", type=int, default=2000)
    parser.add_argument("--floor", choices=["mesh", "plane"], default="mesh")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    threads = [int(t) for t in args.threads.split(",")]

    w = scene(args.bodies, args.seed, args.floor)
    peer = load_pybullet()
    twin = PybulletTwin(w, 1 / 60, mods=peer) if peer is not None else None
    if args.floor == "mesh":
        V, F = terrain()
        floor = w.add_static(sg.TriangleMesh(V, F))
        if twin is not None:
            col = twin.pb.createCollisionShape(twin.p.GEOM_MESH, vertices=V.tolist(), indices=F.ravel().tolist(),
                                               flags=twin.p.GEOM_FORCE_CONCAVE_TRIMESH)
            twin.ids[floor] = twin.pb.createMultiBody(baseMass=0, baseCollisionShapeIndex=col)
    O, D, length = rays(args.rays, args.seed)
    print(f"scene: a {'triangle-mesh terrain' if args.floor == 'mesh' else 'plane'} and {args.bodies} static bodies "
          f"(boxes, spheres, capsules, hulls); {args.rays} rays of {length:g} m")
    ours = {}
    for t in threads:
        w.set_threads(t)
        hits = w.cast_rays(O, D, length)
        ours[t] = best_time(lambda: w.cast_rays(O, D, length), args.repeats)
        print(f"signorini cast_rays, {t} thread(s): {args.rays / ours[t]:,.0f} rays/s "
              f"({ours[t] * 1e3:.1f} ms; {np.count_nonzero(hits.body >= 0)} hits)")

    if twin is None:
        print("pybullet: not installed")
    else:
        body_of = {v: k for k, v in twin.ids.items()}
        ends = O + length * D
        for t in threads:
            res = pybullet_batch(twin.pb, O, ends, t)
            theirs = best_time(lambda: pybullet_batch(twin.pb, O, ends, t), args.repeats)
            print(f"pybullet rayTestBatch, numThreads {t}: {args.rays / theirs:,.0f} rays/s "
                  f"({theirs * 1e3:.1f} ms); signorini / pybullet = {theirs / ours[t]:.2f}")
        body = np.array([body_of.get(r[0], -1) if r[0] >= 0 else -1 for r in res])
        dist = np.array([r[2] * length if r[0] >= 0 else np.inf for r in res])
        same = body == hits.body
        both = same & (body >= 0)
        gaps = np.abs(dist[both] - hits.distance[both])
        kinds = np.array([type(w.shape(i)).__name__ if i >= 0 else "" for i in body])
        print(f"agreement: same body (or both miss) on {same.mean():.2%} of rays; "
              f"|distance difference| where both hit it: max {gaps.max():.2e} m, median {np.median(gaps):.2e} m")
        for kind in ("Plane", "TriangleMesh", "Box", "Sphere", "Capsule", "ConvexHull"):
            sel = kinds[both] == kind
            if sel.any():
                print(f"  {kind}: {sel.sum()} rays, max |difference| {gaps[sel].max():.2e} m")
        twin.close()

    rng = np.random.default_rng(args.seed + 2)
    centres = np.column_stack([rng.uniform(-HALF, HALF, (args.overlaps, 2)), rng.uniform(0, 6, args.overlaps)])
    w.set_threads(1)

    def boxes():
        return [w.overlap_aabb(c - 0.5, c + 0.5) for c in centres]

    def spheres():
        return [w.overlap(sg.Sphere(0.5), c) for c in centres]

    found = sum(len(x) for x in boxes())
    tb = best_time(boxes, args.repeats)
    ts = best_time(spheres, args.repeats)
    print(f"overlap_aabb (1 m boxes): {args.overlaps / tb:,.0f} queries/s ({found} bodies found); "
          f"overlap (0.5 m spheres): {args.overlaps / ts:,.0f} queries/s")


if __name__ == "__main__":
    main()
