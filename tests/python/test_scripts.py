"""The install script: the main job (scripts/run.sh) installs the runtime only, the tests
(scripts/test.sh) add the test tools, and both lists are the pyproject's (no drift)."""
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[2]


def bash_array(text: str, name: str) -> set[str]:
    body = re.search(rf"^{name}=\((.*?)\)", text, flags=re.S | re.M).group(1)
    return set(re.findall(r'"([^"]+)"', body))


def names(requirements) -> set[str]:
    return {re.split(r"[<>=; ]", r, maxsplit=1)[0].lower() for r in requirements}


def test_run_installs_the_runtime_and_test_adds_the_test_tools():
    script = (ROOT / "scripts" / "install.sh").read_text()
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    runtime, tests = names(bash_array(script, "runtime")), names(bash_array(script, "tests"))
    build = names(pyproject["build-system"]["requires"])
    # tomli is only for Python < 3.11, which bookworm's 3.11 does not need
    assert runtime == build | names(pyproject["project"]["dependencies"]) - {"tomli"}
    assert tests == names(pyproject["project"]["optional-dependencies"]["test"])
    assert not runtime & {"pytest", "scipy", "playwright", "mujoco", "pybind11-stubgen"}
    assert re.search(r"^bash scripts/install.sh$", (ROOT / "scripts" / "run.sh").read_text(), flags=re.M)
    assert re.search(r"^bash scripts/install.sh --test$", (ROOT / "scripts" / "test.sh").read_text(), flags=re.M)
    # no silent pip: the build shows its progress
    assert "pip install -q" not in script and "-v --no-build-isolation -e ." in script


def installed_check(tree, *calls, env=None):
    """Run install.sh's functions (sourced, so nothing is installed) in ``tree``; returns the exit
    status of each call in order."""
    script = "source scripts/install.sh\n" + "\n".join(f"{c}; echo status=$?" for c in calls)
    result = subprocess.run(["bash", "-c", script], cwd=tree, capture_output=True, text=True, env=env, timeout=120)
    assert result.returncode == 0, result.stderr
    return [int(x) for x in re.findall(r"^status=(\d+)$", result.stdout, flags=re.M)]


@pytest.mark.slow
def test_install_is_skipped_only_when_the_installed_package_matches_the_checkout(tmp_path):
    """install.sh's check (not a pip install): a copy of the checkout whose package python3 imports
    matches once its install is stamped, for that kind of install, until a source changes or python3
    imports another checkout's package.

    The copy's python/signorini is a link to the package this test imports: with PYTHONPATH it is
    the one python3 imports from the copy, and under an editable install (CI's: its import hook
    wins over PYTHONPATH) it is the installed checkout's, so the copy matches either way."""
    import signorini

    package = Path(signorini.__file__).parent
    tree = tmp_path / "checkout"
    skip = shutil.ignore_patterns("__pycache__", "build", ".git", "signorini-out", ".pytest_cache")
    tree.mkdir()
    for part in ("CMakeLists.txt", "pyproject.toml"):
        shutil.copy(ROOT / part, tree / part)
    for part in ("cpp", "bindings", "scripts"):
        shutil.copytree(ROOT / part, tree / part, ignore=skip)
    (tree / "python").mkdir()
    (tree / "python" / "signorini").symlink_to(package, target_is_directory=True)
    env = {**os.environ, "PYTHONPATH": str(tree / "python"), "SIGNORINI_STAMP_DIR": str(tmp_path / "stamps")}

    assert installed_check(tree, "installed_matches runtime", env=env) == [1]          # never installed
    assert installed_check(tree, "write_stamp runtime", "installed_matches runtime", "installed_matches test",
                           env=env) == [0, 0, 1]                                     # a runtime install only
    assert installed_check(tree, "write_stamp test", "installed_matches test", "installed_matches runtime",
                           env=env) == [0, 0, 0]                                     # a test install holds both
    # a changed source (C++ here) installs again
    source = tree / "cpp" / "src" / "world" / "world.cpp"
    source.write_text(source.read_text() + "\n// changed\n")
    assert installed_check(tree, "installed_matches runtime", env=env) == [1]
    assert installed_check(tree, "write_stamp runtime", "installed_matches runtime", env=env) == [0, 0]
    # python3 importing another checkout's package installs again: the copy's package is now a
    # checkout of its own, and python3 imports another (PYTHONPATH's, or the editable install's)
    (tree / "python" / "signorini").unlink()
    shutil.copytree(package, tree / "python" / "signorini", ignore=skip)
    other = {**env, "PYTHONPATH": str(package.parent)}
    assert installed_check(tree, "installed_matches runtime", env=other) == [1]
