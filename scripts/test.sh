#!/usr/bin/env bash
# README command 2: install what is missing, then run every test: the C++ library on its own
# (GoogleTest under ctest, bindings off), the package's import contracts (import-linter,
# [tool.importlinter] in pyproject.toml) and the Python suite (pytest).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install.sh --test
cmake -S . -B build/cpp -G Ninja -DCMAKE_BUILD_TYPE=Release -DSIGNORINI_BUILD_TESTS=ON \
  -DSIGNORINI_BUILD_PYTHON=OFF >/dev/null
cmake --build build/cpp
ctest --test-dir build/cpp --output-on-failure
lint-imports
python3 -m pytest -q tests/python
