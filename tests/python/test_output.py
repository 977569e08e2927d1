"""Recording, saving, summarising and plotting, mostly on a stand-in world.

The stand-in moves bodies ballistically (exact in closed form) and reports a scripted contact list,
so every recorded number there is known in advance. The certificate summary is checked on the real
core, against the figures the world reports step by step.
"""

import math
import warnings
from types import SimpleNamespace

import numpy as np
import pytest

import signorini as sg
from signorini import meshes, output, scenes


class BallisticWorld:
    """Bodies in free flight under gravity, integrated exactly; body 0 is a static plane z = 0.

    Contacts are scripted: step k (1-based) reports gaps ``gaps(k)`` and iterations k % 5.
    """

    def __init__(self, gaps):
        self.gravity = np.array([0.0, 0.0, -9.81])
        self._shapes = [
            SimpleNamespace(normal=(0.0, 0.0, 1.0), offset=0.0),
            SimpleNamespace(radius=0.2),
            SimpleNamespace(half_extents=(0.3, 0.2, 0.1)),
            SimpleNamespace(vertices=meshes.torus(0.3, 0.1, 12, 6)[0], faces=meshes.torus(0.3, 0.1, 12, 6)[1]),
        ]
        self.masses = np.array([np.inf, 1.0, 2.0, 3.0])
        self.is_static = np.array([True, False, False, False])
        self.num_bodies = 4
        self.time = 0.0
        self._p0 = np.array([[0, 0, 0], [0, 0, 1.0], [1.0, 0, 2.0], [-1.0, 0, 3.0]])
        self._v0 = np.array([[0, 0, 0], [1.0, 0, 0], [0, 0.5, 1.0], [0, 0, 0]])
        self._gaps = gaps
        self._k = 0
        self.angular_velocities = np.array([[0, 0, 0], [0, 0, 1.0], [0, 0, 0], [1.0, 0, 0]])
        self.contacts = SimpleNamespace(gap=np.zeros(0))
        self.solver_stats = SimpleNamespace(iterations=0, residual=0.0, converged=True)

    def _free(self):
        return np.where(self.is_static[:, None], 0.0, 1.0)

    @property
    def positions(self):
        t = self.time
        return self._p0 + self._free() * (self._v0 * t + 0.5 * self.gravity * t**2)

    @property
    def velocities(self):
        return self._free() * (self._v0 + self.gravity * self.time)

    @property
    def orientations(self):
        # body 1 spins about z at 1 rad/s, body 3 about x
        half = 0.5 * self.time
        q = np.tile([1.0, 0.0, 0.0, 0.0], (4, 1))
        q[1] = [np.cos(half), 0, 0, np.sin(half)]
        q[3] = [np.cos(half), np.sin(half), 0, 0]
        return q

    def step(self, dt, steps=1):
        for _ in range(steps):
            self._k += 1
            self.time += dt
            gap = np.asarray(self._gaps(self._k), dtype=float)
            k = len(gap)
            self.contacts = SimpleNamespace(gap=gap, body_a=np.zeros(k, int), body_b=np.ones(k, int),
                                            point=np.zeros((k, 3)), normal=np.tile([0.0, 0.0, 1.0], (k, 1)),
                                            force=np.zeros((k, 3)))
            self.solver_stats = SimpleNamespace(iterations=self._k % 5, residual=1e-12 * self._k, converged=True)

    def kinetic_energy(self):
        m = self.masses[1:]
        return float(0.5 * np.sum(m * np.sum(self.velocities[1:] ** 2, axis=1)))

    def potential_energy(self):
        m = self.masses[1:]
        return float(-np.sum(m * (self.positions[1:] @ self.gravity)))

    def shape(self, i):
        return self._shapes[i]


def scripted_gaps(k):
    """no contacts for the first 10 steps, then two contacts, the deepest -k * 1e-5 m."""
    return [] if k <= 10 else [0.001, -k * 1e-5]


def make_scene(steps=40, dt=0.01, snapshot_times=None):
    return SimpleNamespace(
        name="ballistic", world=BallisticWorld(scripted_gaps), dt=dt, steps=steps,
        description="stand-in world", snapshot_times=snapshot_times,
    )


