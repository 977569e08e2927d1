"""Command line.

    python -m signorini run [SCENE | FILE.toml] [--out DIR] [--steps N] [--dt DT] [--stride S] [--quiet]
                            [--html PATH | --no-html] [--no-plot] [--video [PATH]] [--fps F]
                            [--size WxH] [--gltf [PATH]] [--usd [PATH]] [--allow-path DIR ...]
    python -m signorini export TRAJECTORY [--out DIR] [--html ...] [--video ...] [--gltf ...] [--usd ...] [--png]
    python -m signorini view SCENE_OR_FILE_OR_TRAJECTORY [--host H] [--port P] [--allow-path DIR ...]
    python -m signorini list

``run`` builds a built-in scene (default ``torus``) or reads a scene file (``signorini.scenefile``), runs it while recording (a progress bar once a
run takes more than a second, unless ``--quiet``), and writes into ``--out``: ``<scene>.npz``, the
trajectory with its scene (``signorini.trajectory``), ``<scene>.png`` (energy, contacts, solver
effort and 3-D snapshots) and ``<scene>.html`` (the offline player, ``signorini.player``); on
request an MP4 (``signorini.render``), a binary glTF and a USD stage (``signorini.export``), each at
the path given or ``<out>/<scene>.<ext>``. It prints a summary naming every file written with its
size, and the frame stride: chosen so that the trajectory's frames fit 20 MB
(``trajectory.TRAJECTORY_BUDGET``) unless ``--stride`` gives it. ``--quiet`` shows no progress bar,
no decomposition estimate and no ``SolverWarning``.
``export`` writes the same files from a saved trajectory, without the simulator: those asked for,
or the HTML player alone when none is asked for; ``view`` serves
the interactive viewer (``signorini.viewer``) of a scene (simulated live) or a trajectory file.
A scene file reads mesh files from its own folder only, and from each folder given with
``--allow-path DIR`` (repeatable; ``run`` and ``view``); a mesh anywhere else is refused, the
message naming the rule and the option.
Bad arguments (an unknown scene, steps or stride < 1, dt <= 0, a bad size, an ``--allow-path``
that is not a folder) exit with code 2 and argparse's message; a missing or unreadable scene or
trajectory file exits with code 2 naming the file.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import sys
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Optional, Union

from . import scenes

if TYPE_CHECKING:
    from .trajectory import Record

__all__ = ["main", "make_parser"]


def _scene_name(text: str) -> str:
    """argparse type: a built-in scene name or the path of a scene file (.toml)."""
    if text not in scenes.SCENES and not text.lower().endswith(".toml"):
        known = ", ".join(sorted(scenes.SCENES))
        raise argparse.ArgumentTypeError(f"unknown scene {text!r} (known scenes: {known}; or a scene file .toml)")
    return text


def _read_scene(source: str, allow_paths=()) -> "scenes.Scene":
    """The Scene of a built-in name or a scene file (its meshes read from its own folder and the
    allow_paths folders), or exit 2 naming the file and the problem."""
    if source in scenes.SCENES:
        return scenes.build(source)
    from .scenefile import ScenePathError, read_scene

    try:
        return read_scene(source, allow_paths=allow_paths)
    except (FileNotFoundError, ValueError) as e:
        how = ""
        if isinstance(e, ScenePathError):
            how = ("\n  a scene file's meshes are read from its own folder and from folders given with "
                   "--allow-path DIR (repeatable) only")
        print(f"python -m signorini: error: {e}{how}", file=sys.stderr)
        raise SystemExit(2) from None


def _folder(text: str) -> Path:
    """argparse type: an existing folder (``--allow-path``)."""
    path = Path(text)
    if not path.is_dir():
        raise argparse.ArgumentTypeError(f"not a folder: {text!r}")
    return path


def _add_allow_path(p: argparse.ArgumentParser) -> None:
    """``--allow-path DIR``, repeatable, for the commands that read scene files."""
    p.add_argument("--allow-path", action="append", default=[], type=_folder, metavar="DIR", dest="allow_paths",
                   help="a folder a scene file's mesh files may also be read from, besides the scene file's own "
                        "(repeat it for more; relative to the current folder). Without it a mesh outside the "
                        "scene file's folder (../, an absolute path, a symlink leading out) is refused")


def _positive_int(text: str, what: str = "steps") -> int:
    """argparse type: an integer >= 1 (number of steps, stride)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{what} must be an integer >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{what} must be an integer >= 1, got {value}")
    return value


