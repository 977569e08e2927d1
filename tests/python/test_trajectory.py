"""Trajectories that carry their scene: recorded from real runs of the core, saved, loaded back."""

import dataclasses
import zipfile
from pathlib import Path

import numpy as np
import pytest

import signorini as sg
from signorini import output, scenes
from signorini.trajectory import (CONTACT_KEYS, Recorder, auto_stride, load_trajectory, moving_bodies, record_bytes,
                                  save_trajectory)


def assert_records_equal(a, b):
    """Every field of two records equal, arrays exactly."""
    for field in dataclasses.fields(a):
        x, y = getattr(a, field.name), getattr(b, field.name)
        if field.name == "draw_meshes":
            assert len(x) == len(y)
            for (v1, f1), (v2, f2) in zip(x, y):
                np.testing.assert_array_equal(v1, v2)
                np.testing.assert_array_equal(f1, f2)
        elif isinstance(x, dict):
            assert x.keys() == y.keys(), field.name
            for k in x:
                # (events: a dict of kinds, each a dict of arrays)
                pairs = ([(f"{k}.{f}", x[k][f], y[k][f]) for f in x[k]] if isinstance(x[k], dict)
                         else [(k, x[k], y[k])])
                for name, u, v in pairs:
                    np.testing.assert_array_equal(u, v, err_msg=f"{field.name}[{name}]")
                    assert np.asarray(u).dtype == np.asarray(v).dtype, f"{field.name}[{name}]"
        elif isinstance(x, np.ndarray):
            np.testing.assert_array_equal(x, y, err_msg=field.name)
            assert x.dtype == y.dtype, field.name
        else:
            assert x == y, field.name


@pytest.fixture(scope="module")
def boxes_record():
    return output.run(scenes.build("boxes"), steps=40, progress=False, stride=3)


def test_record_carries_the_scene(boxes_record):
    r = boxes_record
    world = scenes.build("boxes").world
    n = world.num_bodies
    assert r.names[0] == "ground" and len(set(r.names)) == n
    assert [s["type"] for s in r.shapes] == ["plane", "box", "box"] + ["sphere"] * 5
    assert r.shapes[1]["half_extents"] == [0.2, 0.2, 0.2]
    assert r.shapes[3]["radius"] == 0.15
    # draw meshes: the box's 8 corners, a plane patch on z = 0 around the bodies
    np.testing.assert_allclose(np.abs(r.draw_meshes[1][0]), 0.2)
    np.testing.assert_allclose(r.draw_meshes[0][0][:, 2], 0.0, atol=1e-12)
    assert np.ptp(r.draw_meshes[0][0][:, 0]) > np.ptp(r.positions[:, 1:, 0])
    np.testing.assert_array_equal(r.is_static, world.is_static)
    np.testing.assert_allclose(r.gravity, [0, 0, -9.81])


def test_stride_keeps_every_sth_step_and_the_last(boxes_record):
    r = boxes_record
    # 40 steps with stride 3: steps 0, 3, ..., 39 and the last step 40
    np.testing.assert_array_equal(r.frame_step, list(range(0, 40, 3)) + [40])
    assert r.steps == 40 and r.frames == 15
    assert r.step_time.shape == r.num_contacts.shape == r.iterations.shape == (40,)
    assert set(r.solver) >= {"iterations", "converged", "residual", "max_complementarity", "max_cone_violation"}

    # the same run at stride 1 (the core is deterministic): frames are its rows at those steps
    full = output.run(scenes.build("boxes"), steps=40, progress=False)
    assert full.frames == 41
    np.testing.assert_array_equal(r.positions, full.positions[r.frame_step])
    np.testing.assert_array_equal(r.orientations, full.orientations[r.frame_step])
    np.testing.assert_array_equal(r.time, full.time[r.frame_step])
    np.testing.assert_array_equal(r.num_contacts, full.num_contacts)

    # each frame's contacts are those of the step that ended at it
    counts = np.diff(r.contacts["offsets"])
    assert counts[0] == 0
    np.testing.assert_array_equal(counts[1:], r.num_contacts[r.frame_step[1:] - 1])
    f = r.frames - 1
    c = r.frame_contacts(f)
    np.testing.assert_array_equal(c["point"], full.frame_contacts(40)["point"])
    np.testing.assert_allclose(np.linalg.norm(c["normal"], axis=1), 1.0, rtol=1e-9)
    assert set(c) == set(CONTACT_KEYS)


