#!/usr/bin/env bash
# README command 1: install what is missing, then run a built-in scene (default: the lecture's
# torus on a tilted plane), writing <out>/<scene>.npz (the trajectory with its scene), <out>/<scene>.png
# and <out>/<scene>.html (the offline player) and printing a summary that names them. Any further
# arguments go to 'python3 -m signorini run' (e.g. --video --gltf --usd).
#   bash scripts/run.sh [SCENE] [OUT_DIR] [OPTIONS...]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install.sh
python3 -m signorini run "${1:-torus}" --out "${2:-signorini-out}" "${@:3}"