def _stride(text: str) -> int:
    """argparse type: a frame stride, an integer >= 1."""
    return _positive_int(text, "stride")


def _chunk(text: str) -> int:
    """argparse type: runs per task of a sweep, an integer >= 1."""
    return _positive_int(text, "runs per task")


def _size(text: str) -> tuple[int, int]:
    """argparse type: WIDTHxHEIGHT in pixels, both even and >= 16 (H.264 with yuv420p)."""
    try:
        width, height = (int(x) for x in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must be WIDTHxHEIGHT in pixels, e.g. 640x480, got {text!r}") from None
    if width < 16 or height < 16 or width % 2 or height % 2:
        raise argparse.ArgumentTypeError(f"size must be even and at least 16x16 pixels, got {text!r}")
    return width, height


def _positive_number(what: str, unit: str = "") -> Callable[[str], float]:
    """argparse type: a finite number > 0, the error naming it (``what``) and its unit."""
    suffix = f" ({unit})" if unit else ""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{what} must be a number > 0{suffix}, got {text!r}") from None
        if not (math.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(f"{what} must be a finite number > 0{suffix}, got {text}")
        return value

    return parse


_positive_float = _positive_number("dt", "seconds")  # time step, s
_fps = _positive_number("fps")                        # frames per second of simulated time


def _add_outputs(p: argparse.ArgumentParser, html_default: bool) -> None:
    """The output options shared by ``run`` and ``export``."""
    html = p.add_mutually_exclusive_group()
    html.add_argument("--html", type=Path, metavar="PATH",
                      help="the offline HTML player (default <out>/<scene>.html" + (
                          "" if html_default else "; written when no other output is asked for, or with --html")
                      + ")")
    if html_default:
        html.add_argument("--no-html", action="store_true", help="write no HTML player")
    p.add_argument("--video", nargs="?", const="", type=str, metavar="PATH",
                   help="an MP4 video (PATH default <out>/<scene>.mp4)")
    p.add_argument("--fps", type=_fps, default=30.0, help="video frames per simulated second (default 30)")
    p.add_argument("--size", type=_size, default=(640, 480), help="video size WIDTHxHEIGHT (default 640x480)")
    p.add_argument("--gltf", nargs="?", const="", type=str, metavar="PATH",
                   help="a binary glTF with one animated node per body (PATH default <out>/<scene>.glb)")
    p.add_argument("--usd", nargs="?", const="", type=str, metavar="PATH",
                   help="a USD stage with one time-sampled Xform per body (PATH default <out>/<scene>.usda)")
    p.add_argument("--quiet", action="store_true",
                   help="no progress bars" + (", no decomposition estimate and no SolverWarning" if html_default else ""))


def make_parser() -> argparse.ArgumentParser:
    """The argument parser, with the ``run``, ``export``, ``view``, ``sweep`` and ``list`` sub-commands."""
    parser = argparse.ArgumentParser(
        prog="python -m signorini", description="signorini: rigid bodies with contact.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="examples:\n  python -m signorini list\n  python -m signorini run torus --out out\n"
               "  python -m signorini run my_scene.toml --video\n  python -m signorini COMMAND --help",
    )
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    run = commands.add_parser(
        "run", help="run a built-in scene or a scene file, write <out>/<scene>.npz, .png and .html",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="examples:\n  python -m signorini run                       # the torus, into signorini-out/\n"
               "  python -m signorini run boxes --steps 240 --out out --video --gltf\n"
               "  python -m signorini run path/to/scene.toml --quiet   # any scene file (signorini.scenefile)\n"
               "  python -m signorini run scenes/a.toml --allow-path assets   # meshes also from assets/")
    run.add_argument(
        "scene", nargs="?", default=scenes.DEFAULT_SCENE, type=_scene_name,
        help=f"a built-in scene name (default {scenes.DEFAULT_SCENE}; see 'list') or a scene file .toml",
    )
    run.add_argument("--out", default="signorini-out", type=Path, help="output folder (default signorini-out/)")
    run.add_argument("--steps", type=_positive_int, help="number of steps (default: the scene's)")
    run.add_argument("--dt", type=_positive_float, help="time step in seconds (default: the scene's)")
    run.add_argument("--stride", type=_stride, default=None,
                     help="keep every S-th step as a frame (default: chosen so that the frames fit the 20 MB budget "
                          "of signorini.trajectory.TRAJECTORY_BUDGET; the summary prints it)")
    run.add_argument("--no-plot", action="store_true", help="write no PNG")
    _add_outputs(run, html_default=True)
    _add_allow_path(run)

    export = commands.add_parser(
        "export", help="write the player, video, glTF or USD of a saved trajectory",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="examples:\n  python -m signorini export out/boxes.npz               # out/boxes.html\n"
               "  python -m signorini export out/boxes.npz --gltf --usd --out exported")
    export.add_argument("trajectory", type=Path, help="a .npz written by 'run' or Record.save")
    export.add_argument("--out", type=Path, help="output folder (default: the trajectory's)")
    export.add_argument("--png", action="store_true", help="also the summary plot")
    _add_outputs(export, html_default=False)

    view = commands.add_parser(
        "view", help="serve the interactive viewer of a scene or a trajectory",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="examples:\n  python -m signorini view boxes               # simulated live, http://127.0.0.1:8080\n"
               "  python -m signorini view out/boxes.npz        # a saved trajectory\n"
               "  python -m signorini view my_scene.toml --host 0.0.0.0 --port 9000\n\n"
               "who can connect:\n"
               "  By default the viewer listens on 127.0.0.1: only this machine can reach it, and only\n"
               "  the viewer's own page can open its websocket (a page of another site open in your\n"
               "  browser is refused). With --host 0.0.0.0 (or another address of this machine) ANYONE\n"
               "  WHO CAN REACH THIS MACHINE ON THE NETWORK can open the viewer, watch the simulation\n"
               "  and control it (play, pause, step, scrub): there is no password and no encryption.\n"
               "  Use it on a network you trust only. The share-URL feature (a public tunnel) is off.")
    view.add_argument("source", help="a built-in scene name or a scene file .toml (simulated live), or a trajectory .npz")
    view.add_argument("--host", default="127.0.0.1",
                      help="address to serve on (default 127.0.0.1, this machine only; 0.0.0.0 serves every "
                           "network interface: anyone on the network can view and control the simulation)")
    view.add_argument("--port", type=int, default=8080, help="port (default 8080; the next free one if taken)")
    _add_allow_path(view)

    sweep = commands.add_parser(
        "sweep", help="run a scene file over a grid of parameter values and seeds, on Ray, into one table",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="examples:\n"
               "  python -m signorini sweep boxes --set 'bodies.box_0.friction=0.1:0.9:9' --seeds 20 --steps 240 \\\n"
               "      --out results.parquet\n"
               "  python -m signorini sweep scene.toml --set world.gravity.2=-9.81,-1.62 --set scene.dt=0.002 \\\n"
               "      --out r.parquet --address 10.0.0.1:6379      # a Ray cluster ('ray start --head')\n\n"
               "PATH is a dotted path into the scene file: bodies.<name or index>.<key>, world.<key>,\n"
               "materials.<name>.<key>, scene.<key>, with list indices (world.gravity.2). SPEC is\n"
               "'a:b:n' (n numbers from a to b), 'v1,v2,...' or one value. Seed 0 runs the file as it is;\n"
               "seed s >= 1 moves every dynamic body's start by a uniform offset within +-jitter per axis.\n"
               "Without --address a local Ray starts on this machine (without Ray installed: local\n"
               "processes). Started again with the same --out, a sweep runs only what is missing.")
    sweep.add_argument("scene", type=_scene_name, help="a built-in scene name or a scene file .toml")
    sweep.add_argument("--set", dest="settings", action="append", default=[], metavar="PATH=SPEC",
                       help="a parameter and its values (repeat for a grid of every combination)")
    sweep.add_argument("--seeds", type=_positive_int, default=1, help="seeds 0 .. N-1 per combination (default 1)")
    sweep.add_argument("--steps", type=_positive_int, help="steps per run (default: the scene's)")
    sweep.add_argument("--dt", type=_positive_float, help="time step in seconds (default: the scene's)")
    sweep.add_argument("--jitter", type=float, default=1e-3, help="seeds >= 1: start offsets within +-this (m, default 0.001)")
    sweep.add_argument("--out", type=Path, required=True, help="the results table (.parquet)")
    sweep.add_argument("--address", help="HOST:PORT of a Ray cluster's head (default: a local Ray)")
    sweep.add_argument("--timeout", type=_positive_float, help="seconds per run before it is stopped (default: none)")
    sweep.add_argument("--chunk", type=_chunk, help="runs per task (default: sized from the runs' measured time, "
                                                   "0.1 to 10 s of runs a task)")
    sweep.add_argument("--trajectories", type=Path, metavar="DIR", help="also each run's trajectory .npz, in DIR")
    sweep.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_allow_path(sweep)

    commands.add_parser("list", help="list the built-in scenes", formatter_class=argparse.RawDescriptionHelpFormatter,
                        epilog="example:\n  python -m signorini list | head -2")
    return parser


def _default(value: Optional[str], out: Path, stem: str, ext: str) -> Optional[Path]:
    """The path of an optional output: None when not asked, <out>/<stem>.<ext> when asked without a path."""
    if value is None:
        return None
    return Path(value) if value else out / f"{stem}.{ext}"


def _write_outputs(args: argparse.Namespace, record: "Record", out: Path, html_default: bool,
                   scene: Optional["scenes.Scene"] = None) -> list[Path]:
    """Write the files the options ask for; returns their paths in the order written."""
    from . import output

    files = []
    if getattr(args, "png", False) or (scene is not None and not getattr(args, "no_plot", True)):
        files.append(output.plot(out / f"{record.scene}.png", record, scene))
    html = args.html or (out / f"{record.scene}.html" if html_default and not getattr(args, "no_html", False) else None)
    if html is not None:
        from .player import write_html

        files.append(write_html(html, record))
    video = _default(args.video, out, record.scene, "mp4")
    if video is not None:
        from .render import write_video

        files.append(write_video(video, record, fps=args.fps, size=args.size, progress=not args.quiet))
    gltf = _default(args.gltf, out, record.scene, "glb")
    if gltf is not None:
        from .export import write_gltf

        files.append(write_gltf(gltf, record))
    usd = _default(args.usd, out, record.scene, "usda")
    if usd is not None:
        from .export import write_usd

        files.append(write_usd(usd, record))
    return files


def _run(args: argparse.Namespace) -> int:
    """Build, run, save, draw and summarise one scene."""
    from . import decomposition, output
    from .trajectory import TRAJECTORY_BUDGET
    from .world import SolverWarning

    with contextlib.ExitStack() as quiet:
        if args.quiet:
            # --quiet: no decomposition estimate or bar, no progress bar, no SolverWarning
            quiet.enter_context(decomposition.quiet())
            quiet.enter_context(warnings.catch_warnings())
            warnings.simplefilter("ignore", SolverWarning)
        scene = _read_scene(args.scene, args.allow_paths)
        record = output.run(scene, steps=args.steps, dt=args.dt, progress=not args.quiet, stride=args.stride)
    files = [output.save_trajectory(args.out / f"{scene.name}.npz", record)]
    files += _write_outputs(args, record, args.out, html_default=True, scene=scene)
    print(output.format_summary(record, files, budget=None if args.stride else TRAJECTORY_BUDGET))
    return 0


def _sweep(args: argparse.Namespace) -> int:
    """A sweep of a scene file (signorini.sweep): the table written to --out, a line per status."""
    from . import sweeps as sweep
    from .scenefile import SceneFileError, read_scene

    path = scenes.SCENES.get(args.scene, Path(args.scene))
    try:
        grid = {}
        for item in args.settings:
            name, sep, spec = item.partition("=")
            if not sep or not name or not spec:
                raise sweep.SweepError(f"--set {item!r}: give PATH=SPEC, e.g. bodies.box.friction=0.1:0.9:9")
            if name in grid:
                raise sweep.SweepError(f"--set {name}: given twice")
            grid[name] = sweep.parse_values(spec, f"--set {name}")
        scene = read_scene(path, allow_paths=args.allow_paths)
        runs = sweep.SceneRuns(path, grid, jitter=args.jitter, allow_paths=args.allow_paths)
        table = sweep.sweep(runs, grid, steps=args.steps or scene.steps, dt=args.dt or scene.dt, seeds=args.seeds,
                            address=args.address, out=args.out, timeout=args.timeout, chunk=args.chunk,
                            trajectories=args.trajectories, progress=False if args.quiet else None)
    except (sweep.SweepError, SceneFileError, FileNotFoundError) as e:
        print(f"python -m signorini: error: {e}", file=sys.stderr)
        return 2
    counts = table["status"].value_counts()
    print(f"sweep of {scene.name}: {len(table)} runs ({', '.join(f'{n} {s}' for s, n in counts.items())}) "
          f"-> {args.out}")
    return 0 if counts.get("ok", 0) == len(table) else 1


def _load(path: Union[str, Path]) -> "Record":
    """A trajectory file, or exit 2 with a message naming the file."""
    from .trajectory import load_trajectory

    try:
        return load_trajectory(path)
    except (FileNotFoundError, ValueError) as e:
        print(f"python -m signorini: error: {e}", file=sys.stderr)
        raise SystemExit(2) from None


def _export(args: argparse.Namespace) -> int:
    """Write the asked-for files of a saved trajectory (the HTML player when nothing is asked)."""
    record = _load(args.trajectory)
    out = args.out or args.trajectory.parent
    nothing = not (args.html or args.png or args.video is not None or args.gltf is not None or args.usd is not None)
    files = _write_outputs(args, record, out, html_default=nothing)
    for path in files:
        print(f"written      {path}")
    return 0


def _view(args: argparse.Namespace) -> int:
    """Serve the viewer of a scene name or a trajectory file until Ctrl-C."""
    from .viewer import Viewer

    source: object
    if args.source in scenes.SCENES or args.source.lower().endswith(".toml"):
        source = _read_scene(args.source, args.allow_paths)
    elif Path(args.source).suffix == ".npz" or Path(args.source).exists():
        source = _load(args.source)
    else:
        known = ", ".join(sorted(scenes.SCENES))
        print(f"python -m signorini: error: {args.source!r} is neither a scene ({known}) nor a trajectory file",
              file=sys.stderr)
        return 2
    viewer = None
    try:
        viewer = Viewer(source, host=args.host, port=args.port, verbose=True)
        print(f"signorini viewer of {args.source} at http://{args.host}:{viewer.port} (Ctrl-C stops)", flush=True)
        viewer.serve_forever()
    except KeyboardInterrupt:
        # Ctrl-C while the viewer was still being set up
        if viewer is not None:
            viewer.stop()
    return 0


def _list() -> int:
    """Print each scene with its step, length and description, read from the scene files' [scene]
    tables (nothing is built, so this is instant)."""
    for name in sorted(scenes.SCENES):
        info = scenes.scene_info(name)
        default = " (default)" if name == scenes.DEFAULT_SCENE else ""
        print(f"{name}{default}: {info['bodies']} bodies, {info['steps']} steps of "
              f"{info['dt']:.6g} s = {info['dt'] * info['steps']:.3g} s\n    {info['description']}", flush=True)
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit status (argparse exits with 2 on bad arguments). Output cut
    short by a closed pipe (``... list | head -1``) ends quietly."""
    commands = {"run": _run, "export": _export, "view": _view, "sweep": _sweep}
    try:
        args = make_parser().parse_args(argv)
        if args.command in commands:
            return commands[args.command](args)
        return _list()
    except BrokenPipeError:
        # the reader went away: point stdout at devnull so the interpreter's final flush is quiet
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":
    sys.exit(main())
