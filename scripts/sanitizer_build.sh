#!/usr/bin/env bash
# Configures and builds a sanitizer build (scripts/sanitize.sh and scripts/fuzz.sh use it):
#
#   scripts/sanitizer_build.sh asan [TARGET...]   build-asan/: AddressSanitizer + UndefinedBehaviorSanitizer
#                                                 and the libFuzzer targets
#   scripts/sanitizer_build.sh tsan [TARGET...]   build-tsan/: ThreadSanitizer
#
# clang-14: asan at -O2 (at -O1 a solver test took 1.5 times the CPU time: Eigen's code is not inlined), tsan at
# -O1 (it runs a few threaded tests, and compiles faster: it is part of CI),
# without the benchmarks (and, under tsan, the Python module); all targets, or the ones named.
set -euo pipefail
cd "$(dirname "$0")/.."
kind=${1:-}
shift || true
case "$kind" in
  # The Python module too: Kiji Studio's console, tested in studio_gui, runs it inside the app.
  asan) dir=build-asan opt=-O2 extra=(-DKIJI_SANITIZE=address,undefined -DKIJI_BUILD_FUZZERS=ON -DKIJI_BUILD_PYTHON=ON) ;;
  tsan) dir=build-tsan opt=-O1 extra=(-DKIJI_SANITIZE=thread) ;;
  *) echo "usage: scripts/sanitizer_build.sh asan|tsan [TARGET...]" >&2; exit 2 ;;
esac
if ! command -v clang++-14 >/dev/null; then
  echo "kiji: clang-14 is missing; run scripts/sanitize.sh, which installs it" >&2
  exit 2
fi
if [ ! -x .venv/bin/python ]; then
  echo "kiji: .venv is missing (it carries LCM); run scripts/setup.sh first" >&2
  exit 2
fi
cmake -S . -B "$dir" -G Ninja -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO=$opt -DCMAKE_C_FLAGS_RELWITHDEBINFO=$opt \
  -DKIJI_BUILD_BENCH=OFF -DKIJI_BUILD_PYTHON=OFF -DPython_EXECUTABLE="$PWD/.venv/bin/python" \
  -Dpybind11_DIR="$(.venv/bin/python -m pybind11 --cmakedir)" "${extra[@]}" >/dev/null
targets=()
for t in "$@"; do targets+=(--target "$t"); done
cmake --build "$dir" -j "$(nproc)" "${targets[@]}"
