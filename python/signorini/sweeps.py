"""Parameter sweeps: every combination of a grid of parameters, each with every seed, run as Ray
tasks (or, without Ray, in local processes), gathered into one table.

    import signorini as sg
    def build(seed, friction):
        w = sg.World(gravity=(0, 0, -9.81))
        ...
        return w
    table = sg.sweep(build, {"friction": [0.1, 0.5, 0.9]}, steps=600, dt=1/240, seeds=20,
                     out="results.parquet")                 # pandas.DataFrame, one row per run

    python -m signorini sweep scene.toml --set 'bodies.box.friction=0.1:0.9:9' --seeds 20 \\
        --steps 600 --out results.parquet [--address HOST:PORT]

Where the runs go (``address``):
- None: a Ray already initialised in this process (``ray.init`` by the caller) is used as it is;
  otherwise a local Ray is started on this machine for the sweep and stopped after it.
- "HOST:PORT": the Ray cluster whose head listens there (``ray start --head --port PORT`` on one
  machine, ``ray start --address HOST:PORT`` on the others); checked to answer before any run.
- Without Ray installed (``pip install signorini[ray]``), the runs go to local processes (one per
  core, forked, so ``build`` need not be picklable) and the sweep says so once.

A run is: ``world = build(seed=s, **params)``, then ``steps`` steps of ``dt`` (one at a time, so a
``timeout`` is checked between steps), then the row. Runs are independent: a run that raises,
goes non-finite or times out is a row with its status and message, and the others go on. Ray
retries a task whose worker process died (``max_retries``); a run is deterministic, so a retried
run gives the same row.

Rows (``ROW_COLUMNS``, then the parameters' and the metrics' columns): one column per parameter
(in the grid's order), ``seed``, ``status`` ("ok", "build_error", "exception", "nonfinite",
"timeout", "metrics_error"), ``error`` (the message, "" when ok), ``steps_done``, ``time`` (s,
simulated), ``kinetic_energy``, ``potential_energy`` (J, ``World.potential_energy``), ``contacts``
(the last step's count) and the last step's certificate maxima (``residual``,
``max_penetration_velocity``, ``max_overlap``, ``max_cone_violation``), the final ``positions``
(N, 3) and ``orientations`` (N, 4) as nested lists, ``wall`` (s, the run's own wall time) and
``state_hash`` (``state_hash``: SHA-256 of the final positions, orientations, velocities and
angular velocities), so a run gives the same row, bit for bit, wherever it ran; then the user's
``metrics(world)`` columns. Rows are ordered by grid combination (the first parameter varying
slowest), then seed.

Resuming: with ``out`` given, each finished task's rows are written at once to
``<out>.parts/`` (one Parquet file per task); a sweep started again with the same ``out``, grid
and seeds reads them and ``out`` itself and runs only what is missing; at the end the whole table
is written to ``out`` (Parquet, pyarrow) and the parts are removed.

Why not Ray's own ``ray.tune``: Tune is built for hyper-parameter search with trial schedulers
and checkpoints of training state; a sweep here is a fixed, deterministic grid whose rows are
plain data, which plain Ray tasks carry with less machinery.
"""
from __future__ import annotations

import hashlib
import itertools
import math
import os
import pickle
import socket
import sys
import time
import warnings
from pathlib import Path
from typing import Callable, Iterable, Mapping, Optional, Sequence

import numpy as np

from .world import SolverWarning, World

STATUSES = ("ok", "build_error", "exception", "nonfinite", "timeout", "metrics_error")
ROW_COLUMNS = ("seed", "status", "error", "steps_done", "time", "kinetic_energy", "potential_energy", "contacts",
               "residual", "max_penetration_velocity", "max_overlap", "max_cone_violation", "positions",
               "orientations", "wall", "state_hash")
_CERTIFICATE = ("residual", "max_penetration_velocity", "max_overlap", "max_cone_violation")


class SweepError(ValueError):
    """A sweep refused before any run: a bad grid, seeds, steps, dt, output or address."""


def state_hash(world: World) -> str:
    """SHA-256 (hex) of the world's positions, orientations, velocities and angular velocities as
    float64 bytes: equal hashes mean bit-identical states."""
    h = hashlib.sha256()
    for a in (world.positions, world.orientations, world.velocities, world.angular_velocities):
        h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
    return h.hexdigest()


