#!/usr/bin/env bash
# Installs what signorini needs on Debian bookworm, as root, skipping what is already there, and the
# package itself: a wheel built by scikit-build-core once per state of the sources and kept in
# build/wheels/<source hash>/<python>/ (a second install of the same sources reinstalls that wheel,
# no build), compiled in the cached build/<wheel tag>/ folder, so changed sources recompile only what
# changed (the build shows ninja's progress).
#   bash scripts/install.sh           # runtime: what 'python3 -m signorini run' needs (README command 1)
#   bash scripts/install.sh --test    # and the test tools: GoogleTest, Chromium, pytest, pytest-xdist,
#                                     # scipy, playwright, mujoco, pybind11-stubgen, import-linter, pybullet
#                                     # (its pybullet_data meshes), Ray (the sweep tests start a local head) (README command 2)
#   bash scripts/install.sh [--test] --editable   # for developers: an editable install instead (edits
#                                     # to python/signorini show without reinstalling); this checkout
#                                     # keeps it (run.sh and test.sh too) until --wheel switches back
# Runtime: the compiler, CMake, ninja, Eigen 3.4, FCL 0.7 and libccd, Qhull (Debian packages), the
# Python build tools and the pyproject dependencies. Test: GoogleTest and Chromium (the browser
# tests open the HTML player in it, headless; playwright drives it, so no browser download) and
# the pyproject 'test' extra.
# Skipped in a second or so when nothing changed: an install records a hash of the sources it was
# built from (the C++ core, the bindings, the package, the build files and this script's lists),
# the python3 it went into and its mode (wheel or editable) in build/install-stamp-<runtime|test>;
# when these match and that python3 imports this install's signorini with its compiled core (the
# package of the cached wheel, or this checkout's for an editable install), nothing is done.
# SIGNORINI_REINSTALL=1 installs anyway (e.g. after uninstalling a dependency by hand).

