"""Many runs (issue 22): throughput of R runs of a 1 s scene done serially, with sg.Batch on the
core's threads, as a Ray sweep on this machine, with pybullet DIRECT in a multiprocessing pool and
with MuJoCo's rollout (its thread pool over a list of models); printed, never asserted.

    python benchmarks/bench_many.py [--runs 1000] [--threads 2] [--repeats 3] [--no-ray] [--no-peers]

The scene: a 0.2 m box (density 1000) dropped from 5 cm onto a 25 degree slope, run i with its own
friction mu in [0.1, 0.9] (the contact's: signorini sqrt(mu_box mu_slope) with the slope's 1 and the
box's mu^2; pybullet mu_box mu_slope with the slope's 1; MuJoCo the larger of the two with the
slope's 0) and yaw, both from numpy.random.default_rng(i); dt 1/240, 240 steps (1 s). Every method
builds its worlds inside its timing. Figures: runs per second (median of --repeats), the speed-up
over signorini serial, and for Ray its start-up (the sweep with it minus the sweep on a Ray already
running, and its parts: ray.init, the workers' first tasks, ray.shutdown), its per-task overhead
(no-op tasks), its steady state (already running) and the sweep size at which the start-up is
amortised enough for 1.6x. Targets (issue 22): Batch at least 1.8x serial on 2 cores, Ray at
least 1.6x including its start-up, Batch at least MuJoCo rollout's runs per second per core.

Ray servers listen on 127.0.0.1 only: run as root, the script re-runs itself inside a network
namespace of its own with only loopback up (unshare -n), as the tests do.
"""
from __future__ import annotations

import argparse
import copy
import math
import os
import shutil
import statistics
import subprocess
import sys
import time

import numpy as np

import signorini as sg
from signorini import sweeps

ANGLE = math.radians(25.0)
DT, STEPS = 1.0 / 240.0, 240
HALF = 0.1


def draw(i: int) -> tuple[float, float]:
    """(mu, yaw) of run i."""
    rng = np.random.default_rng(i)
    return float(rng.uniform(0.1, 0.9)), float(rng.uniform(0.0, 2.0 * math.pi))


def slope_frame() -> tuple[np.ndarray, np.ndarray]:
    """The slope's normal and the quaternion (w, x, y, z) turning z onto it."""
    n = np.array([-math.sin(ANGLE), 0.0, math.cos(ANGLE)])
    return n, np.array([math.cos(-ANGLE / 2), 0.0, math.sin(-ANGLE / 2), 0.0])


def box_start(yaw: float) -> tuple[tuple, tuple]:
    """Centre 5 cm above the slope's contact height and orientation: yawed about the normal (the
    slope's tilt about y times the yaw about z, written out: a run's set-up is part of its cost)."""
    c, s = math.cos(-ANGLE / 2), math.sin(-ANGLE / 2)
    cz, sz = math.cos(yaw / 2), math.sin(yaw / 2)
    # (c, 0, s, 0) * (cz, 0, 0, sz)
    q = (c * cz, s * sz, s * cz, c * sz)
    d = HALF + 0.05
    return (-d * math.sin(ANGLE), 0.0, d * math.cos(ANGLE)), q


def make(i: int) -> sg.World:
    mu, yaw = draw(i)
    n, _ = slope_frame()
    w = sg.World(gravity=(0, 0, -9.81), threads=1)
    w.add_static(sg.Plane(normal=tuple(n), offset=0.0), friction=1.0)
    p, q = box_start(yaw)
    w.add_body(sg.Box((HALF, HALF, HALF)), density=1000.0, position=p, orientation=q, friction=mu * mu)
    return w


def serial(runs: int) -> float:
    t = time.perf_counter()
    for i in range(runs):
        make(i).step(DT, STEPS)
    return time.perf_counter() - t


def batch(runs: int, threads: int) -> float:
    t = time.perf_counter()
    b = sg.Batch(make, runs, threads=threads)
    b.step(DT, STEPS)
    return time.perf_counter() - t


def sweep_ray(runs: int) -> float:
    """The sweep as a user runs it: sg.sweep starts a local Ray, runs, and stops it."""
    t = time.perf_counter()
    table = sg.sweep(lambda seed, run: make(run), {"run": list(range(runs))}, steps=STEPS, dt=DT, progress=False)
    assert (table["status"] == "ok").all()
    return time.perf_counter() - t


def _warm(seconds: float) -> None:
    """A first task: imports what a sweep's task imports, then holds its worker for `seconds` (so
    that each of the tasks given out at once lands on a worker of its own)."""
    import signorini.sweeps  # noqa: F401

    time.sleep(seconds)


