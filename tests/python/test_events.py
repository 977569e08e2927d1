"""World.events (issue 24, "Events"): the body pairs that began and ended touching in the last step
call, and the beginnings faster than hit_speed, as arrays in a deterministic order. Checked against
a bouncing ball's closed form, and for what must not change them: thread count, a call of several
steps against several calls, a restored state and a pickled world."""
import math
import pickle

import numpy as np
import pytest

import signorini as sg

G = 9.81

# the piles below are busy on purpose: a fast contact the PGS leaves unconverged warns, and that is
# not what these tests are about
pytestmark = pytest.mark.filterwarnings("ignore::signorini.SolverWarning")


def bouncing_ball(dt, restitution, height, solver="pgs"):
    w = sg.World(gravity=(0.0, 0.0, -G), solver=solver)
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    r = 0.1
    w.add_body(sg.Sphere(r), mass=1.0, position=(0.0, 0.0, r + height), restitution=restitution)
    return w


def collect(w, dt, steps):
    """Every event of `steps` single-step calls: {kind: [(call, step, body_a, body_b, speed, impulse)]}."""
    out = {"begin": [], "end": [], "hits": []}
    for k in range(steps):
        w.step(dt)
        e = w.events
        for kind in out:
            lst = getattr(e, kind)
            for i in range(len(lst)):
                out[kind].append((k, int(lst.step[i]), int(lst.body_a[i]), int(lst.body_b[i]), float(lst.speed[i]),
                                  float(lst.impulse[i])))
    return out


def test_a_bouncing_ball_gives_a_begin_and_an_end_per_bounce_at_the_analytic_impact_speeds():
    # dropped from h, it hits at v0 = sqrt(2 g h), then at e v0, e^2 v0, ... (each bounce returns
    # at the speed it left with). The speed reported is the approach at the start of the impact
    # step, which is below the true one by at most g dt; each earlier bounce's restitution carries
    # its own error on, so bounce i (from 0) is within (i + 1) g dt of e^i v0.
    dt, e, h = 1 / 1200, 0.8, 1.0
    w = bouncing_ball(dt, e, h)
    v0 = math.sqrt(2 * G * h)
    flight = 2 * v0 / G * (1 + e + e ** 2 + e ** 3 + e ** 4 + e ** 5) - v0 / G  # to the 6th impact
    events = collect(w, dt, int(flight / dt) - 10)  # five bounces, stopped before the sixth impact
    begins, ends = events["begin"], events["end"]
    assert len(begins) == 5 and len(ends) == 5
    for i in range(5):
        expected = v0 * e ** i
        speed = begins[i][4]
        assert speed == pytest.approx(expected, rel=0.01)
        assert expected - (i + 1) * G * dt <= speed <= expected + 1e-12
        assert (begins[i][2], begins[i][3]) == (0, 1)
        # it touches for one step: the impulse (1 + e) m u reverses it, u the approach once the
        # step's gravity is in (speed + g dt, mass 1), and the next step it flies
        assert ends[i][0] == begins[i][0] + 1
        assert begins[i][5] == pytest.approx((1 + e) * (speed + G * dt), rel=1e-9)
    # every beginning is a hit: all faster than the default 1 m/s
    assert w.hit_speed == 1.0
    assert [b[:4] for b in events["hits"]] == [b[:4] for b in begins]


def test_hits_are_the_beginnings_faster_than_hit_speed():
    dt, e = 1 / 600, 0.8
    w = bouncing_ball(dt, e, 1.0)
    w.hit_speed = 3.0  # the first two impacts (4.43, 3.54 m/s) only
    events = collect(w, dt, 1800)
    assert len(events["begin"]) > 3
    assert [h[4] for h in events["hits"]] == [b[4] for b in events["begin"] if b[4] > 3.0]
    assert len(events["hits"]) == 2


def test_a_body_at_rest_began_once_and_never_ends_asleep_or_awake():
    for sleeping in (False, True):
        w = sg.World(sleeping=sleeping)
        w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
        w.add_body(sg.Box((0.5, 0.5, 0.5)), mass=1.0, position=(0.0, 0.0, 0.5))
        events = collect(w, 1 / 60, 300)
        assert len(events["begin"]) == 1 and events["begin"][0][0] == 0
        assert events["end"] == []
        if sleeping:
            assert not w.awake[1]
        # a slow beginning (resting on the floor from the start) is no hit
        assert events["hits"] == []


