"""Cost of reading a world's state from Python: ``World.snapshot()`` (every body as plain NumPy
data, the oracle's input) and the zero-copy state views, at 200, 400 and 800 bodies.

    python benchmarks/bench_snapshot.py [--repeats 30]

Prints the median of ``--repeats`` calls for each body count (never asserts: timings are not
tests). The pile is spheres and boxes in a grid above a plane, stepped once so that contacts exist.
"""
from __future__ import annotations

import argparse
import statistics
import time

import signorini as sg


def world_of(n: int) -> sg.World:
    w = sg.World()
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    side = int(round(n ** (1 / 3))) + 1
    for k in range(n - 1):
        x, y, z = k % side, (k // side) % side, k // (side * side)
        shape = sg.Sphere(0.2) if k % 2 else sg.Box((0.2, 0.2, 0.2))
        w.add_body(shape, density=1000.0, position=(0.5 * x, 0.5 * y, 0.21 + 0.5 * z))
    w.step(1 / 240)
    return w


def median_ms(f, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=30, help="calls per figure (default 30)")
    args = parser.parse_args()
    print(f"{'bodies':>7} {'snapshot() ms':>14} {'per body us':>12} {'positions+orientations+velocities us':>38}")
    for n in (200, 400, 800):
        w = world_of(n)
        snap = median_ms(w.snapshot, args.repeats)
        views = median_ms(lambda: (w.positions, w.orientations, w.velocities, w.angular_velocities), args.repeats)
        print(f"{n:>7} {snap:>14.2f} {1e3 * snap / n:>12.2f} {1e3 * views:>38.1f}")


if __name__ == "__main__":
    main()