def grid_points(grid: Mapping[str, Sequence]) -> list[dict]:
    """Every combination of the grid's values as a list of dicts, the first parameter varying
    slowest. SweepError naming the parameter for a grid that is not a mapping of names to
    non-empty lists."""
    if not isinstance(grid, Mapping):
        raise SweepError(f"sweep: grid must map parameter names to lists of values, got {type(grid).__name__}")
    names = list(grid)
    values = []
    for name in names:
        if not isinstance(name, str) or not name:
            raise SweepError(f"sweep: grid parameter {name!r}: names must be non-empty strings "
                             "(they are passed to build as keywords)")
        if name in ROW_COLUMNS:
            raise SweepError(f"sweep: grid parameter {name!r}: the name is taken by a result column")
        v = grid[name]
        if isinstance(v, (str, bytes)) or not isinstance(v, Iterable):
            raise SweepError(f"sweep: grid parameter {name!r}: give a list of values, got {v!r}")
        v = list(v)
        if not v:
            raise SweepError(f"sweep: grid parameter {name!r}: the list of values is empty")
        values.append(v)
    return [dict(zip(names, combo)) for combo in itertools.product(*values)]


def _seed_list(seeds) -> list[int]:
    if isinstance(seeds, (bool, np.bool_)):
        raise SweepError(f"sweep: seeds must be a count >= 1 or a list of integers, got {seeds!r}")
    if isinstance(seeds, (int, np.integer)):
        if seeds < 1:
            raise SweepError(f"sweep: seeds must be >= 1, got {seeds}")
        return list(range(int(seeds)))
    try:
        got = list(seeds)
    except TypeError:
        raise SweepError(f"sweep: seeds must be a count >= 1 or a list of integers, got {seeds!r}") from None
    if not got or not all(isinstance(s, (int, np.integer)) and not isinstance(s, (bool, np.bool_)) for s in got):
        raise SweepError(f"sweep: seeds must be a count >= 1 or a non-empty list of integers, got {seeds!r}")
    if len(set(got)) != len(got):
        raise SweepError(f"sweep: seeds has duplicates: {got!r}")
    return [int(s) for s in got]


# World.step takes at most INT_MAX steps per call
_STEPS_PER_CALL = 2 ** 30
# with a timeout, the steps go in blocks sized to last about 1/_TIMEOUT_CHECKS of it
_TIMEOUT_CHECKS = 20


def _advance(world: World, recorder, steps: int, dt: float, start: float, timeout: Optional[float], row: dict) -> None:
    """Steps the run's world ``steps`` times; sets row's steps_done, and its status and error when
    a step raises or the run's time (since ``start``) passes ``timeout``.

    The steps go to the core in blocks, not one Python call each: a call's own work (argument
    checks, the lock, the step report) cost half as much again as the steps of a small scene, and
    World.step(dt, n) is n single steps, bit for bit. Without a timeout a run is one block; with
    one, blocks are sized from the steps' measured pace to last about 1/_TIMEOUT_CHECKS of it
    (starting at one step, at most doubling). A block that raises is stepped again one step at a
    time from the state saved before it (the steps after restore_state are bit-identical), so the
    row names the step that failed and keeps the state before it, as single steps would. A
    recorder observes every step: one at a time."""
    def fail(k: int, e: Exception) -> None:
        text = f"step {k} (t = {world.time:.6g} s): {type(e).__name__}: {e}"
        row.update(status="nonfinite" if "non-finite" in str(e) else "exception", error=text)

    k, block = 0, 1
    while k < steps:
        if timeout is not None and time.perf_counter() - start > timeout:
            row.update(status="timeout", error=f"still running after {timeout:g} s (step {k} of {steps})")
            return
        n = 1 if recorder is not None else min(steps - k, _STEPS_PER_CALL if timeout is None else block)
        saved = world.save_state() if n > 1 else None
        began = time.perf_counter()
        try:
            if recorder is not None:
                recorder.step(dt, 1)
            else:
                world.step(dt, n)
        except Exception as e:  # noqa: BLE001 - a failing run is a row
            if saved is None:
                return fail(k, e)
            # again one step at a time, to name the step that fails and keep the state before it
            world.restore_state(saved)
            for j in range(k, k + n):
                try:
                    world.step(dt)
                except Exception as again:  # noqa: BLE001
                    return fail(j, again)
                row["steps_done"] = j + 1
            # (not reached: the core is deterministic; had the steps passed, the run would go on)
        k += n
        row["steps_done"] = k
        if timeout is not None:
            pace = (time.perf_counter() - began) / n
            block = max(1, min(2 * n, int(timeout / _TIMEOUT_CHECKS / pace))) if pace > 0 else 2 * n


