"""The install script: the main job (scripts/run.sh) installs the runtime only, the tests
(scripts/test.sh) add the test tools, and both lists are the pyproject's (no drift)."""
import re
import sys
from pathlib import Path

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
