#!/usr/bin/env bash
# Runs one libFuzzer target for a while:  scripts/fuzz.sh TARGET SECONDS [libFuzzer options...]
#
#   TARGET   fuzz_garment_obj, fuzz_garment_glb, fuzz_body, fuzz_journal, fuzz_png, fuzz_plugin_meta,
#            fuzz_peer, fuzz_session_file, fuzz_operation (tests/fuzz/; its seeds are tests/fuzz/corpus/TARGET/)
#
# Builds the target in build-asan/ (clang-14, AddressSanitizer + UndefinedBehaviorSanitizer) if
# needed, fuzzes from the seeds and what earlier runs found (build-asan/fuzz/corpus/TARGET/, kept
# between runs, never written into the tree), and prints the executions it ran. A crash, a
# sanitizer report, a leak (but see below), an input over the memory limit or a hang of over 10 s is a finding: its
# input is saved as build-asan/fuzz/findings/TARGET/crash-*, and the script exits non-zero.
# Reproduce one with: build-asan/fuzz/TARGET build-asan/fuzz/findings/TARGET/crash-...
set -euo pipefail
cd "$(dirname "$0")/.."

if [ $# -lt 2 ]; then
  echo "usage: scripts/fuzz.sh TARGET SECONDS [libFuzzer options...]" >&2
  echo "targets: $(ls tests/fuzz/corpus | tr '\n' ' ')" >&2
  exit 2
fi
target=$1
seconds=$2
shift 2
seeds=tests/fuzz/corpus/$target
if [ ! -d "$seeds" ]; then
  echo "kiji fuzz: unknown target '$target'; targets: $(ls tests/fuzz/corpus | tr '\n' ' ')" >&2
  exit 2
fi

scripts/sanitizer_build.sh asan "$target" >/dev/null

corpus=build-asan/fuzz/corpus/$target
findings=build-asan/fuzz/findings/$target
mkdir -p "$corpus" "$findings"
log=build-asan/fuzz/$target.log
# Leaks, a report anywhere and undefined behaviour end the input as a finding; an allocation the
# allocator cannot make returns null (operator new throws), as in a real run, instead of aborting.
# libFuzzer brings libstdc++ in ahead of the shared sanitizer runtime, which defines no allocator
# of its own, so the runtime's check of the library order is off.
# The targets that go through assimp do not look for leaks: assimp (5.2) leaks what it has built
# when one of its importers gives up on a file (an FBX cut short, an OBJ face past the end: Kiji
# checks OBJ faces itself first), a few hundred bytes a file, and its frames cannot be told from
# Kiji's (its library has no frame pointers). Kiji's own code on those paths is leak-checked by
# the ctest suite under the same sanitizers.
case "$target" in
  fuzz_garment_obj | fuzz_garment_glb | fuzz_body) leaks=0 ;;
  *) leaks=1 ;;
esac
# intercept_tls_get_addr=0: as in scripts/sanitize.sh (docs/testing.md, "LeakSanitizer's tracer").
export ASAN_OPTIONS=detect_leaks=$leaks:abort_on_error=1:allocator_may_return_null=1:verify_asan_link_order=0:intercept_tls_get_addr=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
started=$SECONDS
set +e
"build-asan/fuzz/$target" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=65536 \
  -print_final_stats=1 -artifact_prefix="$findings/" "$@" "$corpus" "$seeds" >"$log" 2>&1
rc=$?
set -e
# A run that ended on a finding leaves its input folder behind (fuzz_input.h); so does any run of a
# fuzzer no longer alive.
for d in /dev/shm/kiji-fuzz-* "${TMPDIR:-/tmp}"/kiji-fuzz-*; do
  [ -d "$d" ] && ! kill -0 "${d##*-}" 2>/dev/null && rm -rf "$d"
done
runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
if [ "$rc" -ne 0 ]; then
  tail -60 "$log" >&2
  echo "kiji fuzz: $target FOUND A PROBLEM after $runs executions (exit $rc): input in $findings/, log in $log" >&2
  exit 1
fi
# The time it ran: options such as -runs can end it before SECONDS.
echo "kiji fuzz: $target: $runs executions in $((SECONDS - started)) s ($rate a second), no finding; corpus $(ls "$corpus" | wc -l) inputs"