def test_recorder_observing_an_outside_loop_equals_recorder_step():
    a, b = scenes.build("boxes"), scenes.build("boxes")
    ra = Recorder(a.world, stride=2)
    ra.step(a.dt, 9)
    rb = Recorder(b.world, stride=2)
    for _ in range(9):
        b.world.step(dt=b.dt)
        rb.observe()
    x, y = ra.record(), rb.record()
    np.testing.assert_array_equal(x.positions, y.positions)
    np.testing.assert_array_equal(x.contacts["force"], y.contacts["force"])
    assert x.dt == pytest.approx(y.dt, rel=1e-12)


# float32's unit roundoff: rounding a double x to the nearest float32 moves it by at most U |x|
U = float(np.finfo(np.float32).eps) / 2  # 2^-24, 6.0e-8
FLOAT32_FIELDS = ("positions", "orientations", "velocities", "angular_velocities")


def assert_loaded_equals_recorded(recorded, loaded):
    """The loaded record is the recorded one: float32-stored values (the moving bodies' poses and
    velocities, the contacts' numbers) within float32 rounding, U |x| per component, which is at
    most U times the vector's magnitude; everything else (still bodies included) exactly."""
    moving = moving_bodies(recorded)
    for name in FLOAT32_FIELDS:
        x, y = np.asarray(getattr(recorded, name)), getattr(loaded, name)
        assert y.dtype == np.float64 and y.shape == x.shape, name
        assert np.all(np.abs(y - x) <= U * np.abs(x)), name
        np.testing.assert_array_equal(y[:, ~moving], x[:, ~moving], err_msg=name)
    if recorded.contacts is not None:
        for k in ("point", "normal", "force", "gap"):
            x, y = np.asarray(recorded.contacts[k]), loaded.contacts[k]
            assert y.dtype == np.float64 and np.all(np.abs(y - x) <= U * np.abs(x)), k
    exact = dataclasses.replace(loaded, **{k: np.asarray(getattr(recorded, k)) for k in FLOAT32_FIELDS})
    if recorded.contacts is not None:
        exact.contacts = {**loaded.contacts, **{k: np.asarray(recorded.contacts[k])
                                                for k in ("point", "normal", "force", "gap")}}
    plain = dataclasses.replace(recorded, **{k: np.asarray(getattr(recorded, k)) for k in FLOAT32_FIELDS})
    if recorded.contacts is not None:
        plain.contacts = {k: np.asarray(v) for k, v in recorded.contacts.items()}
    assert_records_equal(plain, exact)


def test_save_and_load_give_the_recorded_run_to_float32_precision(tmp_path, boxes_record):
    path = boxes_record.save(tmp_path / "deep" / "boxes.npz")
    back = load_trajectory(path)
    assert_loaded_equals_recorded(boxes_record, back)
    # the bound is met, not exceeded by chance: the file did round (the positions are not all exact)
    assert np.any(back.positions != boxes_record.positions)
    # a record without contacts and a scene with every shape kind round-trip too
    shapes = output.run(scenes.build("shapes"), steps=5, progress=False, contacts=False)
    assert shapes.contacts is None
    assert_loaded_equals_recorded(shapes, load_trajectory(save_trajectory(tmp_path / "shapes.npz", shapes)))
    kinds = [s["type"] for s in shapes.shapes]
    assert kinds[0] == "trimesh" and {"box", "capsule", "cylinder", "hull", "compound", "sphere", "mesh"} <= set(kinds)


