#!/usr/bin/env bash
# Installs what is missing, builds, and runs every test: C++ with ctest, then Python with pytest
# from .venv against the installed kiji package.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
# Both suites run whatever the first gives; the script fails if either does.
set +e
ctest --test-dir build --output-on-failure -j "$(nproc)"
ctest_rc=$?
# From the repository root: tests/python's conftest is on sys.path, the source tree's python/ is not,
# so the tests import the package installed in .venv.
.venv/bin/python -m pytest -q tests/python "$@"
rc=$?
set -e
if [ "$ctest_rc" -ne 0 ]; then
  echo "kiji test: ctest failed (exit $ctest_rc); pytest exit $rc" >&2
  exit 1
fi
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