# the hash of the sources an install is built from, run from the repository root
source_hash() {
  find CMakeLists.txt pyproject.toml cpp bindings python/signorini scripts/install.sh -type f \
      ! -name '*.so' ! -name '*.pyc' ! -path '*/__pycache__/*' -print0 \
    | LC_ALL=C sort -z | xargs -0 sha256sum | sha256sum | cut -d' ' -f1
}
# what a stamp holds: the sources' hash, the python3 installed into and the mode ($1: wheel | editable)
stamp_text() { echo "$(source_hash) $(command -v python3) $1"; }
stamp_path() { echo "${SIGNORINI_STAMP_DIR:-build}/install-stamp-$1"; }   # $1: runtime | test
# the mode of this checkout's install (wheel | editable): the last one asked for, else wheel
mode_path() { echo "${SIGNORINI_STAMP_DIR:-build}/install-mode"; }
recorded_mode() { cat "$(mode_path)" 2>/dev/null || echo wheel; }
# the folder of the wheel of the sources of hash $1 for this python3: <wheels>/<hash>/<SOABI>
wheel_dir() {
  echo "${SIGNORINI_WHEEL_DIR:-build/wheels}/$1/$(python3 -c 'import sysconfig; print(sysconfig.get_config_var("SOABI") or "py3")')"
}
# the wheel in folder $1, if one is there
wheel_in() { { compgen -G "$1/signorini-*.whl" || true; } | head -n 1; }
# true when python3 imports signorini, with its compiled core, from the install of mode $1 (wheel |
# editable) of these sources: the package pip installed from the cached wheel (pip records the
# wheel's path in direct_url.json), or this checkout's python/signorini
imports_install() {
  if [ "$1" = editable ]; then
    python3 -c 'import os, sys, signorini, signorini._core
sys.exit(os.path.realpath(signorini.__file__) != os.path.realpath("python/signorini/__init__.py"))' 2>/dev/null
  else
    local wheel
    wheel=$(wheel_in "$(wheel_dir "$(source_hash)")")
    [ -n "$wheel" ] || return 1
    python3 -c 'import json, os, sys, pathlib, signorini, signorini._core
from importlib import metadata
dist = metadata.distribution("signorini")
url = json.loads(dist.read_text("direct_url.json") or "{}").get("url")
ours = os.path.realpath(signorini.__file__) == os.path.realpath(dist.locate_file("signorini/__init__.py"))
sys.exit(not (ours and url == pathlib.Path(sys.argv[1]).resolve().as_uri()))' "$wheel" 2>/dev/null
  fi
}
# true when an install of kind $1 (runtime | test) and mode $2 (wheel | editable) was made from
# these sources into this python3, and python3 imports it
installed_matches() {
  local stamp
  stamp=$(stamp_path "$1")
  [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$(stamp_text "$2")" ] || return 1
  imports_install "$2"
}
# records a finished install of kind $1 and mode $2 (a test install holds the runtime too)
write_stamp() {
  mkdir -p "$(dirname "$(stamp_path "$1")")"
  stamp_text "$2" > "$(stamp_path "$1")"
  [ "$1" = test ] && stamp_text "$2" > "$(stamp_path runtime)"
  echo "$2" > "$(mode_path)"
}
# runs a command showing only its lines that match a pattern; its exit status is the command's (pipefail)
show() { local pattern=$1; shift; "$@" 2>&1 | { grep --line-buffered -E "$pattern" || true; }; }
# prints the path of the wheel of these sources for this python3, building it first unless it is
# cached (scikit-build-core compiles in build/<wheel tag>, only what changed; the wheel is written
# to a temporary folder and moved into place whole, so a failed build leaves no wheel behind).
# Keeps the wheels of the 3 latest source states.
ensure_wheel() {
  local dir wheel
  dir=$(wheel_dir "$(source_hash)")
  wheel=$(wheel_in "$dir")
  if [ -n "$wheel" ]; then
    echo "signorini: reusing the wheel built from these sources, $wheel (no build)" >&2
  else
    echo "signorini: building the wheel: the C++ core and the bindings (compiled in build/, only what changed)" >&2
    rm -rf "$dir.partial" && mkdir -p "$dir.partial"
    # CMake's configure lines and ninja's [k/n] progress (pip -v passes them through)
    show '^\s*\[[0-9]+/[0-9]+\]|^-- (Configuring done|Build files)|^\*\*\*|[Ee]rror|Saved ' \
      python3 -m pip wheel -v --no-build-isolation --no-deps -w "$dir.partial" . >&2
    [ -n "$(wheel_in "$dir.partial")" ] || {
      echo "signorini: the wheel build failed; 'python3 -m pip wheel -v --no-build-isolation --no-deps .' shows why" >&2
      return 1
    }
    rm -rf "$dir" && mv "$dir.partial" "$dir"
    wheel=$(wheel_in "$dir")
    ls -1dt "$(dirname "$(dirname "$dir")")"/*/ | tail -n +4 | xargs -r rm -rf
  fi
  echo "$wheel"
}
# sourced (tests/python/test_scripts.py): the functions only
[[ "${BASH_SOURCE[0]}" == "$0" ]] || return 0

set -euo pipefail
cd "$(dirname "$0")/.."

with_tests=0 mode=
for arg in "$@"; do
  case "$arg" in
    --test) with_tests=1 ;;
    --editable) mode=editable ;;
    --wheel) mode=wheel ;;
    *) echo "usage: bash scripts/install.sh [--test] [--editable | --wheel]" >&2; exit 2 ;;
  esac
done
mode=${mode:-$(recorded_mode)}
kind=$([ "$with_tests" = 1 ] && echo test || echo runtime)
if [ "${SIGNORINI_REINSTALL:-0}" != 1 ] && installed_matches "$kind" "$mode"; then
  echo "signorini: installed ($mode) and matching this checkout ($(stamp_path "$kind")); nothing to install" \
       "(SIGNORINI_REINSTALL=1 installs anyway)"
  exit 0
fi

packages=(g++ cmake ninja-build pkg-config libeigen3-dev libfcl-dev libccd-dev libqhull-dev libtbb-dev libxsimd-dev)
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
         "viser>=1.0" "trimesh>=4" "networkx>=2.6" "pydantic>=2" "tomli-w>=1" "pandas>=1.5" "pyarrow>=12")
tests=("pytest>=7" "pytest-xdist>=3" "scipy>=1.8" "playwright>=1.40" "mujoco>=3" "pybind11-stubgen==3.0.0"
       "import-linter>=2.17" "pybullet>=3.2.6" "ray>=2.9" "yourdfpy>=0.0.56")

[ "$with_tests" = 1 ] || tests=()
echo "signorini: Python dependencies (runtime$([ "$with_tests" = 1 ] && echo ' and test'))"
# what pip downloads and installs, not the 'already satisfied' lines
show '^(Collecting|Downloading|Installing|Successfully|ERROR|error)' \
  python3 -m pip install "${runtime[@]}" "${tests[@]}"
if [ "$mode" = editable ]; then
  # the build shows CMake's configure lines and ninja's [k/n] progress (pip -v passes them through)
  echo "signorini: building the C++ core and the bindings (cached in build/), installed editable"
  show '^\s*\[[0-9]+/[0-9]+\]|^-- (Configuring done|Build files)|^\*\*\*|[Ee]rror|Successfully installed' \
    python3 -m pip install -v --no-build-isolation -e .
else
  wheel=$(ensure_wheel)
  show '^(Successfully|ERROR|error)' python3 -m pip install --no-deps --force-reinstall "$wheel"
fi
imports_install "$mode" || {
  echo "signorini: python3 does not import the package just installed ($mode): is PYTHONPATH set, or did the" \
       "build fail? 'python3 -c \"import signorini, signorini._core; print(signorini.__file__)\"' shows which it imports" >&2
  exit 1
}
write_stamp "$kind" "$mode"