def test_run_records_state_rows_and_step_rows():
    scene = make_scene()
    record = output.run(scene, progress=False)
    T, N = 40, 4
    assert record.time.shape == (T + 1,)
    assert record.positions.shape == (T + 1, N, 3) and record.velocities.shape == (T + 1, N, 3)
    assert record.orientations.shape == (T + 1, N, 4) and record.angular_velocities.shape == (T + 1, N, 3)
    assert record.kinetic_energy.shape == record.potential_energy.shape == (T + 1,)
    for name in ("num_contacts", "min_gap", "iterations", "residual", "converged"):
        assert getattr(record, name).shape == (T,), name

    # row 0 is the initial state, row k the state after k steps
    np.testing.assert_allclose(record.time, 0.01 * np.arange(T + 1), atol=1e-15)
    np.testing.assert_allclose(record.positions[0, 1], [0, 0, 1.0])
    np.testing.assert_allclose(record.positions[-1, 1], [0.4, 0, 1.0 - 0.5 * 9.81 * 0.4**2], atol=1e-12)

    # step arrays follow the scripted contacts: none, then 2 with the deepest gap -k 1e-5
    k = np.arange(1, T + 1)
    np.testing.assert_array_equal(record.num_contacts, np.where(k <= 10, 0, 2))
    assert np.all(np.isnan(record.min_gap[:10]))
    np.testing.assert_allclose(record.min_gap[10:], -k[10:] * 1e-5)
    np.testing.assert_allclose(record.penetration, np.where(k <= 10, 0.0, k * 1e-5))
    np.testing.assert_array_equal(record.iterations, k % 5)

    # exact ballistic motion conserves energy
    np.testing.assert_allclose(record.total_energy, record.total_energy[0], rtol=1e-12)


def test_run_overrides_steps_and_dt_and_rejects_bad_ones():
    record = output.run(make_scene(), steps=7, dt=0.5, progress=False)
    assert record.steps == 7 and record.dt == 0.5
    assert record.time[-1] == pytest.approx(3.5)
    with pytest.raises(ValueError, match="dt"):
        output.run(make_scene(), dt=0.0, progress=False)
    with pytest.raises(ValueError, match="steps"):
        output.run(make_scene(), steps=0, progress=False)


def test_save_and_load_round_trip(tmp_path):
    record = output.run(make_scene(steps=12), progress=False)
    path = output.save_trajectory(tmp_path / "sub" / "run.npz", record)
    with np.load(path, allow_pickle=False) as data:
        assert data["frame_positions"].shape == (13, int(np.count_nonzero(data["moving"])), 3)
        assert str(data["scene"]) == "ballistic"
    back = output.load_trajectory(path)
    assert back.scene == "ballistic" and back.dt == record.dt and back.positions.shape == (13, 4, 3)
    # float32 in the file: within 2^-24 of each value
    u = float(np.finfo(np.float32).eps) / 2
    assert np.all(np.abs(back.orientations - record.orientations) <= u * np.abs(record.orientations))
    np.testing.assert_array_equal(back.min_gap, record.min_gap)
    np.testing.assert_array_equal(back.masses, record.masses)


def test_summary_numbers():
    scene = make_scene(steps=200, dt=0.01)  # 2 s
    record = output.run(scene, progress=False)
    s = output.summary(record, window=1.0)
    assert s["bodies"] == 4 and s["dynamic"] == 3 and s["steps"] == 200
    assert s["simulated_time"] == pytest.approx(2.0)
    # the deepest scripted penetration in the last second is at the last step
    assert s["max_penetration_last"] == pytest.approx(200 * 1e-5)
    assert s["contact_steps"] == 190
    assert s["iterations_max"] == 4
    assert s["iterations_median"] == 2
    assert s["energy_change"] == pytest.approx(0.0, abs=1e-9)
    text = output.format_summary(record, files=["a.npz", "b.png"])
    assert "ballistic" in text and "a.npz" in text and "b.png" in text and "last 1 s: 2 mm" in text
    # ballistic motion keeps its energy, and the summary says so
    line = next(x for x in text.splitlines() if x.startswith("energy"))
    assert line.startswith("energy       kept: kinetic ") and line.endswith(", rounding)") and "drift" not in line


