#!/usr/bin/env bash
# Writes the type stubs of the compiled module, python/signorini/_core.pyi, with pybind11-stubgen
# (run after changing the bindings; tests/python/test_stubs.py fails while they differ).
set -euo pipefail
cd "$(dirname "$0")/.."
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
python3 -m pybind11_stubgen signorini._core -o "$out"
cp "$out/signorini/_core.pyi" python/signorini/_core.pyi
echo "written      python/signorini/_core.pyi"