def sweep_running_ray(runs: int, figures: list) -> float:
    """The sweep on a local Ray started before the timing, its workers warm (as on a cluster that
    is up): its steady state. The start-up's parts are timed on the way and put in `figures`:
    ray.init (the same options as sg.sweep's own local Ray), the workers' first tasks (their
    imports), Ray's per-task overhead (no-op tasks), the share of the CPUs' time the sweep spent in
    runs, and ray.shutdown."""
    import ray

    got = {}
    t = time.perf_counter()
    ray.init(**sweeps.LOCAL_RAY)
    got["init"] = time.perf_counter() - t
    cpus = int(ray.cluster_resources()["CPU"])
    hold = 0.5
    t = time.perf_counter()
    ray.get([ray.remote(_warm).remote(hold) for _ in range(cpus)])
    got["warm"] = time.perf_counter() - t - hold
    got["task"] = ray_task_overhead()
    try:
        t = time.perf_counter()
        table = sg.sweep(lambda seed, run: make(run), {"run": list(range(runs))}, steps=STEPS, dt=DT, progress=False)
        elapsed = time.perf_counter() - t
        assert (table["status"] == "ok").all()
        got["busy"] = table["wall"].sum() / (cpus * elapsed)
    finally:
        t = time.perf_counter()
        ray.shutdown()
        got["shutdown"] = time.perf_counter() - t
    figures.append(got)
    return elapsed


def ray_task_overhead(tasks: int = 400) -> float:
    """Seconds per no-op task on the running Ray, submitted all at once and gathered."""
    import ray

    noop = ray.remote(lambda: None)
    ray.get([noop.remote() for _ in range(20)])
    t = time.perf_counter()
    ray.get([noop.remote() for _ in range(tasks)])
    return (time.perf_counter() - t) / tasks


def runs_for(target: float, start_up: float, serial_run: float, steady: float) -> float:
    """Runs a sweep needs for `target` times serial including a start-up of `start_up` s: runs R of
    `serial_run` s each, at `steady` times serial once Ray runs, take R serial_run / steady +
    start_up; that is R serial_run / target when R = start_up / (serial_run (1/target - 1/steady)).
    Infinite when the steady state itself is below the target."""
    if steady <= target:
        return math.inf
    return start_up / (serial_run * (1.0 / target - 1.0 / steady))


_PB = None


def _pb_worker_init():
    global _PB
    import pybullet

    _PB = pybullet.connect(pybullet.DIRECT)


def _pb_run(i: int) -> list:
    import pybullet as p

    mu, yaw = draw(i)
    p.resetSimulation(physicsClientId=_PB)
    p.setGravity(0, 0, -9.81, physicsClientId=_PB)
    p.setPhysicsEngineParameter(fixedTimeStep=DT, numSolverIterations=10, physicsClientId=_PB)
    n, q_slope = slope_frame()
    plane = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=_PB)
    ground = p.createMultiBody(0, plane, baseOrientation=[*q_slope[1:], q_slope[0]], physicsClientId=_PB)
    p.changeDynamics(ground, -1, lateralFriction=1.0, physicsClientId=_PB)
    box = p.createCollisionShape(p.GEOM_BOX, halfExtents=[HALF] * 3, physicsClientId=_PB)
    pos, q = box_start(yaw)
    body = p.createMultiBody(8.0, box, basePosition=list(pos), baseOrientation=[*q[1:], q[0]], physicsClientId=_PB)
    p.changeDynamics(body, -1, lateralFriction=mu, physicsClientId=_PB)
    for _ in range(STEPS):
        p.stepSimulation(physicsClientId=_PB)
    return list(p.getBasePositionAndOrientation(body, physicsClientId=_PB)[0])


