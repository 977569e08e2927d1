"""How signorini's step cost grows with the world (issue 21, "Broad phase for large worlds" and the
log-log slope target); printed figures, no asserts.

    python benchmarks/bench_slope.py [--statics 1000,10000,100000] [--bodies 1000,3000,10000,30000,50000]
        [--solvers pgs,soft] [--chunks 5] [--warmup 5] [--steps 2] [--tiny] [--only statics|bodies]

Two tables, each over worlds of several sizes built first and then stepped chunk by chunk in turn
(one chunk of every world, then the next), so that a load spike on the machine hits every size;
ms/step is the median over the chunks of a chunk's time over its steps (each step timed alone).
signorini runs on 1 thread, with its defaults ("pgs") and with ``set_solver(solver="soft")``.

1. Static bodies (``--statics``): Box3D's large_world as ``bench_scale.large_world`` builds it,
   n x n static 10 m floor tiles with n = round(sqrt(count)), and the same 100 spheres released one
   every 5 steps over Box3D's 500 steps (sleeping on, as Box3D's scene), dt 1/60; the 500 steps are
   cut into ``--chunks`` chunks. Printed: ms/step per count and the ratio of the largest count's
   cost to the smallest's (the issue's target: a step whose cost depends on the moving bodies, not
   on the static ones, so a ratio close to 1).
2. Body count (``--bodies``): N boxes of 0.5 m (``bench_scale.sleep_pile``'s boxes: columns of 5,
   1 cm apart with seeded jitter, dropped 1 cm onto each other) in round(sqrt(N / 5)) x
   round(sqrt(N / 5)) columns on a static floor, sleeping off, dt 1/60: every size is the same pile
   made wider, so a cost that grows only with the bodies and their contacts gives a slope of 1.
   ``--warmup`` untimed steps, then ``--chunks`` chunks of ``--steps`` steps. Printed: ms/step per
   size, ms per 1,000 boxes and per 1,000 contacts, and the least-squares slope of log(ms/step)
   against log(N) (the issue's target: at most 1.05 from 1,000 to 50,000 boxes), and against the
   contact count (a wider pile has a few more contacts per box: fewer boxes on its rim).
``--tiny`` shrinks both to a smoke test (a few hundred bodies, a few steps).
"""
from __future__ import annotations

import argparse
import importlib.util
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np

import signorini as sg


