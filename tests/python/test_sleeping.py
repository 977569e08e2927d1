"""Islands and sleeping (docs/conventions.md, "Sleeping"), through the Python API: a resting body
falls asleep at the step its timer passes ``time_to_sleep`` and keeps its pose bit for bit; a touch
wakes exactly the touched island; every waking call wakes; ``set_awake`` and ``can_sleep``; saved
states and pickles continue bit for bit; bad settings raise naming the setting; both solvers."""
import pickle
from pathlib import Path

import numpy as np
import pytest

import signorini as sg

DT = 1 / 240
SOLVERS = ("pgs", "soft")


def cube_stacks(solver="pgs", xs=(0.0,), height=2, **kw):
    """A plane and, at each x, a stack of `height` 0.2 m cubes resting on it (their faces touching)."""
    w = sg.World(sleeping=True, solver=solver, **kw)
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    for x in xs:
        for level in range(height):
            w.add_body(sg.Box((0.1, 0.1, 0.1)), density=1000.0, position=(x, 0.0, 0.1 + 0.2 * level))
    return w


def sleep_step(dt: float, time_to_sleep: float) -> int:
    """The step after which a body at rest from the first step sleeps: its timer, the steps' dt
    summed in floating point as the world sums them, is then > 0 and >= time_to_sleep."""
    t, k = 0.0, 0
    while not (t > 0.0 and t >= time_to_sleep):
        t, k = t + dt, k + 1
    return k


def pose_bytes(w, i):
    return w.positions[i].tobytes() + w.rotations[i].tobytes() + w.orientations[i].tobytes()


def step_until_awake(w, i, steps=120):
    """Steps w until body i is awake, at most `steps` steps (the caller asserts what woke)."""
    for _ in range(steps):
        w.step(DT)
        if w.awake[i]:
            return


@pytest.mark.parametrize("solver", SOLVERS)
@pytest.mark.parametrize("dt, time_to_sleep", [(DT, 0.5), (1 / 60, 0.25)])
def test_a_box_at_rest_sleeps_at_the_closed_form_step_and_keeps_its_pose_bit_for_bit(solver, dt, time_to_sleep):
    w = cube_stacks(solver, height=1, time_to_sleep=time_to_sleep)
    k_sleep = sleep_step(dt, time_to_sleep)
    t = 0.0
    for k in range(1, k_sleep):
        w.step(dt)
        t += dt
        assert w.awake[1], k
        assert w.sleep_times[1] == t, k  # below the thresholds from the first step
    w.step(dt)
    assert not w.awake[1]
    assert not w.velocities[1].any() and not w.angular_velocities[1].any()
    before, energy = pose_bytes(w, 1), (w.kinetic_energy(), w.potential_energy())
    contacts, forces = w.contacts.as_dict(), w.contact_forces
    weight = 1000.0 * 0.2**3 * 9.81
    assert len(w.contacts) == 4 and abs(forces[1][2] - weight) < 1e-3 * weight
    w.step(dt, 1000)
    assert pose_bytes(w, 1) == before
    assert (w.kinetic_energy(), w.potential_energy()) == (0.0, energy[1])
    assert len(w.detect_contacts(dt)) == 0  # a sleeping pair is not even detected
    # its contacts and forces are reported as they were when it fell asleep, bit for bit
    assert all(np.array_equal(v, contacts[k]) for k, v in w.contacts.as_dict().items())
    assert np.array_equal(w.contact_forces[1], forces[1])
    assert np.allclose(w.contact_forces[0], -forces[1], rtol=0, atol=1e-12 * weight)  # the ground's reaction


def test_the_awake_view_is_read_only_shared_and_false_for_static_bodies():
    w = cube_stacks(height=1)
    view = w.awake
    assert view.dtype == np.bool_ and view.shape == (2,)
    assert view.tolist() == [False, True]
    with pytest.raises(ValueError):
        view[1] = False
    w.step(DT, 200)
    assert view.tolist() == [False, False]  # the view shows the step
    assert np.shares_memory(view, w.awake)


@pytest.mark.parametrize("solver", SOLVERS)
def test_a_ball_dropped_on_one_stack_wakes_that_island_only(solver):
    w = cube_stacks(solver, xs=(0.0, 1.0))  # bodies 1, 2 and 3, 4: two islands on one plane
    w.step(DT, 240)
    assert not w.awake[1:].any()
    far = pose_bytes(w, 3) + pose_bytes(w, 4)
    ball = w.add_body(sg.Sphere(0.05), density=1000.0, position=(0.0, 0.0, 0.6))
    step_until_awake(w, 1)
    assert w.awake[[1, 2, ball]].all()
    assert not w.awake[[3, 4]].any()
    assert pose_bytes(w, 3) + pose_bytes(w, 4) == far
    # the ball rests on the woken stack, and the three sleep together later
    w.step(DT, 600)
    assert not w.awake[[1, 2, ball]].any()
    assert w.positions[ball][2] > 0.4