def test_custom_world_and_names(tmp_path):
    w = sg.World(gravity=(0, 0, -9.81))
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    w.add_body(sg.Sphere(radius=0.1), mass=1.0, position=(0, 0, 0.5))
    rec = sg.Recorder(w, names=["floor", "ball"], scene="drop")
    rec.step(dt=0.01, steps=20)
    r = rec.record()
    back = sg.load_trajectory(r.save(tmp_path / "drop.npz"))
    assert back.names == ["floor", "ball"] and back.scene == "drop"
    # free fall for the first steps: z = 0.5 - 1/2 g t^2 to the integrator's first order
    assert back.positions[5, 1, 2] < 0.5
    with pytest.raises(ValueError, match="names"):
        sg.Recorder(w, names=["one"])
    with pytest.raises(ValueError, match="not unique"):
        sg.Recorder(w, names=["a", "a"])


@pytest.mark.parametrize("stride", [0, -1, 1.5, True])
def test_bad_stride_is_an_error(stride):
    with pytest.raises(ValueError, match="stride"):
        Recorder(scenes.build("boxes").world, stride=stride)


def test_bad_files_give_errors_naming_them(tmp_path, boxes_record):
    with pytest.raises(FileNotFoundError, match="missing.npz"):
        load_trajectory(tmp_path / "missing.npz")

    text = tmp_path / "text.npz"
    text.write_text("not a trajectory")
    with pytest.raises(ValueError, match="text.npz.*not an .npz"):
        load_trajectory(text)

    # a truncated file
    good = boxes_record.save(tmp_path / "good.npz")
    cut = tmp_path / "cut.npz"
    cut.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    with pytest.raises(ValueError, match="cut.npz"):
        load_trajectory(cut)

    # an .npz of something else
    other = tmp_path / "other.npz"
    np.savez(other, x=np.zeros(3))
    with pytest.raises(ValueError, match="other.npz.*not a signorini trajectory"):
        load_trajectory(other)

    # an array removed from a real trajectory
    broken = tmp_path / "broken.npz"
    with zipfile.ZipFile(good) as src, zipfile.ZipFile(broken, "w") as dst:
        for item in src.infolist():
            if item.filename != "frame_positions.npy":
                dst.writestr(item, src.read(item.filename))
    with pytest.raises(ValueError, match="broken.npz.*missing frame_positions"):
        load_trajectory(broken)


def test_solver_warnings_of_a_recorded_run_are_given_once():
    """A stack solved by the PGS with one sweep a step flags every step: one warning says how many."""
    w = sg.World(gravity=(0, 0, -9.81), solver="pgs", max_iterations=1, tolerance=1e-12, warn_velocity=1e-9)
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    for k in range(4):
        w.add_body(sg.Box((0.1, 0.1, 0.1)), mass=1.0, position=(0.01 * k, 0, 0.1 + 0.2 * k))
    with pytest.warns(sg.SolverWarning) as caught:
        Recorder(w).step(1 / 240, 30)
    assert len(caught) == 1
    assert "[120 unconverged solver substeps in 30 recorded steps]" in str(caught[0].message)
    assert w.unconverged_substeps == 120  # 4 substeps a step


def test_select_frames_keeps_poses_and_their_contacts(boxes_record):
    r = boxes_record
    keep = [0, 2, 5, r.frames - 1]
    s = r.select_frames(keep)
    assert s.frames == 4 and s.steps == r.steps
    np.testing.assert_array_equal(s.positions, r.positions[keep])
    np.testing.assert_array_equal(s.frame_step, r.frame_step[keep])
    for j, f in enumerate(keep):
        for k in CONTACT_KEYS:
            np.testing.assert_array_equal(s.frame_contacts(j)[k], r.frame_contacts(f)[k])
    with pytest.raises(ValueError, match="increasing"):
        r.select_frames([3, 1])


def test_html_player_thins_frames_of_very_large_runs(tmp_path, boxes_record):
    import json
    import re

    from signorini.player import frame_data_bytes, write_html

    r = boxes_record
    full = write_html(tmp_path / "full.html", r)
    budget = frame_data_bytes(r.select_frames([0, 3, 6, 9, 12, 14]))  # contacts included
    thin = write_html(tmp_path / "thin.html", r, max_frame_bytes=budget)

    def frames(path):
        text = path.read_text(encoding="utf-8")
        data = re.search(r'<script id="signorini-data" type="application/json">(.*?)</script>', text, re.S).group(1)
        return json.loads(data)["frames"]

    assert frames(full) == r.frames
    assert r.frames == 15 and frames(thin) == 6  # every 3rd: frames 0, 3, 6, 9, 12 and the last, 14


