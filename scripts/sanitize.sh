#!/usr/bin/env bash
# The sanitizer runs, a second test command beside the README's (docs/testing.md):
#
#   scripts/sanitize.sh            asan below
#   scripts/sanitize.sh asan       AddressSanitizer + UndefinedBehaviorSanitizer (build-asan/, clang-14): the
#                                  whole ctest suite, then a short run of every fuzz target (scripts/fuzz.sh)
#   scripts/sanitize.sh fuzz       only the short run of every fuzz target
#
# Each build (scripts/sanitizer_build.sh) compiles only what its run needs. Any sanitizer report
# fails the run: the builds stop at the first report (-fno-sanitize-recover) and the run exits
# non-zero. KIJI_FUZZ_SECONDS (default 15) is each fuzz target's share of the asan run, 0 skips them.
# Every phase prints its time.
set -euo pipefail
cd "$(dirname "$0")/.."

runs=("$@")
[ ${#runs[@]} -eq 0 ] && runs=(asan)
for run in "${runs[@]}"; do
  case "$run" in
    asan | fuzz) ;;
    *) echo "usage: scripts/sanitize.sh [asan|fuzz]" >&2; exit 2 ;;
  esac
done

packages=(clang-14 libclang-rt-14-dev libfuzzer-14-dev)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "kiji sanitize: installing ${missing[*]}"
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
[ -x .venv/bin/python ] || scripts/setup.sh >/dev/null  # the Debian packages of the main build, and .venv

jobs=$(nproc)
elapsed() { echo "$(( $(date +%s) - $1 )) s"; }
status=0

for run in "${runs[@]}"; do
  start=$(date +%s)
  case "$run" in
    asan | fuzz)
      if [ "$run" = asan ]; then
        scripts/sanitizer_build.sh asan
      else
        scripts/sanitizer_build.sh asan kiji_fuzzers
      fi
      echo "kiji sanitize: asan build $(elapsed "$start")"
      if [ "$run" = asan ]; then
        # A test that leaks is reported at its exit; a report anywhere fails the test.
        t=$(date +%s)
        ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1:detect_stack_use_after_return=1 \
          UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 LSAN_OPTIONS=suppressions=$PWD/tests/sanitizers/lsan.supp \
          ctest --test-dir build-asan --output-on-failure -j "$jobs" || status=1
        echo "kiji sanitize: asan ctest $(elapsed "$t")"
      fi
      if [ "${KIJI_FUZZ_SECONDS:-15}" != 0 ]; then
        t=$(date +%s)
        for target in tests/fuzz/corpus/*/; do
          scripts/fuzz.sh "$(basename "$target")" "${KIJI_FUZZ_SECONDS:-15}" || status=1
        done
        echo "kiji sanitize: fuzz targets $(elapsed "$t")"
      fi
      ;;
  esac
  echo "kiji sanitize: $run done in $(elapsed "$start")"
done
exit "$status"
