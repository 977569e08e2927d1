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
        assert data["positions"].shape == (51, n, 3)
        assert data["orientations"].shape == (51, n, 4)
        assert data["velocities"].shape == (51, n, 3)
        assert data["angular_velocities"].shape == (51, n, 3)
        assert data["kinetic_energy"].shape == data["potential_energy"].shape == (51,)
        for name in ("num_contacts", "min_gap", "solver_iterations", "solver_residual", "solver_converged"):
            assert data[name].shape == (50,), name
        assert data["masses"].shape == data["is_static"].shape == (n,)
        np.testing.assert_allclose(data["time"], np.arange(51) * float(data["dt"]), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(data["orientations"], axis=2), 1.0, rtol=1e-9)
        assert np.all(np.isfinite(data["positions"]))

    # the summary names the scene and the files
    assert "boxes" in result.stdout
    assert str(npz) in result.stdout and str(png) in result.stdout


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