def file_frame_bytes(path) -> int:
    """Bytes of a trajectory file's frame arrays (moving bodies' poses and velocities, contacts) as
    stored, before compression."""
    with np.load(path) as data:
        return sum(data[k].nbytes for k in data.files
                   if k.startswith("frame_") and k != "frame_step" or k.startswith("contact_") and k != "contact_offsets")


def test_an_automatic_stride_keeps_a_recorded_run_within_the_budget(tmp_path):
    budget = 60_000
    scene = scenes.build("boxes")
    rec = Recorder(scene.world, budget=budget)
    rec.step(scene.dt, 240)
    auto = rec.record()
    assert rec.stride_auto and rec.stride == auto_stride(7, 240, budget) > 1
    path = auto.save(tmp_path / "auto.npz")
    assert file_frame_bytes(path) == record_bytes(auto) <= budget
    assert path.stat().st_size <= budget
    # the same run with every step a frame holds more than the budget: the stride did the work
    full = output.run(scenes.build("boxes"), steps=240, progress=False, stride=1)
    assert full.frames == 241 and record_bytes(full) > budget
    np.testing.assert_array_equal(auto.positions, full.positions[::auto.stride][:auto.frames - 1].tolist()
                                  + [full.positions[-1].tolist()])
    # a stride given is kept, whatever the budget
    rec = Recorder(scenes.build("boxes").world, stride=1, budget=budget)
    rec.step(scene.dt, 240)
    assert rec.record().frames == 241


def test_frames_past_the_allowance_are_thinned_to_the_budget():
    """Stepped by other code (no step count known), the recorder keeps every step, then record()
    keeps every k-th frame and the last so that the frames fit; the stride says k."""
    budget = 40_000
    scene = scenes.build("boxes")
    rec = Recorder(scene.world, budget=budget)
    for _ in range(200):
        scene.world.step(scene.dt)
        rec.observe()
    assert rec.stride == 1 and rec.frames == 201
    r = rec.record()
    assert record_bytes(r) <= budget and r.stride > 1
    assert r.frame_step[-1] == 200 and np.all(np.diff(r.frame_step)[:-1] == r.stride)


def test_static_bodies_are_stored_once_and_restored(tmp_path, boxes_record):
    path = boxes_record.save(tmp_path / "boxes.npz")
    static = boxes_record.is_static
    moving = moving_bodies(boxes_record)
    # the ground is static; a body that never moves in these 40 steps is stored once as well
    assert not moving[static].any() and 0 < np.count_nonzero(moving) < np.count_nonzero(~static)
    with np.load(path) as data:
        np.testing.assert_array_equal(data["moving"], moving)
        assert data["frame_positions"].shape == (boxes_record.frames, int(np.count_nonzero(moving)), 3)
        assert data["frame_positions"].dtype == np.float32
        assert data["still_positions"].shape == (int(np.count_nonzero(~moving)), 3)
        assert data["still_positions"].dtype == np.float64
    back = load_trajectory(path)
    for name in FLOAT32_FIELDS:
        np.testing.assert_array_equal(getattr(back, name)[:, ~moving], np.asarray(getattr(boxes_record, name))[:, ~moving])


def test_a_version_1_file_still_loads():
    """tests/python/data/trajectory_version1.npz: 40 steps of the boxes scene at stride 3, written
    by version 1 (float64, every body every frame); the same run today gives the same arrays."""
    old = load_trajectory(Path(__file__).parent / "data" / "trajectory_version1.npz")
    now = output.run(scenes.build("boxes"), steps=40, progress=False, stride=3)
    with np.load(Path(__file__).parent / "data" / "trajectory_version1.npz") as data:
        assert int(data["version"]) == 1 and data["positions"].dtype == np.float64
    for name in FLOAT32_FIELDS + ("time", "frame_step", "kinetic_energy"):
        np.testing.assert_array_equal(getattr(old, name), np.asarray(getattr(now, name)), err_msg=name)
    for k in CONTACT_KEYS:
        np.testing.assert_array_equal(old.contacts[k], np.asarray(now.contacts[k]), err_msg=k)


