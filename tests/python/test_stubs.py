"""Type stubs: python/signorini/_core.pyi is what pybind11-stubgen makes of the built module (so
the stubs never drift from the bindings), and the package is marked typed (py.typed)."""
import subprocess
import sys
from pathlib import Path

import pytest

import signorini

PACKAGE = Path(signorini.__file__).resolve().parent


def test_core_stubs_match_the_built_module(tmp_path):
    pytest.importorskip("pybind11_stubgen")
    subprocess.run([sys.executable, "-m", "pybind11_stubgen", "signorini._core", "-o", str(tmp_path)], check=True,
                   capture_output=True, text=True)
    generated = (tmp_path / "signorini" / "_core.pyi").read_text()
    committed = (PACKAGE / "_core.pyi").read_text()
    assert generated == committed, "the bindings changed: run 'bash scripts/stubs.sh' and commit _core.pyi"


def test_stubs_cover_every_public_name_and_the_package_is_typed():
    assert (PACKAGE / "py.typed").is_file()
    stub = (PACKAGE / "_core.pyi").read_text()
    for name in signorini._core.__dict__:
        if not name.startswith("_"):
            assert f"class {name}" in stub or f"def {name}(" in stub, name
