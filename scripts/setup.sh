#!/usr/bin/env bash
# Installs what Kiji needs on Debian 12 (apt packages), builds it into build/, and installs the Python
# package into the virtual environment .venv (scripts/setup_python.sh).
# Safe to run again: it installs only what is missing and rebuilds only what changed.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  build-essential cmake ninja-build pkg-config git
  libeigen3-dev libcgal-dev libbullet-dev libassimp-dev libminizip-dev assimp-testmodels
  libpng-dev zlib1g-dev libgtest-dev nlohmann-json3-dev libglib2.0-dev libsodium-dev
  iproute2 nftables util-linux
  python3 python3-dev python3-venv
  # Kiji Studio, the desktop app (built where Qt 6 is found), and its tests under a virtual X server.
  qt6-base-dev libqt6opengl6-dev libgl-dev xvfb xauth xdotool
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "kiji setup: installing ${missing[*]}"
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

scripts/setup_python.sh --venv
# The Python module is built with the venv's interpreter and pybind11 (PyPI's: Debian's 2.10 crashes
# converting NumPy 2 arrays), so that `pip install .` below finds everything already built.
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DKIJI_BUILD_PYTHON=ON \
  -DPython_EXECUTABLE="$PWD/.venv/bin/python" \
  -Dpybind11_DIR="$(.venv/bin/python -m pybind11 --cmakedir)" \
  -Dlcm_DIR="$(.venv/bin/python -c 'import lcm, os; print(os.path.join(os.path.dirname(os.path.dirname(lcm.__file__)), "lib", "lcm", "cmake"))')" >/dev/null
cmake --build build -j "$(nproc)"
scripts/setup_python.sh
