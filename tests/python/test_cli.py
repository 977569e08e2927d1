"""The command line, run as a user runs it: ``python -m signorini ...`` in a subprocess."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import signorini
from signorini import scenes


def run_cli(*args, cwd=None):
    """Run ``python -m signorini *args`` with the same signorini package this test imports."""
    package_root = str(Path(signorini.__file__).resolve().parent.parent)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([package_root, env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return subprocess.run(
        [sys.executable, "-m", "signorini", *args],
        capture_output=True, text=True, env=env, cwd=cwd, timeout=600,
    )


@pytest.mark.slow
def test_run_boxes_writes_record_and_picture(tmp_path):
    out = tmp_path / "out"
    result = run_cli("run", "boxes", "--steps", "50", "--out", str(out))
    assert result.returncode == 0, result.stderr
    npz, png = out / "boxes.npz", out / "boxes.png"
    assert npz.is_file() and png.is_file()
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    # state arrays have one row per step plus the initial state; step arrays one per step
    n = scenes.build("boxes").world.num_bodies
    with np.load(npz, allow_pickle=False) as data:
        assert str(data["scene"]) == "boxes"
        assert data["time"].shape == (51,)
        moving = int(np.count_nonzero(data["moving"]))
        assert 0 < moving < n and data["frame_positions"].shape == (51, moving, 3)
        assert data["frame_positions"].dtype == np.float32
        assert data["kinetic_energy"].shape == data["potential_energy"].shape == (51,)
        for name in ("num_contacts", "min_gap", "solver_iterations", "solver_residual", "solver_converged"):
            assert data[name].shape == (50,), name
        assert data["masses"].shape == data["is_static"].shape == (n,)
        np.testing.assert_allclose(data["time"], np.arange(51) * float(data["dt"]), rtol=1e-12, atol=1e-12)
    r = signorini.load_trajectory(npz)
    assert r.positions.shape == r.velocities.shape == r.angular_velocities.shape == (51, n, 3)
    assert r.orientations.shape == (51, n, 4)
    # unit quaternions stored as float32: each component within 2^-24 of its value, the norm within 2^-23
    np.testing.assert_allclose(np.linalg.norm(r.orientations, axis=2), 1.0, rtol=float(np.finfo(np.float32).eps))
    assert np.all(np.isfinite(r.positions))
    # 50 steps of 8 bodies fit the budget frame by frame: the stride chosen is 1, and said so
    assert "frames       51, every 1 step (stride 1, chosen for the 20 MB frame budget" in result.stdout

    # the summary names the scene and the files, the HTML player among them
    html = out / "boxes.html"
    assert html.is_file() and html.read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
    assert "boxes" in result.stdout
    assert str(npz) in result.stdout and str(png) in result.stdout and str(html) in result.stdout


def test_unknown_scene_exits_2_naming_it(tmp_path):
    result = run_cli("run", "no-such-scene", "--out", str(tmp_path))
    assert result.returncode == 2
    assert "no-such-scene" in result.stderr and "unknown scene" in result.stderr
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("dt", ["0", "-0.01", "nan", "abc"])
def test_bad_dt_exits_2(tmp_path, dt):
    result = run_cli("run", "boxes", f"--dt={dt}", "--out", str(tmp_path))
    assert result.returncode == 2
    assert "dt must be" in result.stderr


def test_bad_steps_exits_2(tmp_path):
    result = run_cli("run", "boxes", "--steps", "0", "--out", str(tmp_path))
    assert result.returncode == 2
    assert "steps must be" in result.stderr


def test_list_names_every_scene():
    result = run_cli("list")
    assert result.returncode == 0, result.stderr
    for name in scenes.SCENES:
        assert name in result.stdout


@pytest.mark.slow
@pytest.mark.parametrize("scene", sorted(scenes.SCENES))
def test_every_scene_writes_every_output(tmp_path, scene):
    out = tmp_path / "out"
    result = run_cli("run", scene, "--steps", "24", "--stride", "2", "--out", str(out), "--quiet", "--no-plot",
                     "--video", "--fps", "60", "--size", "160x120", "--gltf", "--usd", str(tmp_path / "stage.usda"))
    assert result.returncode == 0, result.stderr
    files = [out / f"{scene}.npz", out / f"{scene}.html", out / f"{scene}.mp4", out / f"{scene}.glb",
             tmp_path / "stage.usda"]
    for path in files:
        assert path.is_file() and path.stat().st_size > 0, path
        assert str(path) in result.stdout, path
    assert not (out / f"{scene}.png").exists()
    assert "%|" not in result.stderr and "it/s" not in result.stderr  # --quiet: no progress bar
    from signorini.trajectory import load_trajectory

    record = load_trajectory(out / f"{scene}.npz")
    assert record.frames == 13 and record.steps == 24 and record.scene == scene


def test_export_writes_from_a_saved_trajectory(tmp_path):
    assert run_cli("run", "boxes", "--steps", "10", "--out", str(tmp_path), "--no-plot", "--no-html").returncode == 0
    assert not (tmp_path / "boxes.html").exists()
    result = run_cli("export", str(tmp_path / "boxes.npz"), "--out", str(tmp_path / "again"), "--gltf")
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "again" / "boxes.glb").is_file() and not (tmp_path / "again" / "boxes.html").exists()
    # with nothing asked, the player next to the trajectory
    result = run_cli("export", str(tmp_path / "boxes.npz"))
    assert result.returncode == 0, result.stderr
    assert str(tmp_path / "boxes.html") in result.stdout and (tmp_path / "boxes.html").is_file()


def test_export_help_says_when_the_player_is_written():
    # a bare `export x.npz` writes the player (test above): the help must say so, not "only when asked"
    from signorini.cli import make_parser

    parser = make_parser()
    export = parser._subparsers._group_actions[0].choices["export"]
    help_text = " ".join(export.format_help().split())
    assert "only when asked" not in help_text
    assert "written when no other output is asked for, or with --html" in help_text
    run = parser._subparsers._group_actions[0].choices["run"]
    assert "no other output" not in " ".join(run.format_help().split())  # run writes it unless --no-html


@pytest.mark.parametrize("command", ["export", "view"])
def test_missing_or_corrupt_trajectory_exits_2_naming_it(tmp_path, command):
    result = run_cli(command, str(tmp_path / "nowhere.npz"))
    assert result.returncode == 2
    assert "nowhere.npz" in result.stderr and "no such trajectory file" in result.stderr
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"PK\x03\x04 this is not a zip archive")
    result = run_cli(command, str(bad))
    assert result.returncode == 2
    assert "bad.npz" in result.stderr and "not" in result.stderr


def test_view_of_an_unknown_name_exits_2():
    result = run_cli("view", "no-such-scene")
    assert result.returncode == 2
    assert "no-such-scene" in result.stderr and "neither a scene" in result.stderr


@pytest.mark.parametrize("args, message", [
    (["--stride", "0"], "stride must be"), (["--stride", "x"], "stride must be"),
    (["--video", "--size", "641x480"], "size must be"), (["--video", "--fps", "0"], "fps must be"),
])
def test_bad_output_options_exit_2(tmp_path, args, message):
    result = run_cli("run", "boxes", "--out", str(tmp_path), *args)
    assert result.returncode == 2
    assert message in result.stderr
    assert not any(tmp_path.iterdir())


@pytest.mark.slow
def test_work_longer_than_a_second_shows_a_progress_bar(tmp_path):
    # 0.5 s of the shapes scene drawn at 240 pictures per second: 121 pictures, a few seconds of
    # rendering, so the video's bar appears (test_every_scene_writes_every_output checks that
    # --quiet hides bars)
    result = run_cli("run", "shapes", "--steps", "120", "--out", str(tmp_path), "--no-plot", "--no-html",
                     "--video", "--fps", "240", "--size", "64x48")
    assert result.returncode == 0, result.stderr
    assert "video shapes.mp4" in result.stderr and "frame" in result.stderr


def test_list_reads_the_scene_files_without_building_any_scene(monkeypatch, capsys):
    from signorini import cli

    def no_building(*args, **kwargs):
        raise AssertionError("list built a scene")

    monkeypatch.setattr(scenes, "build", no_building)
    monkeypatch.setattr(scenes, "GENERATORS", {})
    assert cli.main(["list"]) == 0
    out = capsys.readouterr().out
    for name in scenes.SCENES:
        info = scenes.scene_info(name)
        assert f"{name}" in out and f"{info['bodies']} bodies" in out and info["description"] in out
    assert "rain: 1205 bodies, 1200 steps" in out


@pytest.mark.parametrize("args", [["list"], ["--help"], ["run", "--help"]])
def test_a_closed_pipe_ends_quietly(args):
    # the reader closes its end before anything is written: every write fails with EPIPE
    package_root = str(Path(signorini.__file__).resolve().parent.parent)
    env = dict(os.environ, PYTHONPATH=package_root)
    p = subprocess.Popen([sys.executable, "-m", "signorini", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         env=env)
    p.stdout.close()
    stderr = p.stderr.read().decode()
    assert p.wait(timeout=120) == 0
    assert "Traceback" not in stderr and "BrokenPipeError" not in stderr, stderr


def test_list_piped_into_head_prints_one_line_and_no_traceback():
    package_root = str(Path(signorini.__file__).resolve().parent.parent)
    result = subprocess.run(f"{sys.executable} -m signorini list | head -1", shell=True, capture_output=True, text=True,
                            env=dict(os.environ, PYTHONPATH=package_root), timeout=120)
    assert result.stdout.count("\n") == 1 and result.stderr == ""


@pytest.mark.parametrize("command", ["run", "export", "view", "list"])
def test_every_command_help_shows_an_example(command):
    result = run_cli(command, "--help")
    assert result.returncode == 0
    assert "example" in result.stdout and f"python -m signorini {command}" in result.stdout


def test_run_a_scene_file(tmp_path):
    (tmp_path / "drop.toml").write_text(
        "[scene]\ndescription = 'a ball dropped'\ndt = 0.01\nsteps = 30\n"
        "[[bodies]]\nname = 'ground'\nstatic = true\nshape = { type = 'plane', normal = [0, 0, 1] }\n"
        "[[bodies]]\nname = 'ball'\nshape = { type = 'sphere', radius = 0.1 }\nmass = 1\nposition = [0, 0, 1]\n")
    result = run_cli("run", str(tmp_path / "drop.toml"), "--out", str(tmp_path / "out"), "--no-plot", "--quiet")
    assert result.returncode == 0, result.stderr
    from signorini.trajectory import load_trajectory

    record = load_trajectory(tmp_path / "out" / "drop.npz")
    assert record.steps == 30 and record.scene == "drop"
    assert record.positions[-1, 1, 2] < 1.0          # the ball fell


def test_a_bad_scene_file_exits_2_naming_the_file_and_key(tmp_path):
    (tmp_path / "bad.toml").write_text("[[bodies]]\nshape = { type = 'sphere', radius = 0.1 }\nmass = 1\nspin = 3\n")
    result = run_cli("run", str(tmp_path / "bad.toml"), "--out", str(tmp_path / "out"))
    assert result.returncode == 2
    assert "bad.toml" in result.stderr and "bodies[0].spin" in result.stderr and "Traceback" not in result.stderr
    result = run_cli("run", str(tmp_path / "missing.toml"), "--out", str(tmp_path / "out"))
    assert result.returncode == 2 and "missing.toml" in result.stderr and "does not exist" in result.stderr


def scene_with_meshes(root: Path, *folders: str) -> Path:
    """root/scenes/s.toml: a ground and one mesh ball per folder, each ball's .npz file in
    root/<folder>/ (outside the scene file's folder), 5 steps."""
    from signorini import meshes, meshfile

    text = "[scene]\ndt = 0.01\nsteps = 5\n[[bodies]]\nstatic = true\nshape = { type = 'plane', normal = [0, 0, 1] }\n"
    for k, folder in enumerate(folders):
        (root / folder).mkdir(parents=True)
        meshfile.write_npz_mesh(root / folder / "ball.npz", *meshes.icosphere(0.2, 1))
        text += (f"[[bodies]]\nshape = {{ type = 'mesh', file = '../{folder}/ball.npz' }}\ndensity = 500\n"
                 f"position = [{k}, 0, 1]\n")
    (root / "scenes").mkdir(parents=True)
    (root / "scenes" / "s.toml").write_text(text)
    return root / "scenes" / "s.toml"


def test_run_allow_path_lets_a_scene_read_meshes_from_named_folders(tmp_path):
    scene = scene_with_meshes(tmp_path, "assets", "more")
    out = ["--out", str(tmp_path / "out"), "--no-plot", "--no-html", "--quiet"]
    # without the option: refused, the message naming the file, the key, the rule and the option
    result = run_cli("run", str(scene), *out)
    assert result.returncode == 2, result.stderr
    assert "s.toml" in result.stderr and "bodies[1]" in result.stderr and "outside the folders" in result.stderr
    assert "--allow-path DIR" in result.stderr and "Traceback" not in result.stderr
    assert not (tmp_path / "out" / "s.npz").exists()
    # one folder allowed, the other still refused; relative folders are read from the current one
    result = run_cli("run", str(scene), *out, "--allow-path", "assets", cwd=tmp_path)
    assert result.returncode == 2 and "bodies[2]" in result.stderr and "--allow-path" in result.stderr
    # both: the run loads and writes its trajectory
    result = run_cli("run", str(scene), *out, "--allow-path", "assets", "--allow-path", str(tmp_path / "more"),
                     cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    from signorini.trajectory import load_trajectory

    record = load_trajectory(tmp_path / "out" / "s.npz")
    assert record.num_bodies == 3 and record.steps == 5


def test_allow_path_must_be_a_folder(tmp_path):
    (tmp_path / "file.txt").write_text("")
    for command in ("run", "view"):
        for bad in (tmp_path / "nowhere", tmp_path / "file.txt"):
            result = run_cli(command, "boxes", "--allow-path", str(bad))
            assert result.returncode == 2 and "--allow-path" in result.stderr and "not a folder" in result.stderr


def test_view_allow_path_reaches_the_scene_loader(tmp_path, monkeypatch, capsys):
    """view reads a scene file with the folders of --allow-path (the viewer itself replaced by a
    stand-in that records what it was given); without them it exits 2 before serving."""
    from signorini import cli, viewer

    scene = scene_with_meshes(tmp_path, "assets")
    served = []

    class StandIn:
        def __init__(self, source, **kwargs):
            served.append(source)
            self.port = kwargs["port"]

        def serve_forever(self):
            pass

    monkeypatch.setattr(viewer, "Viewer", StandIn)
    with pytest.raises(SystemExit) as e:
        cli.main(["view", str(scene)])
    assert e.value.code == 2 and "--allow-path" in capsys.readouterr().err and served == []
    assert cli.main(["view", str(scene), "--allow-path", str(tmp_path / "assets")]) == 0
    assert len(served) == 1 and served[0].world.num_bodies == 2


@pytest.mark.parametrize("command", ["run", "view"])
def test_the_help_of_commands_reading_scene_files_names_allow_path(command):
    result = run_cli(command, "--help")
    assert result.returncode == 0 and "--allow-path DIR" in result.stdout and "repeat" in result.stdout
