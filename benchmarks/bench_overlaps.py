"""Heavy on light: how deep a light box sinks under a heavier block, by mass ratio, for the PGS and
the soft step (issue 21, "Deep overlaps go"); printed figures, no asserts.

    python benchmarks/bench_overlaps.py [--thickness 1.8,3.6,10] [--dts 60,240] [--solvers pgs,soft]
        [--ratios 1,10,100,1000] [--seconds 2]

Each row: a light box 40 x 40 mm of the given thickness (mm) and 10 g resting on the ground, and a
block 30 mm wide of `ratio` times its mass set down 1 mm above it, run `--seconds` at dt 1/`dt`.
Printed per ratio: the deepest overlap of any contact of the light box over the run, as a
fraction of its inner radius (half its thickness; issue 21's target is under 50 %), and THROUGH
when the block ends with its bottom below the light box's middle (the box squeezed out or
crushed through).
"""
from __future__ import annotations

import argparse
import warnings

import signorini as sg


def deepest(solver: str, ratio: float, half: float, dt: float, seconds: float, mass: float = 0.01):
    """(deepest overlap of the light box / its inner radius, whether the block went through)."""
    w = sg.World(gravity=(0, 0, -9.81), solver=solver)
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    light = w.add_body(sg.Box((0.02, 0.02, half)), mass=mass, position=(0, 0, half))
    heavy = w.add_body(sg.Box((0.015, 0.015, 0.015)), mass=ratio * mass, position=(0, 0, 2 * half + 0.016))
    worst = 0.0
    for _ in range(int(round(seconds / dt))):
        c = w.detect_contacts(dt)
        mine = (c.body_a == light) | (c.body_b == light)
        if mine.any():
            worst = max(worst, float(-c.gap[mine].min()))
        w.step(dt)
    return worst / half, bool(w.positions[heavy][2] < 0.015 + half)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--thickness", default="1.8,3.6,10", help="light box thicknesses, mm")
    parser.add_argument("--dts", default="60,240", help="steps per second")
    parser.add_argument("--solvers", default="pgs,soft")
    parser.add_argument("--ratios", default="1,10,100,1000")
    parser.add_argument("--seconds", type=float, default=2.0)
    args = parser.parse_args(argv)
    ratios = [float(r) for r in args.ratios.split(",")]
    warnings.simplefilter("ignore", sg.SolverWarning)
    for thickness in (float(t) for t in args.thickness.split(",")):
        for rate in (float(x) for x in args.dts.split(",")):
            for solver in args.solvers.split(","):
                row = []
                for ratio in ratios:
                    rel, through = deepest(solver, ratio, thickness / 2000.0, 1.0 / rate, args.seconds)
                    row.append(f"1:{ratio:g} {rel:.0%}{' THROUGH' if through else ''}")
                print(f"light box 40 x 40 x {thickness:g} mm, dt 1/{rate:g}, {solver}: " + ", ".join(row), flush=True)


if __name__ == "__main__":
    main()
