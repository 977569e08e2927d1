"""The README's Python snippets run as written: each on its own, as a script in a fresh empty
folder and its own process (a block whose first line is ``# writes here: a, b`` must leave exactly
those names there, any other block nothing), and all in order in one namespace, as a reader would
paste them; its TOML scene file loads, and every script in examples/ runs and passes the check it
states (each asserts its physical claim)."""
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


WRITES = re.compile(r"#\s*writes here:\s*(.+)")


def loopback_only(command: list) -> list:
    """command inside a network namespace of its own with only loopback up, when this test runs as
    root with unshare (as CI does): a local Ray a block starts (sg.sweep) binds and dials 127.0.0.1
    only, never the machine's interface."""
    if os.geteuid() != 0 or shutil.which("unshare") is None:
        return command
    return ["unshare", "-n", "sh", "-c", 'ip link set lo up && exec "$@"', "sh", *command]


def blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", README.read_text(), flags=re.S)


def test_the_readme_blocks_that_write_files_say_so():
    snippets = blocks("python")
    assert len(snippets) >= 5
    assert [i for i, code in enumerate(snippets) if WRITES.match(code.splitlines()[0])] == [8, 9]


@pytest.mark.parametrize("index", range(len(blocks("python"))))
def test_readme_python_block_runs_alone_in_an_empty_folder(index, tmp_path):
    code = blocks("python")[index]
    script = tmp_path / "block.py"
    script.write_text(code)
    folder = tmp_path / "work"
    folder.mkdir()
    env = dict(os.environ, PYTHONPATH=str(Path(signorini.__file__).resolve().parent.parent),
               SIGNORINI_CACHE=str(tmp_path / "cache"))  # any decomposition cached outside the folder
    result = subprocess.run(loopback_only([sys.executable, str(script)]), cwd=folder, env=env, capture_output=True,
                            text=True, timeout=300)
    assert result.returncode == 0, f"README.md python block {index + 1}:\n{code}\n{result.stderr}"
    said = WRITES.match(code.splitlines()[0])
    written = {name.strip() for name in said.group(1).split(",")} if said else set()
    assert set(os.listdir(folder)) == written, f"README.md python block {index + 1} left {sorted(os.listdir(folder))}"


def test_readme_python_snippets_run(tmp_path, monkeypatch):
    snippets = blocks("python")
    assert len(snippets) >= 5
    # the snippets write run.npz, ball.stl, drop.toml, model.xml here
    monkeypatch.chdir(tmp_path)
    # no Ray server from this process (it is not in a network namespace of its own): the sweep
    # block's runs go to local processes
    monkeypatch.setitem(sys.modules, "ray", None)
    namespace: dict = {}
    for k, code in enumerate(snippets):
        try:
            exec(compile(code, f"README.md python block {k + 1}", "exec"), namespace)
        except Exception as e:  # name the block that failed
            raise AssertionError(f"README.md python block {k + 1} fails: {type(e).__name__}: {e}\n{code}") from e
    assert (tmp_path / "run.npz").is_file() and (tmp_path / "drop.toml").is_file()
    assert namespace["w3"].num_bodies == 2 and namespace["d2"].num_bodies == 2


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