WAKING_CALLS = {
    "apply_impulse": lambda w: w.apply_impulse(2, (0.0, 0.0, 0.01)),
    "apply_force": lambda w: w.apply_force(2, (0.0, 0.0, 0.01)),
    "set_external_wrench": lambda w: w.set_external_wrench(2, (0.0, 0.0, 0.01)),
    "set_position": lambda w: w.set_position(2, w.positions[2]),
    "set_orientation": lambda w: w.set_orientation(2, w.orientations[2]),
    "set_velocity": lambda w: w.set_velocity(2, (0.0, 0.0, 0.0)),
    "set_angular_velocity": lambda w: w.set_angular_velocity(2, (0.0, 0.0, 0.0)),
    "set_positions": lambda w: w.set_positions([2], [w.positions[2]]),
    "set_orientations": lambda w: w.set_orientations([2], [w.orientations[2]]),
    "set_velocities": lambda w: w.set_velocities([2], [(0.0, 0.0, 0.0)]),
    "set_angular_velocities": lambda w: w.set_angular_velocities([2], [(0.0, 0.0, 0.0)]),
    "set_material": lambda w: w.set_material(2, friction=0.1),
    "set_enabled": lambda w: w.set_enabled(2, True),
    "set_kinematic": lambda w: w.set_kinematic(2, True),
    "set_collision_filter": lambda w: w.set_collision_filter(2, 1),
    "disable_collision": lambda w: w.disable_collision(1, 2),
    "set_awake": lambda w: w.set_awake(2, True),
    "set_can_sleep": lambda w: w.set_can_sleep(2, False),
    "set_sleep(sleeping=False)": lambda w: w.set_sleep(sleeping=False),
    "remove_body(the ground)": lambda w: w.remove_body(0),
    "set_position(the ground)": lambda w: w.set_position(0, (0.0, 0.0, -0.1)),
    "set_material(the ground)": lambda w: w.set_material(0, friction=0.1),
}


@pytest.mark.parametrize("call", WAKING_CALLS)
def test_every_waking_call_wakes_the_island(call):
    w = cube_stacks()
    w.step(DT, 240)
    assert not w.awake[1:].any()
    WAKING_CALLS[call](w)
    lower = 0 if w.num_bodies == 2 else 1  # the ground removed: the stack is bodies 0 and 1
    assert w.awake[lower] and w.awake[lower + 1], call
    assert not w.sleep_times[lower:].any()


def test_a_moving_kinematic_body_wakes_what_it_touches_and_a_still_one_does_not():
    w = cube_stacks(height=1)
    paddle = w.add_body(sg.Box((0.05, 0.2, 0.05)), kinematic=True, position=(0.3, 0.0, 0.1))
    w.step(DT, 200)
    assert not w.awake[1] and w.awake[paddle]
    w.set_velocity(paddle, (-0.5, 0.0, 0.0))  # reaches the cube after about 0.1 s
    step_until_awake(w, 1)
    assert w.awake[1]
    w.step(DT, 60)
    assert w.positions[1][0] < -0.01  # pushed
    # a cube asleep on a still kinematic platform wakes when the platform is set moving
    lift = w.add_body(sg.Box((0.3, 0.3, 0.05)), kinematic=True, position=(3.0, 0.0, 0.05))
    rider = w.add_body(sg.Box((0.1, 0.1, 0.1)), density=1000.0, position=(3.0, 0.0, 0.2))
    w.step(DT, 240)
    assert not w.awake[rider]
    w.set_velocity(lift, (0.0, 0.0, 0.1))
    assert w.awake[rider]
    w.step(DT, 60)
    assert w.positions[rider][2] > 0.2 + 0.02  # carried up


