#!/usr/bin/env bash
# The sanitizer runs, a second test command beside the README's (docs/testing.md):
#
#   scripts/sanitize.sh            asan below
#   scripts/sanitize.sh asan       AddressSanitizer + UndefinedBehaviorSanitizer (build-asan/, clang-14): the
#                                  whole ctest suite, then a short run of every fuzz target (scripts/fuzz.sh)
#   scripts/sanitize.sh asan-short the same build: every test program but the long runs (below), no fuzzing
#   scripts/sanitize.sh fuzz       only the short run of every fuzz target
#   scripts/sanitize.sh tsan       ThreadSanitizer (build-tsan/): the threaded tests with KIJI_THREADS=4
#
# Each build (scripts/sanitizer_build.sh) compiles only what its run needs. Any sanitizer report
# fails the run: the builds stop at the first report (-fno-sanitize-recover) and the run exits
# non-zero. KIJI_FUZZ_SECONDS (default 15) is each fuzz target's share of the asan run, 0 skips them;
# KIJI_FUZZ_SEED fixes the fuzzers' seed.
# Every phase prints its time.
set -euo pipefail
cd "$(dirname "$0")/.."

runs=("$@")
[ ${#runs[@]} -eq 0 ] && runs=(asan)
for run in "${runs[@]}"; do
  case "$run" in
    asan | asan-short | fuzz | tsan) ;;
    *) echo "usage: scripts/sanitize.sh [asan|asan-short|fuzz|tsan]..." >&2; exit 2 ;;
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
    asan | asan-short | fuzz)
      # asan-short: every GoogleTest program but the two whose runs are long under ASan (test_drape's
      # default-body drape alone takes 12 minutes; test_cli runs the drape and the bench), and not the
      # app, the installed tool or the peer processes. Each program's tests carry its name as a label.
      short=()
      for src in tests/core/*/test_*.cpp tests/core/*/*/test_*.cpp tests/plugins/test_*.cpp tests/apps/test_*.cpp; do
        name=$(basename "$src" .cpp)
        case "$name" in test_drape | test_cli) ;; *) short+=("$name") ;; esac
      done
      case "$run" in
        asan) scripts/sanitizer_build.sh asan ;;
        asan-short) scripts/sanitizer_build.sh asan "${short[@]}" ;;
        fuzz) scripts/sanitizer_build.sh asan kiji_fuzzers ;;
      esac
      echo "kiji sanitize: asan build $(elapsed "$start")"
      if [ "$run" != fuzz ]; then
        labels=()
        if [ "$run" = asan-short ]; then
          pattern=$(IFS='|'; echo "${short[*]}")
          labels=(-L "^($pattern)\$")
        fi
        # A test that leaks is reported at its exit; a report anywhere fails the test. No
        # strict_string_checks: Qt's keyboard library (xkbcommon) passes strndup a name with no NUL
        # within its bound, which strndup allows and that check reports. intercept_tls_get_addr=0:
        # clang 14's runtime can misread a plugin's thread-local block and crash LeakSanitizer at exit
        # (docs/testing.md, "LeakSanitizer's tracer").
        t=$(date +%s)
        ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:detect_stack_use_after_return=1:intercept_tls_get_addr=0 \
          UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 LSAN_OPTIONS=suppressions=$PWD/tests/sanitizers/lsan.supp \
          ctest --test-dir build-asan --output-on-failure -j "$jobs" "${labels[@]}" || status=1
        echo "kiji sanitize: asan ctest $(elapsed "$t")"
      fi
      if [ "$run" != asan-short ] && [ "${KIJI_FUZZ_SECONDS:-15}" != 0 ]; then
        t=$(date +%s)
        # KIJI_FUZZ_SEED fixes libFuzzer's seed: the same inputs, in the same order, on every run.
        seed=()
        [ -n "${KIJI_FUZZ_SEED:-}" ] && seed=("-seed=$KIJI_FUZZ_SEED")
        for target in tests/fuzz/corpus/*/; do
          scripts/fuzz.sh "$(basename "$target")" "${KIJI_FUZZ_SECONDS:-15}" "${seed[@]}" || status=1
        done
        echo "kiji sanitize: fuzz targets $(elapsed "$t")"
      fi
      ;;
    tsan)
      # The tests that run Kiji's threads: the worker pool, the haptic loop, the simulation loop,
      # the peer runner, one session shared by two threads through its lock (as the app and Python
      # with the GIL released use it), and the solver, whose steps share their loops with the pool.
      scripts/sanitizer_build.sh tsan test_parallel test_haptics test_simulation_loop test_peer test_session test_solver
      echo "kiji sanitize: tsan build $(elapsed "$start")"
      # The solver's six slowest tests (40-115 s each under ThreadSanitizer, 6 of its 7.5 minutes)
      # are left to the asan run and the ordinary suite: they run the same shared loops as the rest.
      slow_solver=Xpbd.AGridOfEvenSideHangsAsWellAsOneOfOddSide:Xpbd.AHandBringsFineClothAlongWithoutStretchingItAndAFirmOneWins
      slow_solver+=:Xpbd.SelfCollisionHoldsOnAMeshFinerThanTheThickness:Xpbd.NoPullOrBodyMakesTheClothNonFinite
      slow_solver+=:Xpbd.ClothDroppedOnASphereRestsOnItWithoutPenetrating:Xpbd.ACrushedKnotOfClothStepsInBoundedWorkAndSaysSo
      tests=(test_parallel test_haptics test_simulation_loop test_peer
             "test_session --gtest_filter=*TwoThreadsShareOneSessionThroughItsLock*"
             "test_solver --gtest_filter=-$slow_solver")
      for t in "${tests[@]}"; do
        t0=$(date +%s)
        # shellcheck disable=SC2086  # the filter is the test's own argument
        if (cd build-tsan/tests && KIJI_THREADS=4 \
              TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1 suppressions=$PWD/../../tests/sanitizers/tsan.supp" \
              ./$t >"../tsan_${t%% *}.log" 2>&1); then
          echo "kiji sanitize: tsan ${t%% *} passed in $(elapsed "$t0")"
        else
          tail -80 "build-tsan/tsan_${t%% *}.log" >&2
          echo "kiji sanitize: tsan ${t%% *} FAILED (log in build-tsan/tsan_${t%% *}.log)" >&2
          status=1
        fi
      done
      ;;
  esac
  echo "kiji sanitize: $run done in $(elapsed "$start")"
done
exit "$status"
