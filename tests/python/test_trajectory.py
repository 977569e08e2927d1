"""Trajectories that carry their scene: recorded from real runs of the core, saved, loaded back."""

import dataclasses
import zipfile

import numpy as np
import pytest

import signorini as sg
from signorini import output, scenes
from signorini.trajectory import CONTACT_KEYS, Recorder, load_trajectory, save_trajectory


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
                np.testing.assert_array_equal(x[k], y[k], err_msg=f"{field.name}[{k}]")
                assert np.asarray(x[k]).dtype == np.asarray(y[k]).dtype, f"{field.name}[{k}]"
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


def test_save_and_load_give_identical_arrays(tmp_path, boxes_record):
    path = boxes_record.save(tmp_path / "deep" / "boxes.npz")
    back = load_trajectory(path)
    assert_records_equal(boxes_record, back)
    # a record without contacts and a scene with every shape kind round-trip too
    shapes = output.run(scenes.build("shapes"), steps=5, progress=False, contacts=False)
    assert shapes.contacts is None
    assert_records_equal(shapes, load_trajectory(save_trajectory(tmp_path / "shapes.npz", shapes)))
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
            if item.filename != "positions.npy":
                dst.writestr(item, src.read(item.filename))
    with pytest.raises(ValueError, match="broken.npz.*missing positions"):
        load_trajectory(broken)


def test_solver_warnings_of_a_recorded_run_are_given_once():
    """A stack solved with one sweep a step flags every step: one warning says how many."""
    w = sg.World(gravity=(0, 0, -9.81), max_iterations=1, tolerance=1e-12, warn_velocity=1e-9)
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

    from signorini.player import write_html

    r = boxes_record
    full = write_html(tmp_path / "full.html", r)
    thin = write_html(tmp_path / "thin.html", r, max_frame_bytes=r.num_bodies * 40 * 5)

    def frames(path):
        text = path.read_text(encoding="utf-8")
        data = re.search(r'<script id="signorini-data" type="application/json">(.*?)</script>', text, re.S).group(1)
        return json.loads(data)["frames"]

    assert frames(full) == r.frames
    assert r.frames == 15 and frames(thin) == 6  # every 3rd: frames 0, 3, 6, 9, 12 and the last, 14
