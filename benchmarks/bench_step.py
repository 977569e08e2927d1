"""Step timing on the built-in scenes: prints the median wall time per step (no asserts).

    python benchmarks/bench_step.py [--repeats 5]

Each scene is built fresh and stepped `steps` times per repeat; the median over repeats of the
per-step time is reported with its spread, plus contacts and PGS sweeps per step for context.
"""
import argparse
import statistics
import time

import numpy as np

import signorini as sg
from signorini import compare, scenes


def many_spheres(n: int = 400):
    """n spheres rained onto the ground in a loose grid: a broad-phase and solver load."""
    w = sg.World(gravity=(0, 0, -9.81))
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    rng = np.random.default_rng(1)
    side = int(np.ceil(np.sqrt(n)))
    for k in range(n):
        i, j = divmod(k, side)
        w.add_body(sg.Sphere(0.1), density=1000.0,
                   position=(0.25 * i, 0.25 * j, 0.2 + 0.4 * rng.random()))
    return w, 1 / 240, 480


CASES = {
    "torus": lambda: (lambda s: (s.world, s.dt, s.steps))(scenes.build("torus")),
    "boxes": lambda: (lambda s: (s.world, s.dt, s.steps))(scenes.build("boxes")),
    "tumbling_box": compare.tumbling_box,
    "spheres_400": many_spheres,
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    print(f"{'scene':14s} {'bodies':>6s} {'steps':>6s} {'us/step (median)':>17s} {'spread':>8s} "
          f"{'contacts/step':>13s} {'sweeps/step':>11s}")
    for name, build in CASES.items():
        per_step, contacts, sweeps = [], [], []
        for _ in range(args.repeats):
            world, dt, steps = build()
            t0 = time.perf_counter()
            for _ in range(steps):
                world.step(dt)
                contacts.append(world.solver_stats.contacts)
                sweeps.append(world.solver_stats.iterations)
            per_step.append((time.perf_counter() - t0) / steps * 1e6)
        med = statistics.median(per_step)
        print(f"{name:14s} {world.num_bodies:6d} {steps:6d} {med:17.1f} {max(per_step) / min(per_step):7.2f}x "
              f"{np.mean(contacts):13.1f} {np.mean(sweeps):11.1f}")


if __name__ == "__main__":
    main()
