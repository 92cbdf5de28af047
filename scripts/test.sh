#!/usr/bin/env bash
# Installs what is missing, builds, and runs every test: C++ with ctest, then Python with pytest
# from .venv against the installed kiji package.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
ctest --test-dir build --output-on-failure -j "$(nproc)"
# Run from tests/python's parent with the source tree's python/ kept off sys.path, so the tests see the
# installed package only.
set +e
.venv/bin/python -m pytest -q tests/python "$@"
rc=$?
set -e
if [ "$rc" -eq 5 ]; then
  # pytest's 5 is "no tests collected": a failure when there are test files to collect.
  if compgen -G "tests/python/test_*.py" >/dev/null; then
    echo "kiji test: pytest collected no tests, but tests/python has test files" >&2
    exit 1
  fi
  echo "kiji test: no Python tests"
  exit 0
fi
exit "$rc"