def _load_bench_scale():
    """benchmarks/bench_scale.py, loaded by path (the benchmarks folder is not a package)."""
    spec = importlib.util.spec_from_file_location("bench_scale", Path(__file__).resolve().parent / "bench_scale.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up by name
    spec.loader.exec_module(module)
    return module


bench = _load_bench_scale()

SOLVERS = {"pgs": {}, "soft": {"solver": "soft"}}


def static_world(count: int, solver: str, tiny: bool = False):
    """large_world with about ``count`` static tiles (n x n, n = round(sqrt(count))): (scene, run)."""
    n = max(2, round(math.sqrt(count)))
    scene = bench.large_world(tiny=False, scale=n / 1000.0, threads=1, sleeping=True)
    if tiny:
        scene.steps = 20
    return scene, bench.SignoriniRun(scene, SOLVERS[solver])


def box_pile(count: int, solver: str):
    """About ``count`` boxes, columns of 5 on a static floor, sleeping off: (scene, run)."""
    across = max(1, round(math.sqrt(count / 5.0)))
    scene = bench.sleep_pile(across=across, layers=5, threads=1, sleeping=False)
    return scene, bench.SignoriniRun(scene, SOLVERS[solver])


def awake_spheres(world) -> int:
    """Released (enabled) dynamic bodies that are awake."""
    w = world
    return int(np.count_nonzero(np.asarray(w.awake) & np.asarray(w.enabled) & ~np.asarray(w.is_static)))


def interleaved(runs: list, chunks: list[tuple[int, int]]) -> list[list[float]]:
    """Steps every run over each chunk (first step index, step count) in turn, releasing bodies
    where its scene says; returns per run the chunks' ms/step."""
    times = [[] for _ in runs]
    for first, length in chunks:
        for k, run in enumerate(runs):
            releases = {s: v for s, v in run.scene.releases.items() if first <= s < first + length}
            times[k].append(1e3 * bench.run_steps(run, first, length, releases) / length)
    return times


def slope(sizes, ms) -> float:
    """Least-squares slope of log(ms) against log(size)."""
    return float(np.polyfit(np.log(np.asarray(sizes, float)), np.log(np.asarray(ms, float)), 1)[0])


def bench_statics(counts: list[int], solvers: list[str], chunks: int, tiny: bool) -> list[dict]:
    """Table 1: large_world's ms/step at each static count, per solver."""
    worlds = []
    for solver in solvers:
        for count in counts:
            t0 = time.perf_counter()
            scene, run = static_world(count, solver, tiny)
            statics = int(np.count_nonzero(scene.world.is_static))
            print(f"  built large_world, {statics} static tiles, {solver}: {time.perf_counter() - t0:.1f} s",
                  file=sys.stderr, flush=True)
            worlds.append((solver, statics, run))
    steps = worlds[0][2].scene.steps
    cut = bench.peers.chunk_lengths(steps, chunks)
    spans = [(sum(cut[:k]), length) for k, length in enumerate(cut)]
    times = interleaved([w[2] for w in worlds], spans)
    rows = []
    for (solver, statics, run), t in zip(worlds, times):
        ms, q1, q3 = bench._median(t)
        rows.append({"solver": solver, "statics": statics, "ms": ms, "q1": q1, "q3": q3,
                     "awake": awake_spheres(run.world)})
    return rows


def bench_bodies(counts: list[int], solvers: list[str], chunks: int, steps: int, warmup: int) -> list[dict]:
    """Table 2: a pile of columns of boxes at each size, per solver."""
    worlds = []
    for solver in solvers:
        for count in counts:
            scene, run = box_pile(count, solver)
            worlds.append((solver, run))
    for solver, run in worlds:
        t0 = time.perf_counter()
        bench.run_steps(run, 0, warmup, {})
        print(f"  box pile, {run.dynamic.size} boxes, {solver}: {warmup} warm-up steps in "
              f"{time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)
    spans = [(warmup + k * steps, steps) for k in range(chunks)]
    times = interleaved([w[1] for w in worlds], spans)
    rows = []
    for (solver, run), t in zip(worlds, times):
        ms, q1, q3 = bench._median(t)
        rows.append({"solver": solver, "bodies": int(run.dynamic.size), "ms": ms, "q1": q1, "q3": q3,
                     "contacts": len(run.world.contacts)})
    return rows


def format_statics(rows) -> str:
    lines = [f"{'solver':<6}  {'statics':>8}  {'ms/step':>9}  {'25-75 %':>15}  {'awake at end':>12}"]
    for r in rows:
        lines.append(f"{r['solver']:<6}  {r['statics']:>8d}  {r['ms']:>9.3f}  "
                     f"{r['q1']:>7.3f}-{r['q3']:<7.3f}  {r['awake']:>12d}")
    for solver in dict.fromkeys(r["solver"] for r in rows):
        mine = [r for r in rows if r["solver"] == solver]
        lo, hi = min(mine, key=lambda r: r["statics"]), max(mine, key=lambda r: r["statics"])
        cells = " / ".join(f"{r['ms']:.3f}" for r in sorted(mine, key=lambda r: r["statics"]))
        counts = " / ".join(f"{r['statics']}" for r in sorted(mine, key=lambda r: r["statics"]))
        lines.append(f"large_world, {solver}, 100 spheres: ms/step at {counts} static boxes = {cells}; "
                     f"ratio {hi['statics']}/{lo['statics']} = {hi['ms'] / lo['ms']:.2f} (target: close to 1)")
    return "\n".join(lines)


def format_bodies(rows) -> str:
    lines = [f"{'solver':<6}  {'boxes':>7}  {'contacts':>8}  {'ms/step':>9}  {'25-75 %':>17}  {'ms per 1k boxes':>15}  "
             f"{'ms per 1k contacts':>18}"]
    for r in rows:
        lines.append(f"{r['solver']:<6}  {r['bodies']:>7d}  {r['contacts']:>8d}  {r['ms']:>9.3f}  "
                     f"{r['q1']:>8.3f}-{r['q3']:<8.3f}  {1e3 * r['ms'] / r['bodies']:>15.3f}  "
                     f"{1e3 * r['ms'] / max(r['contacts'], 1):>18.3f}")
    for solver in dict.fromkeys(r["solver"] for r in rows):
        mine = sorted((r for r in rows if r["solver"] == solver), key=lambda r: r["bodies"])
        if len(mine) < 2:
            continue
        s = slope([r["bodies"] for r in mine], [r["ms"] for r in mine])
        c = slope([r["contacts"] for r in mine], [r["ms"] for r in mine])
        lines.append(f"box pile, {solver}: log-log slope of ms/step against boxes from {mine[0]['bodies']} to "
                     f"{mine[-1]['bodies']}: {s:.3f} (target: at most 1.05); against contacts: {c:.3f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> dict:
    """Parses the options, runs the tables, prints them; returns {"statics": rows, "bodies": rows}."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--statics", default="1000,10000,100000", help="static tile counts of table 1")
    parser.add_argument("--bodies", default="1000,3000,10000,30000,50000", help="box counts of table 2")
    parser.add_argument("--solvers", default="pgs,soft", help="comma-separated, from: " + ", ".join(SOLVERS))
    parser.add_argument("--chunks", type=int, default=5, help="timed chunks per world (default 5)")
    parser.add_argument("--steps", type=int, default=2, help="steps per chunk of table 2 (default 2)")
    parser.add_argument("--warmup", type=int, default=5, help="untimed steps before table 2's chunks (default 5)")
    parser.add_argument("--only", choices=("statics", "bodies"), default=None, help="run one table only")
    parser.add_argument("--tiny", action="store_true", help="a smoke test: small worlds, few steps")
    args = parser.parse_args(argv)
    solvers = [s.strip() for s in args.solvers.split(",") if s.strip()]
    if unknown := [s for s in solvers if s not in SOLVERS]:
        parser.error(f"unknown solver(s) {unknown}; known: {', '.join(SOLVERS)}")
    if args.chunks < 1 or args.steps < 1 or args.warmup < 0:
        parser.error("--chunks and --steps must be at least 1, --warmup at least 0")
    statics = [int(x) for x in args.statics.split(",") if x.strip()]
    bodies = [int(x) for x in args.bodies.split(",") if x.strip()]
    if args.tiny:
        statics, bodies = [16, 64], [50, 200]
        args.chunks, args.steps, args.warmup = min(args.chunks, 2), 1, 1
    if any(n < 1 for n in statics + bodies):
        parser.error("counts must be at least 1")
    print(f"signorini on 1 thread, dt 1/60; ms/step = median over {args.chunks} interleaved chunk(s)")
    result = {"statics": [], "bodies": []}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sg.SolverWarning)
        if args.only in (None, "statics"):
            result["statics"] = bench_statics(statics, solvers, args.chunks, args.tiny)
            print()
            print(format_statics(result["statics"]))
        if args.only in (None, "bodies"):
            result["bodies"] = bench_bodies(bodies, solvers, args.chunks, args.steps, args.warmup)
            print()
            print(format_bodies(result["bodies"]))
    sys.stdout.flush()
    return result


if __name__ == "__main__":
    main()
