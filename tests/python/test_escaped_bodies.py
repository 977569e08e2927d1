"""Bodies set moving past their reach within a step (issue 21, "Deep overlaps go";
docs/conventions.md, "Deep overlaps": escaped bodies).

A step detects its contacts once, as far as each body can travel in it at its velocity then
(its speculative reach). A body struck within the step by a faster one, or pulled by a joint,
can outrun that reach and meet a body the detection left out. From the PGS step's second
substep on, such a body (|p - p_0| plus its turn's reach above its reach) has its pairs that
carry no contact found at the substep's poses, new candidates included, for the rest of the
step; the oracle does the same with its own narrow phase."""
import numpy as np
import pytest

import signorini as sg
from signorini import compare, fuzz, oracle

RADIUS = 0.005
MASS = 0.01
SPEED = 6.0


def struck_row(**world):
    """Three 5 mm balls of 10 g on the x axis without gravity: a projectile at -3 cm moving at
    6 m/s, a ball at rest at 0 and another at rest at 2 cm. The projectile reaches the middle
    ball a third of the way into a step of 1/60 s; the middle ball, at rest when the step's
    contacts were found, then reaches the third within the same step."""
    w = sg.World(gravity=(0, 0, 0), sleeping=False, **world)
    p = w.add_body(sg.Sphere(RADIUS), mass=MASS, position=(-0.03, 0, 0), velocity=(SPEED, 0, 0))
    a = w.add_body(sg.Sphere(RADIUS), mass=MASS, position=(0.0, 0, 0))
    b = w.add_body(sg.Sphere(RADIUS), mass=MASS, position=(0.02, 0, 0))
    return w, (p, a, b)


@pytest.mark.parametrize("dt", [1 / 60, 1 / 240])
def test_a_ball_struck_within_the_step_pushes_the_next_without_passing_into_it(dt):
    # without restitution the three balls end together at the shared velocity of the momentum,
    # SPEED / 3 (closed form of a perfectly inelastic collision), each gap closed and none
    # overlapping past the PGS's tolerance (1e-6 m/s per substep over the step); momentum is
    # kept to rounding (the contacts are internal forces)
    w, (p, a, b) = struck_row()
    for _ in range(round(0.05 / dt)):
        w.step(dt)
        x = w.positions[:, 0]
        gaps = np.diff(x) - 2 * RADIUS
        assert gaps.min() > -1e-6 * w.step_report["steps"] * dt, gaps
        assert MASS * w.velocities[:, 0].sum() == pytest.approx(MASS * SPEED, rel=1e-12)
    v = w.velocities[:, 0]
    tolerance = 1e-6 * w.substep_count(dt)
    assert v == pytest.approx([SPEED / 3] * 3, abs=tolerance)


def test_without_the_escape_rule_the_struck_ball_passes_into_the_next(monkeypatch):
    # the oracle told of no escaped body (the middle ball's reach counted at the step's start
    # only): its pair with the third ball is found only at the next step, 2 cm deep (four
    # radii). With the rule the gap closes and stays closed
    snapshot = struck_row()[0].snapshot()
    dt = 1 / 60
    state, _ = oracle.step(snapshot, dt)
    x = np.asarray(state["position"])[:, 0]
    assert x[2] - x[1] - 2 * RADIUS > -1e-6
    monkeypatch.setitem(oracle.step.__globals__, "escaped_bodies", lambda detected, now, dt: None)
    state, _ = oracle.step(snapshot, dt)
    x = np.asarray(state["position"])[:, 0]
    assert x[2] - x[1] - 2 * RADIUS < -0.01


def struck_onto_floor():
    """The row stood on end over a floor plane, without gravity: a ball at rest 2 cm above the
    floor, struck from above at 6 m/s a third of the way into a step of 1/60 s."""
    w = sg.World(gravity=(0, 0, 0), sleeping=False)
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    a = w.add_body(sg.Sphere(RADIUS), mass=MASS, position=(0, 0, RADIUS + 0.02))
    p = w.add_body(sg.Sphere(RADIUS), mass=MASS, position=(0, 0, RADIUS + 0.05), velocity=(0, 0, -SPEED))
    return w, (a, p)