@pytest.mark.parametrize("solver", SOLVERS)
def test_set_awake_false_sleeps_the_island_now_and_can_sleep_false_never_sleeps(solver):
    w = cube_stacks(solver, xs=(0.0,))
    lone = w.add_body(sg.Box((0.1, 0.1, 0.1)), density=1000.0, position=(1.0, 0.0, 0.1), can_sleep=False)
    w.step(DT)
    assert w.awake[1:].all()
    w.set_awake(2, False)
    assert not w.awake[1] and not w.awake[2] and w.awake[lone]
    assert not w.velocities[1:3].any() and not w.angular_velocities[1:3].any()
    with pytest.raises(ValueError, match=r"body 3 \(Box\).*can_sleep"):
        w.set_awake(lone, False)
    assert w.awake[lone]
    with pytest.raises(ValueError, match=r"body 0 \(Plane\): a static body"):
        w.set_awake(0, True)
    w.step(DT, 600)
    assert w.awake[lone] and not w.can_sleep[lone] and w.can_sleep[1]
    # a body on top of one that cannot sleep stays awake with it (one island)
    top = w.add_body(sg.Box((0.1, 0.1, 0.1)), density=1000.0, position=(1.0, 0.0, 0.3))
    w.step(DT, 600)
    assert w.awake[top]
    w.set_can_sleep(lone, True)
    w.step(DT, 200)
    assert not w.awake[[lone, top]].any()


def test_sleeping_off_never_sleeps_and_set_awake_false_says_so():
    w = cube_stacks()
    w.set_sleep(sleeping=False)
    w.step(DT, 400)
    assert w.awake[1:].all() and not w.sleep_times.any()
    with pytest.raises(ValueError, match="sleeping is switched off"):
        w.set_awake(1, False)