def pybullet_pool(runs: int, processes: int) -> float | None:
    try:
        import pybullet  # noqa: F401
    except ImportError:
        return None
    import multiprocessing

    t = time.perf_counter()
    with multiprocessing.get_context("fork").Pool(processes, initializer=_pb_worker_init) as pool:
        pool.map(_pb_run, range(runs), chunksize=max(1, runs // (8 * processes)))
    return time.perf_counter() - t


MJCF = """<mujoco><option timestep="{dt}"/>
<worldbody><geom name="slope" type="plane" size="5 5 0.1" euler="0 {deg} 0" friction="0 0.005 0.0001"/>
<body name="box"><freejoint/><geom name="box" type="box" size="{h} {h} {h}" density="1000" friction="0.5 0.005 0.0001"/></body>
</worldbody></mujoco>"""


def mujoco_rollout(runs: int, threads: int) -> float | None:
    try:
        import mujoco
        from mujoco import rollout
    except ImportError:
        return None
    t = time.perf_counter()
    base = mujoco.MjModel.from_xml_string(MJCF.format(dt=DT, deg=-math.degrees(ANGLE), h=HALF))
    models, states = [], []
    data = mujoco.MjData(base)
    size = mujoco.mj_stateSize(base, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    for i in range(runs):
        mu, yaw = draw(i)
        m = copy.copy(base)  # a model of its own (MjModel copies its arrays)
        m.geom_friction[1, 0] = mu
        models.append(m)
        pos, q = box_start(yaw)
        mujoco.mj_resetData(base, data)
        data.qpos[:3], data.qpos[3:7] = pos, q
        state = np.empty(size)
        mujoco.mj_getState(base, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        states.append(state)
    datas = [mujoco.MjData(base) for _ in range(threads)]
    rollout.rollout(models, datas, np.array(states), nstep=STEPS)
    return time.perf_counter() - t


def in_loopback_namespace() -> bool:
    """True when this network namespace has no interface but loopback (one of our own; asked of
    the kernel through the namespace itself: /sys/class/net shows the namespace sysfs was mounted in)."""
    import socket

    return all(name == "lo" for _, name in socket.if_nameindex())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=1000)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--no-ray", action="store_true", help="leave out the Ray sweep")
    parser.add_argument("--no-peers", action="store_true", help="leave out pybullet and MuJoCo")
    args = parser.parse_args(argv)
    try:
        import ray  # noqa: F401
        have_ray = not args.no_ray
    except ImportError:
        have_ray = False
    if have_ray and not in_loopback_namespace():
        if os.geteuid() == 0 and shutil.which("unshare"):
            command = ["unshare", "-n", "sh", "-c", 'ip link set lo up && exec "$@"', "sh", sys.executable,
                       os.path.abspath(__file__), *(argv if argv is not None else sys.argv[1:])]
            env = dict(os.environ, RAY_USAGE_STATS_ENABLED="0", RAY_AUTH_MODE="disabled")
            return subprocess.call(command, env=env)
        print("the Ray sweep is left out: it needs a loopback-only network namespace (root and unshare)")
        have_ray = False

    methods = {"signorini serial": lambda: serial(args.runs),
               f"signorini Batch, {args.threads} threads": lambda: batch(args.runs, args.threads)}
    ray_figures: list[dict] = []
    with_start = "signorini sweep on a local Ray, start-up included"
    running = "signorini sweep on a local Ray already running"
    if have_ray:
        methods[with_start] = lambda: sweep_ray(args.runs)
        methods[running] = lambda: sweep_running_ray(args.runs, ray_figures)
    if not args.no_peers:
        methods[f"pybullet DIRECT, multiprocessing pool of {args.threads}"] = lambda: pybullet_pool(args.runs, args.threads)
        methods[f"MuJoCo rollout, {args.threads} threads"] = lambda: mujoco_rollout(args.runs, args.threads)
    times: dict[str, list] = {name: [] for name in methods}
    for _ in range(args.repeats):   # interleaved: each repeat runs every method once
        for name, run in methods.items():
            times[name].append(run())
    print(f"{args.runs} runs of a box dropped on a 25 degree slope, 1 s at dt 1/240, median of {args.repeats}:")
    base = statistics.median(times["signorini serial"])
    print(f"  {'method':<62} {'runs/s':>9} {'vs serial':>10}")
    for name, got in times.items():
        if got[0] is None:
            print(f"  {name:<62} {'not installed':>20}")
            continue
        t = statistics.median(got)
        print(f"  {name:<62} {args.runs / t:9.0f} {base / t:9.2f}x")
    if have_ray:
        def median(key):
            return statistics.median(f[key] for f in ray_figures)

        serial_run = base / args.runs
        steady = base / statistics.median(times[running])
        start_up = statistics.median(times[with_start]) - statistics.median(times[running])
        print(f"  Ray on this machine ({os.cpu_count()} cores): start-up {start_up:.2f} s (the sweep with it minus "
              f"the sweep on a running Ray; {start_up / serial_run:.0f} serial runs' time)")
        print(f"    its parts: ray.init {median('init'):.2f} s, the workers' first tasks (imports) "
              f"{median('warm'):.2f} s, ray.shutdown {median('shutdown'):.2f} s")
        batched = base / statistics.median(times[f"signorini Batch, {args.threads} threads"])
        print(f"    per-task overhead {median('task') * 1e3:.2f} ms (no-op tasks); on a running Ray the sweep's runs "
              f"had {median('busy'):.0%} of the CPUs' time; steady state {steady:.2f}x serial (Batch {batched:.2f}x)")
        need = runs_for(1.6, start_up, serial_run, steady)
        if math.isinf(need):
            print("    1.6x including start-up: out of reach at any size (the steady state is below 1.6x)")
        else:
            print(f"    1.6x including start-up needs a sweep of at least {math.ceil(need / 1000) * 1000:,} runs "
                  f"of this scene ({args.runs:,} here)")
    cores = os.cpu_count() or 1
    mj = times.get(f"MuJoCo rollout, {args.threads} threads")
    if mj and mj[0] is not None:
        b = statistics.median(times[f"signorini Batch, {args.threads} threads"])
        print(f"  per core: Batch {args.runs / b / args.threads:.0f} runs/s, MuJoCo rollout "
              f"{args.runs / statistics.median(mj) / args.threads:.0f} runs/s ({cores} cores here)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
