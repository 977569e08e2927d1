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
  otherwise a local Ray is started on this machine for the sweep (``LOCAL_RAY``: no dashboard,
  quiet, on 127.0.0.1, Ray's count of the CPUs) and stopped after it.
- "HOST:PORT": the Ray cluster whose head listens there (``ray start --head --port PORT`` on one
  machine, ``ray start --address HOST:PORT`` on the others); checked to answer before any run.
- Without Ray installed (``pip install signorini[ray]``), the runs go to local processes (one per
  core, forked, so ``build`` need not be picklable) and the sweep says so once.

Tasks: a Ray task (or a local process's) runs a chunk of runs, ``chunk`` of them, by default
sized as the sweep goes (``task_size``): a few runs first, then about 1/4 per worker of what is
left, at least 0.1 s and at most 10 s of runs by their measured wall time. ``build`` and
``metrics`` are put in Ray's object store once; a worker imports signorini once, on its first
task. What a sweep on Ray costs beyond its runs is mostly a local Ray's start-up (ray.init, the
workers' first imports, ray.shutdown: seconds) and ~1 ms per task; benchmarks/bench_many.py
prints both, and the sweep size from which start-up is amortised. For a sweep whose serial time
is no more than that start-up, ``Batch`` (threads, one process) is the faster tool.

A run is: ``world = build(seed=s, **params)``, then ``steps`` steps of ``dt`` (in blocks of
steps, the same state bit for bit as one at a time; a ``timeout`` is checked between blocks, each
about 1/20 of it), then the row. Runs are independent: a run that raises, goes non-finite or
times out is a row with its status and message, and the others go on. Ray retries a task whose
worker process died (``max_retries``); a run is deterministic, so a retried run gives the same
row.

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
import logging
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


# Runs per task (``chunk=None``). A task costs ~1 ms of Ray's own work (scheduling, arguments and
# rows through the object store; bench_many prints it) and a run of a small scene ~3 ms, so one
# run per task would spend a quarter of the time in Ray; one task per CPU would leave CPUs idle at
# the end while the last, long tasks finish. So tasks shrink as the sweep goes on (guided
# self-scheduling: each takes 1/(_GUIDED * workers) of the runs not yet given out), but never
# below _MIN_TASK_SECONDS of runs (overhead under 1 % of a task) nor above _MAX_TASK_SECONDS
# (progress and the parts written for resuming keep coming), sized by the runs' mean wall time
# measured so far. The first tasks, before any run is measured, take _FIRST_TASK_RUNS runs.
_GUIDED = 4
_MIN_TASK_SECONDS = 0.1
_MAX_TASK_SECONDS = 10.0
_FIRST_TASK_RUNS = 2
# tasks given out per worker at a time: one running, one waiting, so that no worker waits for the
# driver between tasks
_IN_FLIGHT = 2


def task_size(remaining: int, workers: int, run_seconds: Optional[float]) -> int:
    """Runs in the next task (``chunk=None``, see above) with ``remaining`` runs not yet given out
    to ``workers`` workers, ``run_seconds`` the mean wall time of a run so far (None: none yet)."""
    guided = math.ceil(remaining / (_GUIDED * workers))
    if run_seconds is None:
        size = min(guided, _FIRST_TASK_RUNS)
    else:
        per = max(run_seconds, 1e-9)
        size = min(max(guided, math.ceil(_MIN_TASK_SECONDS / per)), max(1, math.floor(_MAX_TASK_SECONDS / per)))
    return max(1, min(size, remaining))


def _schedule(jobs: list, workers: int, chunk: Optional[int], submit: Callable, wait_one: Callable,
              collect: Callable) -> None:
    """Gives out ``jobs`` as tasks of ``chunk`` runs (None: ``task_size``), ``_IN_FLIGHT`` per
    worker at a time: ``submit(jobs)`` starts a task, ``wait_one()`` returns the rows of one that
    finished (any), ``collect(rows)`` takes them."""
    k, in_flight, measured, wall = 0, 0, 0, 0.0
    while k < len(jobs) or in_flight:
        while k < len(jobs) and in_flight < _IN_FLIGHT * workers:
            size = chunk or task_size(len(jobs) - k, workers, wall / measured if measured else None)
            submit(jobs[k:k + size])
            k, in_flight = k + size, in_flight + 1
        got = wait_one()
        in_flight -= 1
        measured += len(got)
        wall += sum(r["wall"] for r in got)
        collect(got)


# A local Ray started for a sweep: a new one ("local": ray.init with no address would join the
# cluster of the machine's last `ray start` or RAY_ADDRESS instead, even one that has gone or
# that this process cannot reach), no dashboard (a sweep has its progress bar), the workers'
# output kept in Ray's log files rather than copied to the driver, Ray's INFO lines off, and every
# server on 127.0.0.1 (a local Ray serves this process only). The CPUs are Ray's own count of the
# machine's (it reads the container's CPU limit, which os.cpu_count does not).
LOCAL_RAY = {"address": "local", "include_dashboard": False, "log_to_driver": False,
             "logging_level": logging.WARNING, "_node_ip_address": "127.0.0.1"}


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
    again with it resumes), timeout (s per run, or None), chunk (runs per task; default sized as
    the sweep goes, see ``task_size``), trajectories (a folder: each run's trajectory .npz, written
    by the workers), progress (a tqdm bar on stderr; default when stderr is a terminal),
    processes (local processes when Ray is not installed; default the machine's cores).
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
                ray.init(**LOCAL_RAY)
                started = True
            try:
                cpus = max(1, int(ray.cluster_resources().get("CPU", 1)))
                task = ray.remote(max_retries=3, retry_exceptions=False)(_run_chunk)
                # put once, not pickled again with every task
                build_ref, metrics_ref = ray.put(build), ray.put(metrics)
                running: list = []

                def wait_one() -> list[dict]:
                    ready, _ = ray.wait(running, num_returns=1)
                    running.remove(ready[0])
                    return ray.get(ready[0])

                _schedule(jobs, cpus, chunk,
                          lambda some: running.append(task.remote(build_ref, some, steps, dt, metrics_ref, timeout,
                                                                  trajectories)),
                          wait_one, collect)
            finally:
                if started:
                    ray.shutdown()
        elif jobs:
            import multiprocessing
            import queue

            warnings.warn("sweep: Ray is not installed (pip install 'signorini[ray]'): the runs go to local "
                          "processes on this machine", RuntimeWarning, stacklevel=2)
            n = processes or os.cpu_count() or 1
            _LOCAL_JOB.update(build=build, steps=steps, dt=dt, metrics=metrics, timeout=timeout,
                              trajectories=trajectories)
            finished: queue.SimpleQueue = queue.SimpleQueue()

            def wait_one() -> list[dict]:
                got = finished.get()
                if isinstance(got, BaseException):
                    raise got
                return got

            try:
                with multiprocessing.get_context("fork").Pool(n) as pool:
                    _schedule(jobs, n, chunk,
                              lambda some: pool.apply_async(_local_chunk, (some,), callback=finished.put,
                                                            error_callback=finished.put),
                              wait_one, collect)
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