@pytest.mark.filterwarnings("ignore::signorini.SolverWarning")
def test_sleeping_changes_nothing_before_a_body_sleeps_and_is_deterministic():
    """Same scene, same settings: bit-identical; and with sleeping on, identical to sleeping off
    until the first body sleeps (timers and islands only decide when to sleep)."""
    def run(sleeping, steps):
        w = sg.World(sleeping=sleeping)
        w.add_static(sg.Plane((0, 0, 1), 0.0))
        rng = np.random.default_rng(5)
        for k in range(12):
            w.add_body(sg.Box((0.1, 0.1, 0.1)), density=500.0, position=(0.21 * (k % 4), 0.0, 0.3 + 0.25 * (k // 4)),
                       orientation=(1.0, *rng.uniform(-0.2, 0.2, size=3)))
        out = []
        for _ in range(steps):
            w.step(DT)
            out.append(w.positions.tobytes() + w.velocities.tobytes() + w.awake.tobytes())
        return w, out
    on, a = run(True, 700)
    _, b = run(True, 700)
    assert a == b
    _, off = run(False, 700)
    first = next(k for k, x in enumerate(a) if x != off[k])
    assert first > 0
    assert not np.frombuffer(a[first][-13:], dtype=bool)[1:].all()  # the first difference: a body sleeps
    assert not on.awake[1:].any()  # the pile has settled and sleeps


def rain_on_a_sleeping_stack(solver):
    w = cube_stacks(solver)
    w.add_body(sg.Sphere(0.05), density=1000.0, position=(0.02, 0.0, 3.0))  # lands after the stack sleeps
    return w


@pytest.mark.parametrize("solver", SOLVERS)
def test_a_saved_state_and_a_pickle_mid_sleep_step_on_bit_for_bit(solver):
    w = rain_on_a_sleeping_stack(solver)
    w.step(DT, 150)
    assert not w.awake[1] and w.awake[3] and w.sleep_times[3] == 0.0
    saved, pickled = w.save_state(), pickle.dumps(w)
    trace = []
    for _ in range(400):
        w.step(DT)
        trace.append(w.awake[1])
    assert any(trace)  # the ball lands and wakes the stack after the save
    restored = rain_on_a_sleeping_stack(solver)
    restored.restore_state(saved)
    unpickled = pickle.loads(pickled)
    assert unpickled.sleep == w.sleep
    for other in (restored, unpickled):
        other.step(DT, 400)
        assert other.save_state().data == w.save_state().data
        assert other.awake.tolist() == w.awake.tolist()


def test_a_state_saved_before_sleeping_loads_as_all_awake():
    old = np.load(Path(__file__).parent / "data" / "saved_state_format1.npz")
    w = sg.World(sleeping=True)
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    w.add_body(sg.Box((0.2, 0.15, 0.1)), density=500.0, position=(0, 0, 0.1), angular_velocity=(0, 0, 2.0))
    w.add_body(sg.Sphere(0.1), mass=1.0, position=(1.0, 0, 0.1), velocity=(0.3, 0, 0), angular_velocity=(0, 0, 5.0))
    w.set_awake(1, False)
    w.restore_state(sg.SavedState(old["state"].tobytes(), 3, 30 / 240))
    assert w.awake.tolist() == [False, True, True] and not w.sleep_times.any()


@pytest.mark.parametrize("key", ["sleep_linear_velocity", "sleep_angular_velocity", "time_to_sleep"])
@pytest.mark.parametrize("bad", [-0.1, float("nan"), float("inf")])
def test_bad_sleep_thresholds_raise_naming_the_setting_and_change_nothing(key, bad):
    with pytest.raises(ValueError, match=key):
        sg.World(**{key: bad})
    w = cube_stacks()
    w.step(DT, 10)
    before, state = w.sleep, w.save_state()
    with pytest.raises(ValueError, match=key):
        w.set_sleep(**{key: bad})
    assert w.sleep == before and w.save_state().data == state.data


def test_sleep_settings_of_the_wrong_type_raise_naming_them():
    with pytest.raises(TypeError, match="sleeping"):
        sg.World(sleeping="yes")
    with pytest.raises(TypeError, match="time_to_sleep"):
        sg.World(time_to_sleep="1")
    with pytest.raises(TypeError, match="unknown setting"):
        sg.World().set_sleep(sleep_time=1.0)
    with pytest.raises(TypeError, match="can_sleep"):
        sg.World().add_body(sg.Sphere(0.1), mass=1.0, can_sleep=1)


def test_a_scene_file_keeps_the_sleep_settings_and_can_sleep(tmp_path):
    w = cube_stacks(time_to_sleep=0.25, sleep_linear_velocity=0.02)
    w.set_can_sleep(2, False)
    path = w.save_scene(tmp_path / "stack.toml")
    loaded = sg.load_scene(path)
    loaded = loaded.world if hasattr(loaded, "world") else loaded
    assert loaded.sleep == w.sleep == {"sleeping": True, "sleep_linear_velocity": 0.02,
                                       "sleep_angular_velocity": 0.05, "time_to_sleep": 0.25}
    assert loaded.can_sleep.tolist() == [True, True, False]


def busy_sleeping_pile(solver):
    """20 boxes and spheres dropped in two waves onto a plane and a static box, sleeping on: islands
    fall asleep, are woken by the second wave, merge, and sleep again."""
    w = sg.World(sleeping=True, solver=solver, time_to_sleep=0.2)
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    w.add_static(sg.Box((0.3, 0.3, 0.1)), position=(0.6, 0.0, 0.1))
    rng = np.random.default_rng(21)
    for k in range(20):
        shape = sg.Box((0.06, 0.05, 0.04)) if k % 2 else sg.Sphere(0.05)
        x, y = rng.uniform(-0.4, 0.9), rng.uniform(-0.3, 0.3)
        z = 0.3 + 0.15 * (k % 10) + (4.0 if k >= 10 else 0.0)
        w.add_body(shape, density=800.0, position=(x, y, z), orientation=(1.0, *rng.uniform(-0.3, 0.3, size=3)),
                   friction=0.8)
    return w


def trace_of(w, steps, kick_at=()):
    """Per step, the bytes of everything a user reads (poses, velocities, awake flags, contacts and
    contact forces), and the awake flags (steps x N); body 5 is kicked at the steps kick_at."""
    out, flags = [], []
    for k in range(steps):
        if k in kick_at:
            w.apply_impulse(5, (0.0, 0.02, 0.05))
        w.step(DT)
        c = w.contacts
        out.append(w.positions.tobytes() + w.velocities.tobytes() + w.awake.tobytes() + c.alpha.tobytes()
                   + c.body_a.tobytes() + c.body_b.tobytes() + w.contact_forces.tobytes())
        flags.append(w.awake.copy())
    return out, np.array(flags)


@pytest.mark.filterwarnings("ignore::signorini.SolverWarning")
@pytest.mark.parametrize("solver", SOLVERS)
def test_a_busy_pile_that_sleeps_wakes_and_sleeps_again_continues_bit_for_bit_from_a_save(solver):
    w = busy_sleeping_pile(solver)
    first, _ = trace_of(w, 200)
    saved, pickled = w.save_state(), pickle.dumps(w)
    rest, flags = trace_of(w, 1000, kick_at=(350,))
    # after the save, bodies fall asleep and islands are woken (by the second wave and the kick)
    dynamic = flags[:, 2:]
    wake_steps = (~dynamic[:-1] & dynamic[1:]).any(axis=1).sum()
    sleep_steps = (dynamic[:-1] & ~dynamic[1:]).any(axis=1).sum()
    assert wake_steps >= 3 and sleep_steps >= 3, (wake_steps, sleep_steps)
    restored = busy_sleeping_pile(solver)
    restored.restore_state(saved)
    assert trace_of(restored, 1000, kick_at=(350,))[0] == rest
    assert trace_of(pickle.loads(pickled), 1000, kick_at=(350,))[0] == rest
    assert trace_of(busy_sleeping_pile(solver), 200)[0] == first  # and the same scene runs the same


def test_a_refused_step_that_woke_an_island_leaves_it_asleep_as_before():
    w = cube_stacks()
    w.step(DT, 240)
    ball = w.add_body(sg.Sphere(0.05), density=1000.0, position=(0.0, 0.0, 0.451))  # just above the top cube
    before = w.save_state()
    w.set_external_wrench(ball, force=(1e308, 0.0, 0.0))
    with pytest.raises(RuntimeError, match=r"state became non-finite.*undone"):
        w.step(1e10)  # detects the ball on the stack (which wakes it), then overflows
    assert not w.awake[1:3].any()
    w.set_external_wrench(ball, force=(0.0, 0.0, 0.0))
    assert w.save_state().data == before.data
    # and it then goes on as if the refused step had never been tried
    w.step(DT)
    assert w.awake[1:3].all()


def test_a_sleeping_state_restored_into_a_world_with_sleeping_off_wakes():
    w = cube_stacks()
    w.step(DT, 240)
    saved = w.save_state()
    off = cube_stacks()
    off.set_sleep(sleeping=False)
    off.restore_state(saved)
    assert off.awake[1:].all()
    assert len(off.warm_start_cache["alpha"]) == len(w.contacts)  # the kept forces are back in the cache


def test_removing_a_body_wakes_its_island_and_the_other_islands_keep_sleeping_renumbered():
    w = cube_stacks(xs=(0.0, 1.0, 2.0))  # stacks 1-2, 3-4, 5-6
    w.step(DT, 240)
    assert not w.awake[1:].any()
    w.remove_bodies([1, 4])  # the bottom of the first stack, the top of the second
    # now: 1 (the first stack's top, woken), 2 (the second's bottom, woken), 3-4 (asleep)
    assert w.awake[[1, 2]].all() and not w.awake[[3, 4]].any()
    far = pose_bytes(w, 3) + pose_bytes(w, 4)
    w.step(DT, 60)
    assert w.positions[1][2] < 0.2  # it fell onto the ground
    assert pose_bytes(w, 3) + pose_bytes(w, 4) == far
    # the third stack's label was renumbered: a touch still wakes it whole, and only it
    ball = w.add_body(sg.Sphere(0.05), density=1000.0, position=(2.0, 0.0, 0.5))
    step_until_awake(w, 3)
    assert w.awake[[3, 4, ball]].all()
    # and a world rebuilt from its saved state steps on the same
    saved, trace = w.save_state(), []
    for _ in range(200):
        w.step(DT)
        trace.append(w.positions.tobytes() + w.awake.tobytes())
    other = pickle.loads(pickle.dumps(w))
    other.restore_state(saved)
    again = []
    for _ in range(200):
        other.step(DT)
        again.append(other.positions.tobytes() + other.awake.tobytes())
    assert again == trace


def test_a_jointed_pair_asleep_drops_the_joints_substeps_and_takes_them_again_when_it_wakes():
    # the soft step's joints ask for substeps of 0.25 / joint_hertz (1/960 s) while a body of theirs
    # moves; a joint links its bodies' island, so asleep they sleep together and the step keeps only
    # the contacts' substeps (1/240 s), and waking the island brings the joints' back
    dt = 1 / 60
    w = cube_stacks("soft", height=1, time_to_sleep=0.25)
    w.add_body(sg.Box((0.1, 0.1, 0.1)), density=1000.0, position=(0.2, 0.0, 0.1))
    w.add_joint(sg.Spherical(1, 2, anchor=(0.1, 0.0, 0.1)))
    joints_n, contacts_n = round(4 * 240.0 * dt), round(240 * dt)
    assert w.substep_count(dt) == joints_n
    for _ in range(sleep_step(dt, 0.25) + 60):
        w.step(dt)
        if not w.awake[1]:
            break
    assert not w.awake[1] and not w.awake[2]  # asleep together
    assert w.substep_count(dt) == contacts_n
    before = pose_bytes(w, 1) + pose_bytes(w, 2)
    w.step(dt, 30)
    assert pose_bytes(w, 1) + pose_bytes(w, 2) == before
    w.set_awake(2, True)
    assert w.awake[1] and w.substep_count(dt) == joints_n
    w.set_joint_broken(0)  # a broken joint asks for none, awake or not
    assert w.substep_count(dt) == contacts_n
