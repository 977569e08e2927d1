"""The package's layers: the import-linter contracts of pyproject.toml hold, and what import-linter
cannot see is checked here from the source: the compiled core (grimp reads .py files only, so
`from . import _core` shows as an import of the package itself), and private names."""
import ast
import os
import sys
import subprocess
from pathlib import Path

import pytest

import signorini

PACKAGE = Path(signorini.__file__).resolve().parent
ROOT = Path(__file__).resolve().parents[2]
SUBMODULES = {p.stem for p in PACKAGE.glob("*.py")} | {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").exists()}


def package_files():
    return sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)


def imports(path: Path):
    """(node, absolute module imported or None, names) of every import in a file."""
    package = ".".join(("signorini",) + path.relative_to(PACKAGE).with_suffix("").parts[:-1])
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node, alias.name, []
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module
            yield node, module, [alias.name for alias in node.names]


LINT_IMPORTS = "import sys; from importlinter.cli import lint_imports_command; sys.exit(lint_imports_command())"


def test_import_contracts_hold():
    # import-linter is a test dependency (install.sh --test); run by this interpreter, as test.sh does
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(PACKAGE.parent), os.environ.get("PYTHONPATH", "")]))
    run = subprocess.run([sys.executable, "-c", LINT_IMPORTS, "--no-cache"], cwd=ROOT, env=env, capture_output=True,
                         text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "4 kept, 0 broken" in run.stdout


def test_the_oracle_imports_nothing_of_the_package_not_even_the_core():
    for path in sorted((PACKAGE / "oracle").glob("*.py")):
        for node, module, _ in imports(path):
            if module and module.split(".")[0] == "signorini":
                assert module.startswith("signorini.oracle"), f"{path.name}:{node.lineno} imports {module}"


def test_modules_import_the_package_itself_only_for_the_core():
    # import-linter ignores module -> package imports (they stand for _core); nothing else may be one
    for path in package_files():
        if path.name == "__init__.py" or "oracle" in path.parts:
            continue
        for node, module, names in imports(path):
            if module == "signorini":
                for name in names or ["(the package)"]:
                    assert name == "_core" or name in SUBMODULES, \
                        f"{path.name}:{node.lineno} imports {name} from the package instead of its module"


def test_no_private_name_crosses_a_module():
    for path in package_files():
        tree_modules = set()  # local names bound to package modules (from . import render)
        for node, module, names in imports(path):
            if not module or module.split(".")[0] != "signorini":
                continue
            for name in names:
                private = name.startswith("_") and not name.startswith("__")
                assert not private or (name == "_core" and module == "signorini"), \
                    f"{path.name}:{node.lineno} imports the private {name} from {module}"
            if isinstance(node, ast.ImportFrom):
                tree_modules |= {a.asname or a.name for a in node.names if a.name in SUBMODULES}
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in tree_modules:
                private = node.attr.startswith("_") and not node.attr.startswith("__")
                assert not private, f"{path.name}:{node.lineno} reads {node.value.id}.{node.attr}"


def test_only_compare_imports_the_oracle():
    for path in package_files():
        if path.name == "compare.py" or "oracle" in path.parts:
            continue
        for node, module, names in imports(path):
            hit = (module or "").startswith("signorini.oracle") or (module == "signorini" and "oracle" in names)
            assert not hit, f"{path.name}:{node.lineno} imports the oracle"
