"""The README's Python snippets run as written (in order, in one namespace, as a reader would
paste them), its TOML scene file loads, and every script in examples/ runs and passes the check
it states (each asserts its physical claim)."""
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import signorini
import signorini as sg

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
EXAMPLES = sorted((ROOT / "examples").glob("*.py"))


def blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", README.read_text(), flags=re.S)


def test_readme_python_snippets_run(tmp_path, monkeypatch):
    snippets = blocks("python")
    assert len(snippets) >= 4
    # the snippets write run.npz, ball.stl, drop.toml here and read examples/data/boxes.xml
    shutil.copytree(ROOT / "examples" / "data", tmp_path / "examples" / "data")
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    for k, code in enumerate(snippets):
        try:
            exec(compile(code, f"README.md python block {k + 1}", "exec"), namespace)
        except Exception as e:  # name the block that failed
            raise AssertionError(f"README.md python block {k + 1} fails: {type(e).__name__}: {e}\n{code}") from e
    assert (tmp_path / "run.npz").is_file() and (tmp_path / "drop.toml").is_file()
    assert namespace["w3"].num_bodies == 4 and namespace["d2"].num_bodies == 2


def test_readme_scene_file_loads(tmp_path):
    (toml,) = blocks("toml")
    (tmp_path / "readme.toml").write_text(toml)
    scene = sg.read_scene(tmp_path / "readme.toml")
    assert scene.names == ("ground", "box") and scene.steps == 480
    assert scene.world.restitutions[1] == 0.6 and scene.world.masses[1] == 1000.0


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_runs_and_its_claim_holds(tmp_path, script):
    env = dict(os.environ, PYTHONPATH=str(Path(signorini.__file__).resolve().parent.parent), MPLBACKEND="Agg")
    result = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, cwd=tmp_path, env=env,
                            timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr
    assert result.stdout.strip(), "an example says what it found"


def test_every_example_is_tested():
    assert {p.stem for p in EXAMPLES} >= {"stack", "slope", "bounce", "mesh_file", "scene_file", "mjcf"}