def test_a_newer_version_is_refused_naming_it(tmp_path, boxes_record):
    good = boxes_record.save(tmp_path / "good.npz")
    newer = tmp_path / "newer.npz"
    with zipfile.ZipFile(good) as src, zipfile.ZipFile(newer, "w") as dst:
        for item in src.infolist():
            if item.filename != "version.npy":
                dst.writestr(item, src.read(item.filename))
        with dst.open("version.npy", "w") as f:
            np.lib.format.write_array(f, np.array(3))
    with pytest.raises(ValueError, match="newer.npz.*version 3.*reads versions 1 and 2"):
        load_trajectory(newer)


def test_the_recorder_holds_at_most_one_chunk_of_frames_in_memory():
    """Frames go to disk a chunk at a time: whatever the run's length the recorder holds at most
    chunk_frames of them, and what it gives back equals a recording held in memory whole."""
    scene, twin = scenes.build("boxes"), scenes.build("boxes")
    small = Recorder(scene.world, stride=1, chunk_bytes=3 * 8 * 13 * 8)   # 3 frames of 8 bodies
    whole = Recorder(twin.world, stride=1, chunk_bytes=1 << 30)
    assert small.chunk_frames == 3
    for _ in range(50):
        small.step(scene.dt, 1)
        whole.step(twin.dt, 1)
        assert small.frames_in_memory <= small.chunk_frames
    assert whole.frames_in_memory == 51 and small.frames == 51
    for f in (0, 7, 49, 50):  # on disk and in memory
        a, b = small.frame(f), whole.frame(f)
        for k in FLOAT32_FIELDS:
            np.testing.assert_array_equal(a[k], b[k])
        for k in CONTACT_KEYS if f else ():
            np.testing.assert_array_equal(a["contacts"][k], b["contacts"][k])
    r = small.record()
    assert isinstance(r.positions, np.memmap) and isinstance(r.contacts["point"], np.memmap)
    assert_records_equal(dataclasses.replace(r, wall_time=0.0), dataclasses.replace(whole.record(), wall_time=0.0))


def test_the_recorder_keeps_the_contact_events_and_the_file_carries_them(tmp_path):
    # a bouncing ball: every begin, end and hit of the run, with the step it happened in, as
    # World.events gave them step by step; saved and loaded exactly (float64 and int64)
    w = sg.World(sleeping=False)
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    w.add_body(sg.Sphere(0.1), mass=1.0, position=(0, 0, 1.1), restitution=0.8)
    twin = sg.World(sleeping=False)
    twin.add_static(sg.Plane((0, 0, 1), 0.0))
    twin.add_body(sg.Sphere(0.1), mass=1.0, position=(0, 0, 1.1), restitution=0.8)
    rec = sg.Recorder(w, stride=7)
    rec.step(1 / 240, 480)
    r = rec.record()
    steps = []
    for k in range(480):
        twin.step(1 / 240)
        steps += [k] * len(twin.events.begin)
    assert r.events["begin"]["step"].tolist() == steps and len(steps) >= 3
    assert len(r.events["end"]["step"]) >= 2 and r.events["hits"]["speed"][0] > 4.0
    back = sg.load_trajectory(r.save(tmp_path / "bounce.npz"))
    for kind in r.events:
        for k, v in r.events[kind].items():
            np.testing.assert_array_equal(back.events[kind][k], v)
            assert back.events[kind][k].dtype == v.dtype


def test_a_file_with_damaged_events_is_refused_naming_them(tmp_path):
    w = sg.World(sleeping=False)
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    w.add_body(sg.Sphere(0.1), mass=1.0, position=(0, 0, 0.5))
    rec = sg.Recorder(w)
    rec.step(1 / 240, 120)
    path = rec.record().save(tmp_path / "drop.npz")
    with np.load(path) as z:
        data = dict(z)
    data["event_begin_step"] = data["event_begin_step"] + 1000  # past the run's steps
    bad = tmp_path / "bad.npz"
    np.savez(bad, **data)
    with pytest.raises(ValueError, match="event_begin_step names a step outside"):
        sg.load_trajectory(bad)
