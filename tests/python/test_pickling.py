"""Pickling never aborts the process: every class of the compiled core pickles at every protocol
(0 to 5, and a direct ``__reduce__()``) to an equal object, or refuses with a TypeError; the World
facade, saved states and shapes round-trip at every protocol and step on bit for bit.

Protocols 0 and 1 used to abort the interpreter (pybind11: "instance allocation failed"), so each
case runs in a child process: a crash fails the test instead of killing the run."""
import subprocess
import sys
import textwrap

import pytest

import signorini as sg
from signorini import _core

PICKLED = ("Sphere", "Box", "Plane", "Mesh", "Capsule", "Cylinder", "ConvexHull", "TriangleMesh", "Compound",
           "SolverSettings", "SleepSettings", "FrictionCone", "Gyroscopic", "SolverMethod")
REFUSED = ("World", "BatchStepper")  # the facade signorini.World pickles; its core object does not

SAMPLES = """
import pickle, numpy as np, signorini as sg
from signorini import _core, meshes
v, f = meshes.torus(0.3, 0.1)
settings = _core.SolverSettings()
settings.max_iterations, settings.substeps, settings.friction_cone = 7, 3, _core.FrictionCone.cone
settings.method, settings.contact_hertz, settings.relax_iterations = _core.SolverMethod.soft, 45.0, 2
sleep = _core.SleepSettings()
sleep.enabled, sleep.linear_velocity, sleep.time_to_sleep = True, 0.02, 1.5
samples = {
    "Sphere": sg.Sphere(0.5), "Box": sg.Box((1.0, 2.0, 3.0)), "Plane": sg.Plane((0.0, 0.6, 0.8), 0.5),
    "Mesh": sg.Mesh(*meshes.box_mesh((1.0, 1.0, 1.0))), "Capsule": sg.Capsule(0.1, 0.2),
    "Cylinder": sg.Cylinder(0.1, 0.3),
    "ConvexHull": sg.ConvexHull(np.random.default_rng(0).normal(size=(20, 3))),
    "TriangleMesh": sg.TriangleMesh(v, f),
    "Compound": sg.Compound([(sg.Sphere(0.1), ((0.0, 0.0, 0.1), (1.0, 0.0, 0.0, 0.0))), (sg.Box((0.1, 0.2, 0.3)), ((0.0, 0.0, -0.1), (0.0, 1.0, 0.0, 0.0)))]),
    "SolverSettings": settings, "FrictionCone": _core.FrictionCone.cone, "Gyroscopic": _core.Gyroscopic.implicit,
    "SolverMethod": _core.SolverMethod.soft, "SleepSettings": sleep,
    "World": _core.World((0.0, 0.0, -9.81), 0.005, _core.SolverSettings()),
    "BatchStepper": _core.BatchStepper(1),
}
"""


def run_child(code: str) -> str:
    done = subprocess.run([sys.executable, "-c", SAMPLES + textwrap.dedent(code)], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, f"the child process failed ({done.returncode}): {done.stderr[-2000:]}"
    return done.stdout


def test_every_core_class_is_listed_here():
    classes = {n for n, x in vars(_core).items() if isinstance(x, type) and type(x).__name__ == "pybind11_type"}
    assert classes == set(PICKLED) | set(REFUSED)


@pytest.mark.parametrize("name", PICKLED)
def test_core_class_round_trips_at_every_protocol(name):
    out = run_child(f"""
        x = samples[{name!r}]
        reference = pickle.dumps(x, protocol=5)
        for protocol in range(6):
            y = pickle.loads(pickle.dumps(x, protocol=protocol))
            assert type(y) is type(x)
            assert pickle.dumps(y, protocol=5) == reference, protocol
        cls, args, state = x.__reduce__()
        assert pickle.dumps(cls(*args).__class__) == pickle.dumps(type(x))
        print("ok")
    """)
    assert out.strip() == "ok"


def test_solver_settings_keep_every_field():
    out = run_child("""
        y = pickle.loads(pickle.dumps(settings, protocol=0))
        print(y.max_iterations, y.substeps, y.friction_cone == _core.FrictionCone.cone, y.erp == settings.erp)
    """)
    assert out.split() == ["7", "3", "True", "True"]


def test_solver_settings_pickled_before_the_joint_softness_settings_keep_their_60_hz_joints():
    # a pickle of 18 items (before joint_hertz and joint_damping_ratio) steps as it did: the soft
    # step's joints were springs of 60 Hz and damping ratio 2 then
    out = run_child("""
        settings.joint_hertz, settings.joint_damping_ratio = 90.0, 0.5
        cls, args, state = settings.__reduce__()
        assert len(state) == 20 and state[18:] == (90.0, 0.5)
        old = cls(*args)
        old.__setstate__(state[:18])
        print(old.joint_hertz, old.joint_damping_ratio, old.relax_iterations, old.continuous == settings.continuous)
    """)
    assert out.split() == ["60.0", "2.0", "2", "True"]


@pytest.mark.parametrize("name", REFUSED)
def test_core_class_without_pickling_refuses_at_every_protocol(name):
    out = run_child(f"""
        for protocol in range(6):
            try:
                pickle.dumps(samples[{name!r}], protocol=protocol)
            except TypeError as e:
                message = str(e)
            else:
                raise SystemExit("pickled at protocol %d" % protocol)
        try:
            samples[{name!r}].__reduce__()
        except TypeError:
            print(message)
    """)
    assert f"cannot pickle a signorini._core.{name}" in out
    assert ("signorini.World" if name == "World" else "signorini.Batch") in out


def test_world_and_saved_state_round_trip_at_every_protocol_and_step_on_bit_for_bit():
    out = run_child("""
        w = sg.World()
        w.add_static(sg.Plane((0.0, 0.0, 1.0), 0.0))
        w.add_body(samples["Compound"], mass=1.0, position=(0.0, 0.0, 0.5), angular_velocity=(1.0, 2.0, 0.0))
        w.add_body(samples["ConvexHull"], density=100.0, position=(3.0, 0.0, 2.0))
        w.step(1 / 240, 20)
        s = w.save_state()
        reference = pickle.loads(pickle.dumps(w, protocol=5))
        reference.step(1 / 240, 30)
        for protocol in range(6):
            u = pickle.loads(pickle.dumps(w, protocol=protocol))
            u.step(1 / 240, 30)
            assert np.array_equal(u.positions, reference.positions), protocol
            assert np.array_equal(u.velocities, reference.velocities), protocol
            w2 = pickle.loads(pickle.dumps(w, protocol=5))
            w2.restore_state(pickle.loads(pickle.dumps(s, protocol=protocol)))
            w2.step(1 / 240, 30)
            assert np.array_equal(w2.positions, reference.positions), protocol
        print("ok")
    """)
    assert out.strip() == "ok"