def test_a_ball_struck_towards_the_floor_within_the_step_stops_on_it_as_the_oracle_does(monkeypatch):
    # the floor plane is paired with every body, but the struck ball's pair had no point at the
    # step's start (2 cm away, at rest): it is found again as the ball escapes. Both balls end at
    # rest on the floor without sinking past the PGS's tolerance, and the oracle steps alike
    escapes = count_escapes(monkeypatch)
    w, (a, p) = struck_onto_floor()
    report = compare.lockstep(w, 1 / 60, 4)
    assert report.largest < 1e-10, "\n".join(report.lines())
    assert any(escapes)
    w, (a, p) = struck_onto_floor()
    for _ in range(6):
        w.step(1 / 60)
        z = w.positions[:, 2]
        assert z[a] - RADIUS > -1e-6 and z[p] - z[a] - 2 * RADIUS > -1e-6, z
    assert np.abs(w.velocities).max() < 1e-6 * w.substep_count(1 / 60)


def count_escapes(monkeypatch):
    """Counts, per substep, whether the oracle's PGS step found a body escaped."""
    escapes = []
    original = oracle.step.__globals__["escaped_bodies"]

    def counting(*args):
        out = original(*args)
        escapes.append(bool(np.any(out)))
        return out

    monkeypatch.setitem(oracle.step.__globals__, "escaped_bodies", counting)
    return escapes


def test_the_oracle_and_the_core_find_the_escaped_ball_s_pairs_alike(monkeypatch):
    # the oracle, handed the core's contacts at each step's start, finds the escaped ball's new
    # pair with its own narrow phase and steps alike to rounding (1e-10, as test_crosscheck)
    escapes = count_escapes(monkeypatch)
    w, _ = struck_row()
    report = compare.lockstep(w, 1 / 60, 6)
    assert report.largest < 1e-10, "\n".join(report.lines())
    assert report.contact_count_mismatches == 0
    assert sum(escapes) > 5  # substeps with an escaped body


def test_a_chain_struck_by_a_fast_box_keeps_its_links_apart_as_the_oracle_does(monkeypatch):
    # fuzzer scene 1:317: a 0.3 g box at 65 m/s strikes a hanging chain of 5 mm balls, whose
    # links, flung within the step, meet links and a hook the step's detection left out; core
    # and oracle alike to rounding (1e-10 relative: the links spin at up to 100 rad/s)
    escapes = count_escapes(monkeypatch)
    scene = fuzz.generate(1, 317)
    w, _ = fuzz.build(scene)
    report = compare.lockstep(w, scene["dt"], 4)
    spin = max(1.0, float(np.abs(w.angular_velocities).max()))
    assert report.largest < 1e-10 * spin, "\n".join(report.lines())
    assert report.contact_count_mismatches == 0
    assert any(escapes)


def test_fuzzer_scene_1_317_keeps_its_struck_links_under_half_their_inner_size():
    # a 0.3 g box shot at 65 m/s flings a hanging chain's links at 5 m/s within the first step;
    # two links 2 cm apart at the step's start met 4.5 mm deep (91 % of their inner size) when
    # the next step found them. The target is under 50 %
    result = fuzz.run(fuzz.generate(1, 317))
    assert not result["failures"], result["failures"]
    assert result["max_overlap"] < fuzz.DEEP_OVERLAP, result["overlap_at"]


@pytest.mark.parametrize("refuse", ["sensor", "filtered"])
def test_an_escaped_body_s_new_pair_keeps_the_pair_s_own_rules(refuse):
    # a sensor is never solved, and pairs whose collision is disabled never touch: the struck
    # ball passes through the third either way (and the projectile after it), the two sharing
    # the momentum, SPEED / 2 each
    w, (p, a, b) = struck_row()
    if refuse == "sensor":
        w.set_sensor(b, True)
    else:
        w.disable_collision(a, b)
        w.disable_collision(p, b)
    for _ in range(3):
        w.step(1 / 60)
    assert np.all(w.contacts.body_b != b) and np.all(w.contacts.body_a != b)
    v = w.velocities[:, 0]
    assert v[:2] == pytest.approx([SPEED / 2] * 2, abs=1e-6 * w.substep_count(1 / 60))
    assert v[2] == 0.0
