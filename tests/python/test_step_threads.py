"""The step's worker threads (``World(threads=N)``, README "Threads"): every thread count gives the
bits of one thread, because work is only split over items that share no data (the contacts of one
solve colour share no moving body); bad counts are refused and leave the world as it was."""
import pickle

import numpy as np
import pytest

import signorini as sg


def grid(threads, solver, n=18):
    """An n x n grid of slightly tilted boxes landing on a plane, a second box on every third one:
    the largest colours hold more contacts than one task takes (256), so they are split."""
    w = sg.World(solver=solver, threads=threads, max_iterations=6)
    w.add_static(sg.Plane((0.0, 0.0, 1.0), 0.0))
    for i in range(n):
        for j in range(n):
            q = (1.0, 0.01 * (i % 3), 0.01 * (j % 2), 0.0)
            w.add_body(sg.Box((0.1, 0.1, 0.1)), density=500.0, position=(0.3 * i, 0.3 * j, 0.105), orientation=q)
            if (i + j) % 3 == 0:
                w.add_body(sg.Box((0.1, 0.1, 0.1)), density=500.0, position=(0.3 * i + 0.02, 0.3 * j, 0.32))
    return w


def state_bytes(w):
    c = w.contacts
    arrays = [w.positions, w.orientations, w.velocities, w.angular_velocities, c.alpha, c.friction, c.impulse]
    return b"".join(np.ascontiguousarray(a).tobytes() for a in arrays)


@pytest.mark.filterwarnings("ignore::signorini.SolverWarning")  # 6 sweeps: the PGS may flag a substep
@pytest.mark.parametrize("solver", ["pgs", "soft"])
def test_every_thread_count_gives_the_bits_of_one_thread(solver):
    one = grid(1, solver)
    one.step(1 / 60, 30)
    assert len(one.contacts.alpha) > 4 * 256  # the box-plane colours alone exceed one task
    for threads in (2, 3, None):
        w = grid(threads, solver)
        w.step(1 / 60, 30)
        assert state_bytes(w) == state_bytes(one), threads


def test_threads_default_to_the_machine_and_can_be_changed_between_steps():
    w = grid(None, "soft", n=3)
    assert w.threads >= 1
    alone = grid(1, "soft", n=3)
    for threads in (2, 1, 3):
        w.set_threads(threads)
        assert w.threads == threads
        w.step(1 / 60, 5)
        alone.step(1 / 60, 5)
    assert state_bytes(w) == state_bytes(alone)


@pytest.mark.parametrize("bad, error", [(0, ValueError), (-2, ValueError), (1.5, TypeError), (True, TypeError),
                                        ("2", TypeError), (2**40, ValueError)])
def test_bad_thread_counts_are_refused_and_change_nothing(bad, error):
    with pytest.raises(error, match="threads"):
        sg.World(threads=bad)
    w = sg.World(threads=2)
    with pytest.raises(error, match="threads"):
        w.set_threads(bad)
    assert w.threads == 2


def test_a_pickle_keeps_the_thread_count_as_given():
    w = grid(3, "pgs", n=2)
    assert pickle.loads(pickle.dumps(w)).threads == 3
    default = grid(None, "pgs", n=2)
    assert pickle.loads(pickle.dumps(default)).threads == default.threads


@pytest.mark.parametrize("name, steps", [("pile", 120), ("rain", 60), ("shapes", 120)])
def test_built_in_scenes_give_the_bits_of_one_thread(name, steps):
    """Every shape family, mesh floors and hundreds of pairs (the narrow phase is split into chunks
    of 64 pairs): one thread and two give the same bits."""
    from signorini import scenes
    runs = []
    for threads in (1, 2):
        scene = scenes.build(name)
        scene.world.set_threads(threads)
        scene.world.step(scene.dt, steps)
        runs.append(state_bytes(scene.world))
    assert runs[0] == runs[1]
