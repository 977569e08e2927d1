#!/usr/bin/env bash
# Installs what signorini needs on Debian bookworm, as root, skipping what is already there:
# the compiler, CMake, ninja, Eigen 3.4, FCL 0.7 and libccd, Qhull, GoogleTest and Chromium (the
# browser tests open the HTML player in it, headless) (Debian packages), then the Python build tools,
# the runtime and test dependencies and the package itself (editable, built by scikit-build-core
# into the cached build/ folder, so a warm rebuild only recompiles what changed).
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(g++ cmake ninja-build pkg-config libeigen3-dev libfcl-dev libccd-dev libqhull-dev libgtest-dev chromium)
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
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
fi

# a Debian system Python marks itself externally managed; this project installs into it on purpose
export PIP_BREAK_SYSTEM_PACKAGES=1 PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_ROOT_USER_ACTION=ignore
# runtime (pyproject dependencies), then test-only (the test extra); playwright drives Debian's
# chromium, so no 'playwright install' browser download
python3 -m pip install -q "scikit-build-core>=0.10" "pybind11>=2.12" "numpy>=1.22" "matplotlib>=3.6" "tqdm>=4.60" \
  "coacd>=1.0" "pythreejs>=2.4" "pillow>=9" "imageio>=2.20" "imageio-ffmpeg>=0.4.8" "pygltflib>=1.15" \
  "usd-core>=23.0" "viser>=1.0" \
  "pytest>=7" "scipy>=1.8" "playwright>=1.40" "trimesh>=4"
python3 -m pip install -q --no-build-isolation -e .