def _real_scene(world, steps):
    return SimpleNamespace(name="real", world=world, dt=1.0 / 240.0, steps=steps, description="",
                           snapshot_times=None)


def energy_line(record) -> str:
    return next(x for x in output.format_summary(record).splitlines() if x.startswith("energy"))


def test_summary_names_a_friction_loss_as_dissipated():
    # a box slid along the ground at 1 m/s: friction takes all its kinetic energy, 0.5 m v^2 = 4 J,
    # which is everything the run had to spend
    w = sg.World(gravity=(0, 0, -9.81))
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    w.add_body(sg.Box((0.1, 0.1, 0.1)), mass=8.0, position=(0, 0, 0.1), velocity=(1.0, 0, 0))
    record = output.run(_real_scene(w, 120), progress=False)
    s = output.summary(record)
    assert s["energy_change"] == pytest.approx(-4.0, rel=1e-3)
    assert s["energy_available"] == pytest.approx(4.0, rel=1e-3)
    line = energy_line(record)
    assert line.startswith("energy       dissipated 4 J by contacts and friction: 100 % of the 4 J available "
                           "(kinetic 4 J at the start + "), line
    assert line.endswith(" of potential energy released), 0 J still kinetic at the end")
    assert "drift" not in line and "gained" not in line


def test_summary_of_a_slide_down_a_slope_gives_friction_its_closed_form_share():
    # a box released on a 30-degree slope with mu 0.3 slides at a = g (sin 30 - mu cos 30); over
    # the distance d it releases m g d sin 30 of potential energy, of which friction takes
    # mu m g d cos 30: a share mu / tan 30 = 52.0 %, the rest is kinetic. The share is of the energy
    # the run had to spend, never over 100 % (the torus scene's summary read "104 %" of a reference
    # that was near zero)
    theta, mu, m, g = math.radians(30.0), 0.3, 2.0, 9.81
    normal = (-math.sin(theta), 0.0, math.cos(theta))
    w = sg.World(gravity=(0, 0, -g), friction_cone="cone")
    w.add_static(sg.Plane(normal, 0.0), friction=mu)
    w.add_body(sg.Box((0.1, 0.1, 0.1)), mass=m, friction=mu, position=tuple(0.1 * np.array(normal)),
               orientation=(math.cos(-theta / 2), 0.0, math.sin(-theta / 2), 0.0))
    record = output.run(_real_scene(w, 240), progress=False)  # 1 s
    s = output.summary(record)
    d = 0.5 * g * (math.sin(theta) - mu * math.cos(theta)) * 1.0 ** 2
    assert -s["energy_change"] == pytest.approx(mu * m * g * math.cos(theta) * d, rel=1e-2)
    assert s["potential_initial"] - s["potential_final"] == pytest.approx(m * g * d * math.sin(theta), rel=1e-2)
    share = -s["energy_change"] / s["energy_available"]
    assert share == pytest.approx(mu / math.tan(theta), rel=1e-2)
    line = energy_line(record)
    assert line.startswith(f"energy       dissipated {-s['energy_change']:.3g} J by contacts and friction: "
                           f"{100 * share:.3g} % of the {s['energy_available']:.3g} J available "
                           f"(kinetic 0 J at the start + {s['potential_initial'] - s['potential_final']:.3g} J of "
                           "potential energy released), "), line
    assert line.endswith(f"{s['kinetic_final']:.3g} J still kinetic at the end")
    assert "drift" not in line and "gained" not in line


def test_summary_names_a_gain_as_a_gain():
    # a ball lifted by a steady force twice its weight gains m g h over the rise h
    w = sg.World(gravity=(0, 0, -9.81))
    ball = w.add_body(sg.Sphere(0.1), mass=1.0, position=(0, 0, 1.0))
    w.set_external_wrench(ball, force=(0, 0, 2 * 9.81))
    record = output.run(_real_scene(w, 48), progress=False)
    s = output.summary(record)
    rise = record.positions[-1, ball, 2] - record.positions[0, ball, 2]
    assert s["energy_change"] == pytest.approx(9.81 * rise + 0.5 * record.velocities[-1, ball, 2] ** 2, rel=1e-6)
    line = energy_line(record)
    assert line == (f"energy       gained {s['energy_change']:.3g} J: kinetic 0 J -> {s['kinetic_final']:.3g} J, "
                    f"potential released {-9.81 * rise:.3g} J; contacts and friction only dissipate, so it came from "
                    "external forces, kinematic bodies or the integration")
    assert "dissipated" not in line and "drift" not in line