def pile(threads, solver):
    w = sg.World(threads=threads, solver=solver, sleeping=False)
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    rng = np.random.default_rng(7)
    for k in range(40):
        p = (rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6), 0.4 + 0.45 * k)
        shape = sg.Box((0.2, 0.15, 0.1)) if k % 2 else sg.Sphere(0.12)
        w.add_body(shape, density=500.0, position=p, restitution=0.3)
    return w


def as_arrays(e):
    return {kind: {f: getattr(getattr(e, kind), f).copy() for f in ("step", "body_a", "body_b", "point", "normal",
                                                                       "speed", "impulse")}
            for kind in ("begin", "end", "hits")}


def same(a, b):
    for kind in a:
        for f in a[kind]:
            np.testing.assert_array_equal(a[kind][f], b[kind][f], err_msg=f"{kind}.{f}")


@pytest.mark.parametrize("solver", ["pgs", "soft"])
def test_events_are_the_same_bits_for_every_thread_count_and_sorted_by_pair(solver):
    one, two = pile(1, solver), pile(2, solver)
    seen = 0
    for _ in range(6):
        one.step(1 / 60, 20)
        two.step(1 / 60, 20)
        a, b = as_arrays(one.events), as_arrays(two.events)
        same(a, b)
        for kind in a:
            key = a[kind]["step"] * 10 ** 6 + a[kind]["body_a"] * 1000 + a[kind]["body_b"]
            assert np.all(np.diff(key) > 0)  # by step, then pair; a pair once per step and kind
            seen += len(key)
    assert seen > 40  # landings, bounces and partings


def test_a_call_of_several_steps_gives_the_events_of_as_many_calls():
    a, b = pile(1, "pgs"), pile(1, "pgs")
    a.step(1 / 60, 90)
    whole = as_arrays(a.events)
    parts = {kind: [] for kind in whole}
    for k in range(90):
        b.step(1 / 60)
        e = as_arrays(b.events)
        for kind in e:
            e[kind]["step"] = e[kind]["step"] + k
            parts[kind].append(e[kind])
    joined = {kind: {f: np.concatenate([p[f] for p in parts[kind]]) for f in whole[kind]} for kind in whole}
    same(whole, joined)
    assert len(whole["begin"]["step"]) >= 20  # the bodies landing, and on each other
    assert set(whole["begin"]["step"]) <= set(range(90))


def test_a_restored_state_and_a_pickled_world_go_on_giving_the_same_events():
    w = pile(1, "soft")
    w.step(1 / 60, 40)
    saved = w.save_state()
    copy = pickle.loads(pickle.dumps(w))
    w.step(1 / 60, 30)
    ahead = as_arrays(w.events)
    assert len(ahead["begin"]) + len(ahead["end"]) > 0
    w.restore_state(saved)
    w.step(1 / 60, 30)
    same(as_arrays(w.events), ahead)
    copy.step(1 / 60, 30)
    same(as_arrays(copy.events), ahead)


def test_removing_a_body_drops_its_pairs_and_renumbers_the_rest():
    w = sg.World(sleeping=False)
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    a = w.add_body(sg.Box((0.5, 0.5, 0.5)), mass=1.0, position=(-2.0, 0.0, 0.5))
    b = w.add_body(sg.Box((0.5, 0.5, 0.5)), mass=1.0, position=(2.0, 0.0, 0.5))
    w.step(1 / 60)
    assert sorted(w.events.begin.body_b.tolist()) == [a, b]
    w.remove_body(a)
    w.step(1 / 60, 10)
    # the box that stays (now body 1) kept touching: no end, no new beginning; the removed one's
    # pair left with it
    e = w.events
    assert len(e.begin) == 0 and len(e.end) == 0


def test_a_disabled_body_ends_its_pairs():
    w = sg.World(sleeping=False)
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    i = w.add_body(sg.Box((0.5, 0.5, 0.5)), mass=1.0, position=(0.0, 0.0, 0.5))
    w.step(1 / 60, 3)
    w.set_enabled(i, False)
    w.step(1 / 60)
    e = w.events
    assert (e.end.body_a.tolist(), e.end.body_b.tolist(), e.end.step.tolist()) == ([0], [i], [0])
    assert np.all(e.end.point == 0.0) and np.all(e.end.impulse == 0.0)


@pytest.mark.parametrize("bad", [float("nan"), -1.0, float("inf")])
def test_hit_speed_refuses_what_is_not_a_speed_and_keeps_its_value(bad):
    w = sg.World()
    w.hit_speed = 2.5
    with pytest.raises(ValueError, match="hit_speed"):
        w.hit_speed = bad
    assert w.hit_speed == 2.5
    with pytest.raises(TypeError, match="hit_speed"):
        w.hit_speed = None
    assert w.hit_speed == 2.5


