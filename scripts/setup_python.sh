#!/usr/bin/env bash
# The Python side of Kiji's set-up: a virtual environment .venv with numpy, pytest and the build
# requirements, then `pip install .` of the kiji package into it (scripts/setup.sh calls this).
#   scripts/setup_python.sh --venv   only create .venv and install its requirements
#   scripts/setup_python.sh          also build and install the kiji package into .venv
# pip builds in build/, the same tree as the C++ build, so a second run rebuilds only what changed.
# (A plain `pip install .` builds in build-python/ instead.)
set -euo pipefail
cd "$(dirname "$0")/.."

venv=.venv
python=${KIJI_PYTHON:-python3}
if [ ! -x "$venv/bin/python" ]; then
  echo "kiji setup: creating the virtual environment $venv with $($python --version 2>&1)"
  "$python" -m venv "$venv"
fi
# lcm: PyPI's wheel carries the C++ library, lcm-gen and a CMake config that the build uses (Debian's
# liblcm is too old and has none of them).
if ! "$venv/bin/python" -c "import numpy, pytest, pybind11, scikit_build_core, lcm" 2>/dev/null; then
  echo "kiji setup: installing numpy, pytest, pybind11, scikit-build-core and lcm into $venv"
  "$venv/bin/python" -m pip install -q --upgrade pip
  "$venv/bin/python" -m pip install -q numpy pytest "pybind11>=2.12" "scikit-build-core>=0.10" "lcm>=1.5.3,<1.6"
fi
[ "${1:-}" = "--venv" ] && exit 0

echo "kiji setup: pip install . (in build/, the C++ build's tree)"
# The C++ build's tree, which setup.sh configured with this venv's Python and pybind11, so libkiji and
# the tools are compiled once. No build isolation: the venv's pybind11 and numpy, at the same paths
# every time, so nothing is reconfigured or rebuilt for nothing.
"$venv/bin/python" -m pip install -q --no-build-isolation --no-deps -C build-dir=build .
