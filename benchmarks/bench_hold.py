"""Does the 5,050-cube pyramid hold (issue 21: "stands 10 s with the defaults")? No asserts.

    python benchmarks/bench_hold.py [--seconds 10] [--dt 0.016667] [--solver soft|pgs]
        [--recycle D] [--threads 2] [--tiny] [--box3d-sag PATH [--box3d-recycle D]]

Box3D's ``large_pyramid`` (``bench_scale.large_pyramid``: a wall of unit cubes one cube thick, 100
at its base, on a static slab, sleeping off), stepped for ``--seconds`` of simulated time. Printed
once per simulated second: the largest displacement of a cube from its start in the wall's plane
(x) and out of it (y), the top cube's sink (m), the kinetic energy (J) and how many of the step's
pairs kept their manifold (``solver_stats.recycled_pairs``). A soft contact is a spring, so the
wall sinks as its loads say (about 0.7 m at the defaults); it holds when the horizontal figures
stay small and the kinetic energy returns to rest, and falls when the out-of-plane figure grows
without bound (docs/conventions.md, "The soft step" and "Contact recycling").

``--recycle D`` sets ``recycle_distance`` (default: the solver's default, ``RECYCLE_DEFAULTS``; 0
finds every pair anew). ``--box3d-sag PATH`` also runs ``benchmarks/box3d/pyramid_sag.c`` (built
against a Box3D checkout, see its header: a same-machine calibration, not run by CI) over the same
time and dt with 4 substeps and prints Box3D's figures beside ours; ``--box3d-recycle D`` sets
Box3D's contact recycle distance (0: off; default: Box3D's own).
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_scale import large_pyramid  # noqa: E402

BOX3D_LINE = re.compile(r"^t=([0-9.]+) s: .*top_dz=([0-9.eE+-]+) m .*in_plane=([0-9.eE+-]+) m out_of_plane=([0-9.eE+-]+) m")


def hold(seconds: float, dt: float, solver: str, recycle, threads: int, tiny: bool):
    """Steps the pyramid; yields (t, in-plane m, out-of-plane m, top sink m, kinetic J, recycled, pairs)
    once per simulated second, and the wall-clock ms per step at the end as the last item."""
    kwargs = {} if recycle is None else {"recycle_distance": recycle}
    scene = large_pyramid(tiny=tiny, solver=solver, threads=threads, sleeping=False, **kwargs)
    w = scene.world
    start = w.positions.copy()
    top = int(np.argmax(start[:, 2]))
    per_second = max(1, int(round(1.0 / dt)))
    steps = int(round(seconds / dt))
    clock = time.perf_counter()
    for k in range(1, steps + 1):
        w.step(dt)
        if k % per_second == 0 or k == steps:
            d = w.positions - start
            s = w.solver_stats
            yield (k * dt, float(np.abs(d[:, 0]).max()), float(np.abs(d[:, 1]).max()), float(-d[top, 2]),
                   w.kinetic_energy(), s.recycled_pairs, s.pairs)
    yield 1000.0 * (time.perf_counter() - clock) / steps


def box3d(path: str, seconds: float, dt: float, recycle) -> dict:
    """Box3D's figures per simulated second from pyramid_sag: {t: (top sink, in-plane, out-of-plane)}."""
    command = [os.path.abspath(path), str(int(round(seconds / dt))), "4", repr(1.0 / dt)]
    if recycle is not None:
        command.append(repr(recycle))
    done = subprocess.run(command, capture_output=True, text=True, timeout=7200)
    rows = {}
    for line in done.stdout.splitlines():
        if m := BOX3D_LINE.match(line):
            rows[round(float(m.group(1)), 6)] = (-float(m.group(2)), float(m.group(3)), float(m.group(4)))
    if not rows:
        print(f"Box3D pyramid_sag gave nothing (exit {done.returncode}): {(done.stdout + done.stderr)[-300:]}")
    return rows


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--dt", type=float, default=1.0 / 60.0)
    parser.add_argument("--solver", choices=("soft", "pgs"), default="soft")
    parser.add_argument("--recycle", type=float, default=None, help="recycle_distance (m); default: the solver's")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--tiny", action="store_true", help="a 15-cube pyramid (smoke test)")
    parser.add_argument("--box3d-sag", default=None, metavar="PATH")
    parser.add_argument("--box3d-recycle", type=float, default=None)
    args = parser.parse_args(argv)
    theirs = box3d(args.box3d_sag, args.seconds, args.dt, args.box3d_recycle) if args.box3d_sag else {}
    recycle = "default" if args.recycle is None else f"{args.recycle:g} m"
    print(f"large_pyramid{' (tiny)' if args.tiny else ''}, solver {args.solver}, dt {args.dt:.6g} s, recycle_distance "
          f"{recycle}, {args.threads} thread(s)")
    header = f"{'t s':>6}  {'in-plane m':>10}  {'out-of-plane m':>14}  {'top sink m':>10}  {'KE J':>9}  {'recycled':>13}"
    if theirs:
        header += f"  {'Box3D in-plane':>14}  {'Box3D out':>9}  {'Box3D sink':>10}"
    print(header)
    for row in hold(args.seconds, args.dt, args.solver, args.recycle, args.threads, args.tiny):
        if not isinstance(row, tuple):
            print(f"{row:.1f} ms per step (wall clock, printing included)")
            break
        t, x, y, sink, ke, kept, pairs = row
        line = f"{t:6.2f}  {x:10.4f}  {y:14.4f}  {sink:10.3f}  {ke:9.2e}  {kept:>6d}/{pairs:<6d}"
        if (b := theirs.get(round(t, 6))) is not None:
            line += f"  {b[1]:14.4f}  {b[2]:9.4f}  {b[0]:10.3f}"
        print(line, flush=True)


if __name__ == "__main__":
    main()
