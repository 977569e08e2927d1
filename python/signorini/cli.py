"""Command line: ``python -m signorini run [SCENE] [--out DIR] [--steps N] [--dt DT]`` and
``python -m signorini list``.

``run`` builds a built-in scene (default ``torus``), runs it while recording, writes
``<out>/<scene>.npz`` (the record, see ``signorini.output``) and ``<out>/<scene>.png`` (energy,
contacts, solver effort and 3-D snapshots), and prints a short summary. Bad arguments (an unknown
scene, steps < 1, dt <= 0) are reported by argparse with exit code 2.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from . import scenes

__all__ = ["main", "make_parser"]


def _scene_name(text: str) -> str:
    """argparse type: a registered scene name."""
    if text not in scenes.SCENES:
        known = ", ".join(sorted(scenes.SCENES))
        raise argparse.ArgumentTypeError(f"unknown scene {text!r} (known scenes: {known})")
    return text


def _positive_int(text: str) -> int:
    """argparse type: an integer >= 1 (number of steps)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"steps must be an integer >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"steps must be an integer >= 1, got {value}")
    return value


def _positive_float(text: str) -> float:
    """argparse type: a finite number > 0 (time step, s)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"dt must be a number > 0 (seconds), got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"dt must be a finite number > 0 (seconds), got {text}")
    return value


def make_parser() -> argparse.ArgumentParser:
    """The argument parser, with the ``run`` and ``list`` sub-commands."""
    parser = argparse.ArgumentParser(
        prog="python -m signorini", description="signorini: rigid bodies with contact."
    )
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    run = commands.add_parser("run", help="run a built-in scene, write <out>/<scene>.npz and .png")
    run.add_argument(
        "scene", nargs="?", default=scenes.DEFAULT_SCENE, type=_scene_name,
        help=f"scene name (default {scenes.DEFAULT_SCENE}; see 'list')",
    )
    run.add_argument("--out", default="signorini-out", type=Path, help="output folder (default signorini-out/)")
    run.add_argument("--steps", type=_positive_int, help="number of steps (default: the scene's)")
    run.add_argument("--dt", type=_positive_float, help="time step in seconds (default: the scene's)")
    run.add_argument("--no-plot", action="store_true", help="write the .npz only")

    commands.add_parser("list", help="list the built-in scenes")
    return parser


def _run(args: argparse.Namespace) -> int:
    """Build, run, save, plot and summarise one scene."""
    from . import output

    # build and run
    scene = scenes.build(args.scene)
    record = output.run(scene, steps=args.steps, dt=args.dt)

    # write the record and the picture next to each other
    files = [output.save_trajectory(args.out / f"{scene.name}.npz", record)]
    if not args.no_plot:
        files.append(output.plot(args.out / f"{scene.name}.png", record, scene))
    print(output.format_summary(record, files))
    return 0


def _list() -> int:
    """Print each scene with its step, length and description."""
    for name in sorted(scenes.SCENES):
        scene = scenes.build(name)
        default = " (default)" if name == scenes.DEFAULT_SCENE else ""
        print(f"{name}{default}: {scene.world.num_bodies} bodies, {scene.steps} steps of "
              f"{scene.dt:.6g} s = {scene.duration:.3g} s\n    {scene.description}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit status (argparse exits with 2 on bad arguments)."""
    args = make_parser().parse_args(argv)
    if args.command == "run":
        return _run(args)
    return _list()


if __name__ == "__main__":
    sys.exit(main())