def run_one(build: Callable, params: dict, seed: int, steps: int, dt: float, metrics: Optional[Callable] = None,
            timeout: Optional[float] = None, trajectories: Optional[str] = None) -> dict:
    """One run as a row (module doc): build(seed=seed, **params), steps steps of dt, the metrics.
    Never raises for what the run does; the row's status says what went wrong."""
    start = time.perf_counter()
    row: dict = {**params, "seed": seed, "status": "ok", "error": "", "steps_done": 0}

    def finish(world: Optional[World]) -> dict:
        if world is not None:
            stats = world.solver_stats
            row.update(time=world.time, kinetic_energy=world.kinetic_energy(),
                       potential_energy=world.potential_energy(), contacts=stats.contacts,
                       **{k: getattr(stats, k) for k in _CERTIFICATE},
                       positions=world.positions.tolist(), orientations=world.orientations.tolist(),
                       state_hash=state_hash(world))
        row["wall"] = time.perf_counter() - start
        return row

    try:
        world = build(seed=seed, **params)
        if not isinstance(world, World):
            raise TypeError(f"build returned {type(world).__name__}, not a signorini.World")
    except Exception as e:  # noqa: BLE001 - a failing run is a row
        row.update(status="build_error", error=f"{type(e).__name__}: {e}")
        return finish(None)
    recorder = None
    if trajectories is not None:
        from .trajectory import Recorder

        recorder = Recorder(world, steps=steps)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SolverWarning)  # the certificate columns say what the solver did
        _advance(world, recorder, steps, dt, start, timeout, row)
    if row["status"] == "ok" and not all(np.isfinite(a).all() for a in (world.positions, world.velocities)):
        row.update(status="nonfinite", error="the final state is not finite")
    if recorder is not None and row["steps_done"] > 0:
        name = "_".join([f"{k}={v}" for k, v in params.items()] + [f"seed={seed}"])
        recorder.record().save(Path(trajectories) / f"{name}.npz")
    if metrics is not None and row["status"] == "ok":
        try:
            extra = metrics(world)
            if not isinstance(extra, Mapping):
                raise TypeError(f"metrics returned {type(extra).__name__}, not a dict")
            clash = [k for k in extra if k in row or k in ROW_COLUMNS]
            if clash:
                raise ValueError(f"metrics column(s) {clash} clash with the result's own columns")
            row.update(extra)
        except Exception as e:  # noqa: BLE001
            row.update(status="metrics_error", error=f"{type(e).__name__}: {e}")
    return finish(world)


def _run_chunk(build, jobs, steps, dt, metrics, timeout, trajectories) -> list[dict]:
    """The rows of (index, params, seed) jobs, in order (a Ray task's body)."""
    return [dict(run_one(build, params, seed, steps, dt, metrics, timeout, trajectories), _index=index)
            for index, params, seed in jobs]


def _check_address(address: str) -> None:
    host, sep, port = address.rpartition(":")
    if not sep or not host or not port.isdigit():
        raise SweepError(f"sweep: address must be HOST:PORT (a Ray head's), got {address!r}")
    try:
        with socket.create_connection((host, int(port)), timeout=5.0):
            pass
    except OSError as e:
        raise SweepError(f"sweep: no Ray cluster answers at address {address!r} ({e}); start one with "
                         f"'ray start --head --port {port}' on {host}") from None


def _key(params: dict, seed: int) -> str:
    return repr((sorted((k, repr(v)) for k, v in params.items()), int(seed)))


def _read_done(out: Path) -> list[dict]:
    """Rows already written: ``out`` itself and the parts of an interrupted sweep."""
    import pandas as pd

    files = ([out] if out.exists() else []) + sorted((out.parent / (out.name + ".parts")).glob("*.parquet"))
    rows = []
    for f in files:
        rows.extend(pd.read_parquet(f).to_dict("records"))
    return rows


def _plain(rows: list[dict]) -> list[dict]:
    """Rows with NumPy arrays as nested lists (Parquet and pandas take those)."""
    return [{k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in r.items()} for r in rows]


