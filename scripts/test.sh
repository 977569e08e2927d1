#!/usr/bin/env bash
# README command 2: install what is missing, then run every test: the C++ library on its own
# (GoogleTest under ctest, bindings off), the package's import contracts (import-linter,
# [tool.importlinter] in pyproject.toml) and the Python suite (pytest), with the package as installed
# (the wheel by default; 'bash scripts/test.sh --editable' installs this checkout editable instead).
#   bash scripts/test.sh [--editable | --wheel]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install.sh --test "$@"
cmake -S . -B build/cpp -G Ninja -DCMAKE_BUILD_TYPE=Release -DSIGNORINI_BUILD_TESTS=ON \
  -DSIGNORINI_BUILD_PYTHON=OFF >/dev/null
cmake --build build/cpp
ctest --test-dir build/cpp --output-on-failure
# the import-linter contracts of pyproject.toml, by the interpreter the package is installed in
python3 -c "import sys; from importlinter.cli import lint_imports_command; sys.exit(lint_imports_command())"
# two processes, a test file each at a time (a file's module fixtures are built once): on 2 cores
# the suite takes about half the time of one process; the tests marked slow are in it too
python3 -m pytest -q tests/python -n 2 --dist loadfile