def test_energy_change_text_for_a_loss_a_gain_and_rounding():
    # the torus scene's figures: 0.27 J dissipated of 0.528 J available, never "104 %"
    assert output.energy_change_text((0.00106, 0.258), (0.0, -0.527), 0.527) == (
        "dissipated 0.27 J by contacts and friction: 51.1 % of the 0.528 J available (kinetic 0.00106 J at the start "
        "+ 0.527 J of potential energy released), 0.258 J still kinetic at the end")
    # a body thrown up that ends higher, and slower, than it started
    assert output.energy_change_text((10.0, 1.0), (0.0, 5.0), 10.0) == (
        "dissipated 4 J by contacts and friction: 80 % of the 5 J available (kinetic 10 J at the start - 5 J gone "
        "into potential energy), 1 J still kinetic at the end")
    assert output.energy_change_text((0.0, 0.5), (0.0, 0.0), 10.0).startswith(
        "gained 0.5 J: kinetic 0 J -> 0.5 J, potential released 0 J; contacts and friction only dissipate")
    assert output.energy_change_text((1.0, 1.0), (5.0, 5.0 + 1e-15), 5.0).startswith("kept: kinetic 1 J -> 1 J,")
    assert output.energy_change_text((0.0, 0.0), (0.0, 0.0), 0.0).startswith("kept")


@pytest.mark.slow
def test_plot_writes_a_png(tmp_path):
    record = output.run(make_scene(steps=30), progress=False)
    path = output.plot(tmp_path / "run.png", record, make_scene(snapshot_times=(0.0, 0.1, 0.3)))
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert path.stat().st_size > 10_000


def test_plane_patch_is_the_cut_of_the_view_box():
    lo, hi = np.zeros(3), np.ones(3)
    # z = 0.5 cuts the unit cube in a unit square
    square = output._plane_in_box(np.array([0.0, 0.0, 1.0]), 0.5, lo, hi)
    assert square.shape == (4, 3)
    np.testing.assert_allclose(square[:, 2], 0.5)
    # a plane outside the box gives nothing
    assert output._plane_in_box(np.array([0.0, 0.0, 1.0]), 2.0, lo, hi) is None
    # x + y + z = 1.5 cuts a regular hexagon
    n = np.ones(3) / np.sqrt(3)
    hexagon = output._plane_in_box(n, 1.5 / np.sqrt(3), lo, hi)
    assert hexagon.shape == (6, 3)
    sides = np.linalg.norm(np.roll(hexagon, 1, axis=0) - hexagon, axis=1)
    np.testing.assert_allclose(sides, np.sqrt(0.5))


def test_summary_reports_the_certificate_of_every_step():
    # the boxes scene run by output.run and, bit-identically, step by step by hand: the summary's
    # certificate figures are the largest the world reported over the run and over the last second
    steps = 240
    by_hand = scenes.build("boxes")
    seen = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sg.SolverWarning)
        for _ in range(steps):
            by_hand.world.step(by_hand.dt)
            seen.append(by_hand.world.solver_stats)
        record = output.run(scenes.build("boxes"), steps=steps, progress=False)
    s = output.summary(record, window=0.5)
    last = [stats for k, stats in enumerate(seen) if (k + 1) * by_hand.dt > steps * by_hand.dt - 0.5 - 1e-12]
    for key, _, _ in output.CERTIFICATE:
        assert s["certificate_run"][key] == max(getattr(stats, key) for stats in seen), key
        assert s["certificate_last"][key] == max(getattr(stats, key) for stats in last), key
    assert s["certificate_run"]["max_cone_violation"] > 0  # the impacts: the pyramid's corners
    assert "certificate  largest over the run" in output.format_summary(record)