def _write_parquet(table, path: Path) -> None:
    """A DataFrame to path, whole or not at all (written beside it, then renamed)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    table.to_parquet(tmp, index=False)
    os.replace(tmp, path)


# without Ray: the forked workers find the job here (set before the pool forks), so build and
# metrics need not be picklable
_LOCAL_JOB: dict = {}


def _local_chunk(jobs) -> list[dict]:
    j = _LOCAL_JOB
    return _run_chunk(j["build"], jobs, j["steps"], j["dt"], j["metrics"], j["timeout"], j["trajectories"])


def sweep(build: Callable, grid: Mapping[str, Sequence], steps: int, dt: float, seeds=1,
          metrics: Optional[Callable] = None, address: Optional[str] = None, out=None, *,
          timeout: Optional[float] = None, chunk: Optional[int] = None, trajectories=None,
          progress: Optional[bool] = None, processes: Optional[int] = None):
    """Runs build(seed=s, **params) for every combination of ``grid`` and every seed (module doc)
    and returns the rows as a pandas DataFrame.

    Inputs: build (callable -> World; with Ray it must pickle with cloudpickle), grid ({name:
    [values]}), steps (>= 1), dt (s, > 0), seeds (a count n, seeds 0..n-1, or a list of distinct
    integers), metrics (callable world -> dict of extra columns, or None), address (None or
    "HOST:PORT", see the module doc), out (a .parquet path: written at the end; a sweep started
    again with it resumes), timeout (s per run, or None), chunk (runs per task; default about four
    tasks per CPU), trajectories (a folder: each run's trajectory .npz, written by the workers),
    progress (a tqdm bar on stderr; default when stderr is a terminal), processes (local
    processes when Ray is not installed; default the machine's cores).
    Raises SweepError before any run for a bad grid, seeds, steps, dt, out or address.
    """
    import pandas as pd

    if not callable(build):
        raise SweepError(f"sweep: build must be callable (seed=..., **params) -> World, got {build!r}")
    if metrics is not None and not callable(metrics):
        raise SweepError(f"sweep: metrics must be callable (world) -> dict, got {metrics!r}")
    points = grid_points(grid)
    seed_list = _seed_list(seeds)
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1:
        raise SweepError(f"sweep: steps must be an integer >= 1, got {steps!r}")
    if isinstance(dt, bool) or not isinstance(dt, (int, float, np.floating)) or not (math.isfinite(dt) and dt > 0):
        raise SweepError(f"sweep: dt must be a finite number > 0, got {dt!r}")
    if timeout is not None and not (isinstance(timeout, (int, float)) and timeout > 0):
        raise SweepError(f"sweep: timeout must be a number > 0 (s) or None, got {timeout!r}")
    if chunk is not None and (isinstance(chunk, bool) or not isinstance(chunk, int) or chunk < 1):
        raise SweepError(f"sweep: chunk must be an integer >= 1 or None, got {chunk!r}")
    if out is not None:
        out = Path(out)
        if out.suffix != ".parquet":
            raise SweepError(f"sweep: out must be a .parquet file, got {str(out)!r}")
    if trajectories is not None:
        trajectories = str(Path(trajectories).resolve())
        Path(trajectories).mkdir(parents=True, exist_ok=True)
    if address is not None:
        if not isinstance(address, str):
            raise SweepError(f"sweep: address must be 'HOST:PORT' or None, got {address!r}")
        _check_address(address)
    try:
        import ray
    except ImportError:
        ray = None
        if address is not None:
            raise SweepError(f"sweep: address {address!r} needs Ray: pip install 'signorini[ray]'") from None

    jobs_all = [(i * len(seed_list) + j, params, seed) for i, params in enumerate(points)
                for j, seed in enumerate(seed_list)]
    done_rows: dict[int, dict] = {}
    if out is not None:
        wanted = {_key(params, seed): index for index, params, seed in jobs_all}
        for r in _read_done(out):
            params = {k: r[k] for k in points[0]} if all(k in r for k in points[0]) else None
            index = wanted.get(_key(params, r["seed"])) if params is not None else None
            if index is not None:
                r.pop("_index", None)
                done_rows[index] = r
    jobs = [job for job in jobs_all if job[0] not in done_rows]
    parts = out.parent / (out.name + ".parts") if out is not None else None

    from tqdm import tqdm

    bar = tqdm(total=len(jobs_all), initial=len(done_rows), unit="run", desc="sweep", file=sys.stderr,
               disable=(not sys.stderr.isatty()) if progress is None else not progress)
    rows: dict[int, dict] = dict(done_rows)

    def collect(got: list[dict]) -> None:
        if parts is not None and got:
            _write_parquet(pd.DataFrame(_plain(got)), parts / f"runs-{got[0]['_index']:08d}.parquet")
        for r in got:
            rows[r.pop("_index")] = r
        bar.update(len(got))

    try:
        if jobs and ray is not None:
            started = False
            if address is not None:
                ray.init(address=address, ignore_reinit_error=True, log_to_driver=False)
                started = True
            elif not ray.is_initialized():
                ray.init(include_dashboard=False, log_to_driver=False, _node_ip_address="127.0.0.1")
                started = True
            try:
                cpus = max(1, int(ray.cluster_resources().get("CPU", 1)))
                size = chunk or max(1, math.ceil(len(jobs) / (4 * cpus)))
                task = ray.remote(max_retries=3, retry_exceptions=False)(_run_chunk)
                build_ref = ray.put(build)
                pending = [task.remote(build_ref, jobs[k:k + size], steps, dt, metrics, timeout, trajectories)
                           for k in range(0, len(jobs), size)]
                while pending:
                    ready, pending = ray.wait(pending, num_returns=1)
                    collect(ray.get(ready[0]))
            finally:
                if started:
                    ray.shutdown()
        elif jobs:
            import multiprocessing

            warnings.warn("sweep: Ray is not installed (pip install 'signorini[ray]'): the runs go to local "
                          "processes on this machine", RuntimeWarning, stacklevel=2)
            n = processes or os.cpu_count() or 1
            size = chunk or max(1, math.ceil(len(jobs) / (4 * n)))
            _LOCAL_JOB.update(build=build, steps=steps, dt=dt, metrics=metrics, timeout=timeout,
                              trajectories=trajectories)
            try:
                with multiprocessing.get_context("fork").Pool(n) as pool:
                    for got in pool.imap_unordered(_local_chunk, [jobs[k:k + size] for k in range(0, len(jobs), size)]):
                        collect(got)
            finally:
                _LOCAL_JOB.clear()
    finally:
        bar.close()
    table = pd.DataFrame(_plain([rows[i] for i in sorted(rows)]))
    if out is not None:
        _write_parquet(table, out)
        if parts is not None and parts.exists():
            for f in parts.glob("*.parquet"):
                f.unlink()
            parts.rmdir()
    return table


def parse_values(spec: str, where: str) -> list:
    """The values of a ``--set`` spec: 'a:b:n' (n numbers from a to b, both included), 'v1,v2,...'
    (numbers, true/false or strings) or one value. SweepError naming ``where``."""
    def value(text: str):
        t = text.strip()
        if t.lower() in ("true", "false"):
            return t.lower() == "true"
        try:
            return int(t)
        except ValueError:
            pass
        try:
            return float(t)
        except ValueError:
            return t

    if spec.count(":") == 2:
        a, b, n = spec.split(":")
        try:
            lo, hi, count = float(a), float(b), int(n)
        except ValueError:
            raise SweepError(f"{where}: 'a:b:n' needs two numbers and a count, got {spec!r}") from None
        if count < 1 or not (math.isfinite(lo) and math.isfinite(hi)):
            raise SweepError(f"{where}: 'a:b:n' needs finite a, b and n >= 1, got {spec!r}")
        return [float(x) for x in np.linspace(lo, hi, count)]
    values = [value(t) for t in spec.split(",")]
    if any(v == "" for v in values):
        raise SweepError(f"{where}: an empty value in {spec!r}")
    return values


class SceneRuns:
    """``build`` for a sweep of a scene file (the ``sweep`` command): the scene's World for each
    combination of overrides, built once on the driver (so that a bad path or value is refused
    before any run, and the workers need not read the scene's files), and for seed s >= 1 every
    dynamic body's start position moved by a uniform offset in [-jitter, jitter] per axis from
    ``numpy.random.default_rng(s)`` (seed 0: the file as it is)."""

    def __init__(self, path, grid: Mapping[str, Sequence], jitter: float = 1e-3, allow_paths=()):
        from .scenefile import read_scene

        if not (isinstance(jitter, (int, float)) and math.isfinite(jitter) and jitter >= 0):
            raise SweepError(f"sweep: jitter must be a finite number >= 0 (m), got {jitter!r}")
        self.jitter = float(jitter)
        self.worlds = {}
        for point in grid_points(grid):
            scene = read_scene(path, allow_paths=allow_paths, overrides=point)
            self.worlds[_key(point, 0)] = pickle.dumps(scene.world)

    def __call__(self, seed: int, **params) -> World:
        world = pickle.loads(self.worlds[_key(params, 0)])
        if seed != 0 and self.jitter > 0:
            rng = np.random.default_rng(seed)
            moving = np.nonzero(~world.is_static)[0]
            offsets = rng.uniform(-self.jitter, self.jitter, size=(len(moving), 3))
            world.set_positions(moving, np.array(world.positions)[moving] + offsets)
        return world

