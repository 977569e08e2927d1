#!/usr/bin/env bash
# Installs what signorini needs on Debian bookworm, as root, skipping what is already there, and the
# package itself (editable, built by scikit-build-core into the cached build/ folder, so a warm
# rebuild only recompiles what changed; the build shows its progress).
#   bash scripts/install.sh           # runtime: what 'python3 -m signorini run' needs (README command 1)
#   bash scripts/install.sh --test    # and the test tools: GoogleTest, Chromium, pytest, pytest-xdist,
#                                     # scipy, playwright, mujoco, pybind11-stubgen, import-linter, pybullet
#                                     # (its pybullet_data meshes) (README command 2)
# Runtime: the compiler, CMake, ninja, Eigen 3.4, FCL 0.7 and libccd, Qhull (Debian packages), the
# Python build tools and the pyproject dependencies. Test: GoogleTest and Chromium (the browser
# tests open the HTML player in it, headless; playwright drives it, so no browser download) and
# the pyproject 'test' extra.
# Skipped in a second or so when nothing changed: an install records a hash of the sources it was
# built from (the C++ core, the bindings, the package, the build files and this script's lists) and
# the python3 it went into in build/install-stamp-<runtime|test>; when the hash and python3 match
# and that python3 imports this checkout's signorini with its compiled core, nothing is done.
# SIGNORINI_REINSTALL=1 installs anyway (e.g. after uninstalling a dependency by hand).

# the hash of the sources an install is built from, run from the repository root
source_hash() {
  find CMakeLists.txt pyproject.toml cpp bindings python/signorini scripts/install.sh -type f \
      ! -name '*.so' ! -name '*.pyc' ! -path '*/__pycache__/*' -print0 \
    | LC_ALL=C sort -z | xargs -0 sha256sum | sha256sum | cut -d' ' -f1
}
# what a stamp holds: the sources' hash and the python3 installed into
stamp_text() { echo "$(source_hash) $(command -v python3)"; }
stamp_path() { echo "${SIGNORINI_STAMP_DIR:-build}/install-stamp-$1"; }   # $1: runtime | test
# true when an install of kind $1 (runtime | test) was made from these sources into this python3,
# and python3 imports this checkout's package and its compiled core
installed_matches() {
  local stamp
  stamp=$(stamp_path "$1")
  [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$(stamp_text)" ] || return 1
  python3 -c 'import os, sys, signorini, signorini._core
sys.exit(os.path.realpath(signorini.__file__) != os.path.realpath("python/signorini/__init__.py"))' 2>/dev/null
}
# records a finished install of kind $1 (a test install holds the runtime too)
write_stamp() {
  mkdir -p "$(dirname "$(stamp_path "$1")")"
  stamp_text > "$(stamp_path "$1")"
  [ "$1" = test ] && stamp_text > "$(stamp_path runtime)"
  return 0
}
# sourced (tests/python/test_scripts.py): the functions only
[[ "${BASH_SOURCE[0]}" == "$0" ]] || return 0

set -euo pipefail
cd "$(dirname "$0")/.."

with_tests=0
case "${1:-}" in
  --test) with_tests=1 ;;
  "") ;;
  *) echo "usage: bash scripts/install.sh [--test]" >&2; exit 2 ;;
esac
kind=$([ "$with_tests" = 1 ] && echo test || echo runtime)
if [ "${SIGNORINI_REINSTALL:-0}" != 1 ] && installed_matches "$kind"; then
  echo "signorini: installed and matching this checkout ($(stamp_path "$kind")); nothing to install" \
       "(SIGNORINI_REINSTALL=1 installs anyway)"
  exit 0
fi

packages=(g++ cmake ninja-build pkg-config libeigen3-dev libfcl-dev libccd-dev libqhull-dev libtbb-dev)
[ "$with_tests" = 1 ] && packages+=(libgtest-dev chromium)
python3 -m pip --version >/dev/null 2>&1 || packages+=(python3-pip)
# the extension compiles against Python.h
python3 -c 'import os, sysconfig; raise SystemExit(not os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")))' \
  || packages+=(python3-dev)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "signorini: installing Debian packages: ${missing[*]}"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}"
fi

# a Debian system Python marks itself externally managed; this project installs into it on purpose
export PIP_BREAK_SYSTEM_PACKAGES=1 PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_ROOT_USER_ACTION=ignore
# pybind11 and pybind11-stubgen pinned: the committed stubs are what these two versions write
runtime=("scikit-build-core>=0.10" "pybind11==3.1.0" "numpy>=1.22" "matplotlib>=3.6" "tqdm>=4.60" "coacd>=1.0"
         "pythreejs>=2.4" "pillow>=9" "imageio>=2.20" "imageio-ffmpeg>=0.4.8" "pygltflib>=1.15" "usd-core>=23.0"
         "viser>=1.0" "trimesh>=4" "networkx>=2.6" "pydantic>=2" "tomli-w>=1")
tests=("pytest>=7" "pytest-xdist>=3" "scipy>=1.8" "playwright>=1.40" "mujoco>=3" "pybind11-stubgen==3.0.0"
       "import-linter>=2.17" "pybullet>=3.2.6")
# runs a command showing only its lines that match a pattern; its exit status is the command's (pipefail)
show() { local pattern=$1; shift; "$@" 2>&1 | { grep --line-buffered -E "$pattern" || true; }; }

[ "$with_tests" = 1 ] || tests=()
echo "signorini: Python dependencies (runtime$([ "$with_tests" = 1 ] && echo ' and test'))"
# what pip downloads and installs, not the 'already satisfied' lines
show '^(Collecting|Downloading|Installing|Successfully|ERROR|error)' \
  python3 -m pip install "${runtime[@]}" "${tests[@]}"
# the build shows CMake's configure lines and ninja's [k/n] progress (pip -v passes them through)
echo "signorini: building the C++ core and the bindings (cached in build/)"
show '^\s*\[[0-9]+/[0-9]+\]|^-- (Configuring done|Build files)|^\*\*\*|[Ee]rror|Successfully installed' \
  python3 -m pip install -v --no-build-isolation -e .
python3 -c "import signorini._core" || { echo "signorini: the build failed; run 'python3 -m pip install -v --no-build-isolation -e .' to see why" >&2; exit 1; }
write_stamp "$kind"
