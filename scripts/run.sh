#!/usr/bin/env bash
# README command 1: install what is missing, then run a built-in scene (default: the lecture's
# torus on a tilted plane), writing <out>/<scene>.npz and <out>/<scene>.png and printing a summary.
#   bash scripts/run.sh [SCENE] [OUT_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install.sh
python3 -m signorini run "${1:-torus}" --out "${2:-signorini-out}"