def test_contact_pairs_sum_each_pairs_contacts_and_carry_the_weight_above():
    # a resting stack of three 2 kg boxes and a 1 kg ball: each pair's summed force on its upper
    # body is the weight of what rests on it (Newton), to what the PGS's velocity tolerance leaves:
    # tolerance * mass / dt of force
    dt = 1 / 240
    w = sg.World(sleeping=False)
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    for k in range(3):
        w.add_body(sg.Box((0.5, 0.5, 0.5)), mass=2.0, position=(0.0, 0.0, 0.5 + 1.0 * k))
    w.add_body(sg.Sphere(0.2), mass=1.0, position=(3.0, 0.0, 0.2))
    w.step(dt, 240)
    p = w.contact_pairs
    assert list(zip(p.body_a.tolist(), p.body_b.tolist())) == [(0, 1), (0, 4), (1, 2), (2, 3)]
    assert p.count.tolist() == [4, 1, 4, 4] and p.touching.all()
    slack = w.solver["tolerance"] * 7.0 / dt
    np.testing.assert_allclose(p.force[:, 2], [6 * G, 1 * G, 4 * G, 2 * G], rtol=0, atol=slack)
    assert np.abs(p.force[:, :2]).max() < slack
    c = w.contacts
    for k in range(len(p)):
        rows = slice(p.first[k], p.first[k] + p.count[k])
        # (summed in another order than numpy's sum: a rounding apart)
        np.testing.assert_allclose(p.force[k], c.force[rows].sum(axis=0), rtol=0, atol=1e-14 * np.abs(p.force).max())
        assert p.impulse[k] == pytest.approx(c.impulse[rows].sum(), rel=1e-15)
    empty = sg.World().contact_pairs
    assert len(empty) == 0 and empty.force.shape == (0, 3)


def falling_through_a_sensor(threads=1, solver="pgs"):
    """A 0.1 m ball dropped from 4 m through a static sensor box (half extent 0.5 m, centre at 2 m)
    onto the floor."""
    w = sg.World(gravity=(0.0, 0.0, -G), threads=threads, solver=solver, sleeping=False)
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    sensor = w.add_static(sg.Box((0.5, 0.5, 0.5)), position=(0.0, 0.0, 2.0), sensor=True)
    ball = w.add_body(sg.Sphere(0.1), mass=1.0, position=(0.0, 0.0, 4.0))
    return w, sensor, ball


@pytest.mark.parametrize("solver", ["pgs", "soft"])
def test_a_sensor_passed_by_a_ball_begins_and_ends_within_a_step_of_the_analytic_times(solver):
    # the ball overlaps the box while its centre is below 2.5 + 0.1 m and above 1.5 - 0.1 m: from
    # t1 = sqrt(2 (4 - 2.6) / g) to t2 = sqrt(2 (4 - 1.4) / g). Detection sees the step's start, so
    # the event belongs to the first step that starts past the crossing, as the integrator has the
    # ball there: its drop runs ahead of the exact one by less than g t dt (< one step's travel)
    dt = 1 / 240
    w, sensor, ball = falling_through_a_sensor(solver=solver)
    events = {"sensor_begin": [], "sensor_end": []}
    for k in range(int(0.8 / dt)):
        w.step(dt)
        e = w.events
        for kind in events:
            lst = getattr(e, kind)
            events[kind] += [(k, int(lst.body_a[i]), int(lst.body_b[i]), lst.normal[i].copy()) for i in range(len(lst))]
        # it passes through untouched: free fall, and no contact with the sensor is ever reported
        assert not np.any((w.contacts.body_a == sensor) | (w.contacts.body_b == sensor))
    assert w.velocities[ball][2] == pytest.approx(-G * int(0.8 / dt) * dt, rel=1e-12)
    (k1, s1, b1, n1), = events["sensor_begin"]
    (k2, s2, b2, _), = events["sensor_end"]
    assert (s1, b1) == (s2, b2) == (sensor, ball)
    t1, t2 = math.sqrt(2 * (4 - 2.6) / G), math.sqrt(2 * (4 - 1.4) / G)
    assert abs(k1 * dt - t1) < dt and abs(k2 * dt - t2) < dt
    np.testing.assert_allclose(n1, [0.0, 0.0, 1.0], atol=1e-12)  # from the sensor towards the ball
    assert len(w.events.begin) == 0 or all(w.events.begin.body_a != sensor)


def test_sensors_neither_collide_nor_sense_each_other_and_keep_a_sleeping_visitor():
    w = sg.World(gravity=(0.0, 0.0, -G), sleeping=True)
    floor = w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    zone = w.add_static(sg.Box((1.0, 1.0, 0.5)), position=(0.0, 0.0, 0.5), sensor=True)
    box = w.add_body(sg.Box((0.2, 0.2, 0.2)), mass=1.0, position=(0.0, 0.0, 0.2))
    # a moving sensor inside the zone: the two never sense each other; it falls through the floor
    probe = w.add_body(sg.Sphere(0.1), mass=1.0, position=(0.5, 0.0, 0.6), sensor=True)
    assert w.is_sensor.tolist() == [False, True, False, True]
    w.step(1 / 60)
    assert w.events.sensor_begin.body_a.tolist() == [zone] and w.events.sensor_begin.body_b.tolist() == [box]
    w.step(1 / 60, 240)  # the box falls asleep in the zone; the probe passes through the floor
    assert not w.awake[box]
    e = w.events
    # the floor is a half-space: once in it, the probe stays in it
    assert e.sensor_begin.body_a.tolist() == [probe] and e.sensor_begin.body_b.tolist() == [floor]
    assert len(e.sensor_end) == 0
    assert w.positions[probe][2] < -1.0
    # a sensor made a body again collides: the box rests on it from then on
    w.set_sensor(zone, False)
    w.step(1 / 60)
    assert w.events.sensor_end.body_b.tolist() == [box]
    assert np.any((w.contacts.body_a == zone) & (w.contacts.body_b == box))


def test_sensor_events_are_the_same_for_every_thread_count_and_after_a_restore_or_a_pickle():
    import pickle
    def run(w, steps):
        out = []
        for _ in range(steps):
            w.step(1 / 240)
            e = w.events
            out.append((e.sensor_begin.body_b.tolist(), e.sensor_end.body_b.tolist()))
        return out
    one, sensor, ball = falling_through_a_sensor(threads=1)
    two, _, _ = falling_through_a_sensor(threads=2)
    assert run(one, 140) == run(two, 140)  # the ball is inside the sensor now
    saved = one.save_state()
    copy = pickle.loads(pickle.dumps(one))
    ahead = run(one, 60)
    assert ([ball] not in [b for b, _ in ahead]) and any(e == [ball] for _, e in ahead)  # it ends, not begins
    one.restore_state(saved)
    assert run(one, 60) == ahead
    assert run(copy, 60) == ahead


def test_a_scene_file_keeps_a_sensor(tmp_path):
    w, sensor, ball = falling_through_a_sensor()
    w.save_scene(tmp_path / "sensor.toml")
    again = sg.load_scene(tmp_path / "sensor.toml")
    assert again.is_sensor.tolist() == w.is_sensor.tolist() == [False, True, False]


def test_the_oracle_leaves_a_sensor_out_as_the_core_does():
    # the oracle (never the core) finds the same contacts with a sensor in the world: none of it,
    # and steps the same states to 1e-10
    from signorini import compare, oracle
    w = sg.World(sleeping=False, solver="pgs")
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    w.add_static(sg.Box((0.5, 0.5, 0.5)), position=(0.0, 0.0, 0.4), sensor=True)
    for k in range(3):
        w.add_body(sg.Box((0.1, 0.1, 0.1)), mass=1.0, position=(0.3 * k - 0.3, 0.0, 0.1))
    w.step(1 / 240, 10)
    found = oracle.detect_contacts(w.snapshot(), 1 / 240)
    assert not np.any((np.asarray(found["body_a"]) == 1) | (np.asarray(found["body_b"]) == 1))
    report = compare.lockstep(w, 1 / 240, 5)
    assert report.largest < 1e-10, "\n".join(report.lines())


@pytest.mark.parametrize("solver", ["pgs", "soft"])
def test_events_are_the_changes_of_the_touching_pairs_the_contacts_show(solver):
    # the core reads compact copies of the contacts' touching flags (store's, summed over the
    # substeps); the pairs the reported contacts show touching (contact_pairs, from the records)
    # must change exactly by the events, step after step, substeps (dt 1/60) and sleep included
    w = pile(1, solver)
    w.set_sleep(sleeping=True)
    before = set()
    seen = 0
    for _ in range(240):
        w.step(1 / 60)
        p = w.contact_pairs
        now = {(int(a), int(b)) for a, b, t in zip(p.body_a, p.body_b, p.touching) if t}
        e = w.events
        began = set(zip(e.begin.body_a.tolist(), e.begin.body_b.tolist()))
        ended = set(zip(e.end.body_a.tolist(), e.end.body_b.tolist()))
        assert began == now - before and ended == before - now
        seen += len(began) + len(ended)
        before = now
    assert seen > 40
