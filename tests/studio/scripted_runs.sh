#!/usr/bin/env bash
# kiji-studio as a script runs it: each case runs the app (on a virtual X server), checks its exit
# status, what it said and what it wrote. Arguments: the app, the picture comparer, the data
# folder, a scratch folder, the stand-in HD library, xvfb-run.
set -u
studio=$1 compare=$2 data=$3 tmp=$4 standin=$5 xvfb_run=$6
mkdir -p "$tmp"
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
# Runs the app; its exit status in $rc, what it printed in $tmp/out.txt. xvfb-run is given an
# authority file of ours (-f), so that it makes no temporary folder of its own: now and then it could
# not remove that folder and exited 5 in place of the app's status (docs/testing.md).
run() {
  "$xvfb_run" -a -f "$tmp/Xauthority" -s "-screen 0 1600x1200x24" "$studio" "$@" >"$tmp/out.txt" 2>&1
  rc=$?
}
said() { grep -q -- "$1" "$tmp/out.txt" || { fail "expected '$1' in:"; cat "$tmp/out.txt"; }; }

echo "1. a malformed option: exit 2 before any window, naming it"
"$studio" --garment rect:1,x,0.1 >"$tmp/out.txt" 2>&1; rc=$?
[ $rc -eq 2 ] || fail "exit $rc, not 2"
said "option --garment"

echo "2. a broken body file: a message, exit 1"
printf 'v 0 0 0\nv 1 0\nf 1 2 7\nnot an obj file\n' >"$tmp/broken.obj"
run --body "$tmp/broken.obj" --garment rect:1,1,0.1 --quit-after 0.5
[ $rc -eq 1 ] || fail "exit $rc, not 1"
said "The body was not opened"

echo "3. a Phantom whose library is missing: the mouse instead, with the reason, exit 0"
KIJI_HD_LIBRARY="$tmp/no-such/libHD.so" run --garment rect:1,1,0.1 --device phantom --quit-after 0.5
[ $rc -eq 0 ] || fail "exit $rc, not 0"
said "the mouse is used instead"
said "HD library could not be opened"

echo "4. a Phantom that fails to initialise: the HD error code and string, exit 0"
KIJI_HD_LIBRARY="$standin" KIJI_HD_STANDIN_FAIL=init run --garment rect:1,1,0.1 --device phantom --quit-after 0.5
[ $rc -eq 0 ] || fail "exit $rc, not 0"
said "HD_DEVICE_FAULT (0x0300)"

echo "5. the stand-in Phantom presses and pulls: a pinch stroke in the journal"
printf '0 0 0 0 0\n0.3 0 0 0 1\n0.8 0 20 30 1\n1.0 0 20 30 0\n' >"$tmp/pen.path"
KIJI_HD_LIBRARY="$standin" KIJI_HD_STANDIN_PATH="$tmp/pen.path" \
  run --garment rect:1,1,0.05 --device phantom --tool pinch --quit-after 2 --save-journal "$tmp/phantom.journal"
[ $rc -eq 0 ] || { fail "exit $rc, not 0"; cat "$tmp/out.txt"; }
grep -q '"tool": "pinch"' "$tmp/phantom.journal" 2>/dev/null || fail "no pinch stroke in the journal"

echo "6. a replayed session: the screenshot matches the reference, the journal and garment are written"
run --garment rect:1,1,0.05 --device none --paused --edges all --window 1280x800 \
  --replay "$data/cut_and_paint.journal" --quit-after 1 --screenshot "$tmp/replay.png" \
  --save-journal "$tmp/replayed.journal" --export "$tmp/replayed.glb"
[ $rc -eq 0 ] || { fail "exit $rc, not 0"; cat "$tmp/out.txt"; }
[ "$(grep -c '"phase": "begin"' "$tmp/replayed.journal" 2>/dev/null)" = 2 ] || fail "the replayed journal does not have its 2 strokes"
[ -s "$tmp/replayed.glb" ] || fail "no garment exported"
"$compare" "$tmp/replay.png" "$data/replay_reference.png" || fail "the screenshot differs from data/replay_reference.png"

echo "7. a replay of a journal that names a tool this app lacks: a message, exit 1"
sed 's/"tool": "cut"/"tool": "scissors"/' "$data/cut_and_paint.journal" >"$tmp/unknown_tool.journal"
run --garment rect:1,1,0.05 --device none --replay "$tmp/unknown_tool.journal" --quit-after 0.5
[ $rc -eq 1 ] || fail "exit $rc, not 1"
said "scissors"

echo "8. a journal the app saved replays every time, on a busy machine: each replay the same garment"
# The journal of case 5: a pinch stroke of the stand-in pen, made on the app's real-time clock.
first_step=$(grep -m1 -o '"step": [0-9]*' "$tmp/phantom.journal" 2>/dev/null | grep -o '[0-9]*$')
[ "$first_step" = 0 ] || fail "the app's first operation came at step '$first_step', not 0: the clock ran before the scene"
busy=()
for _ in 1 2; do
  ( while :; do :; done ) &
  busy+=($!)
done
for i in $(seq 1 10); do
  run --device none --paused --replay "$tmp/phantom.journal" --quit-after 0.3 --export "$tmp/replayed_$i.glb"
  [ $rc -eq 0 ] || { fail "replay $i: exit $rc"; cat "$tmp/out.txt"; }
  cmp -s "$tmp/replayed_1.glb" "$tmp/replayed_$i.glb" || fail "replay $i gave another garment than replay 1"
done
kill "${busy[@]}"
wait "${busy[@]}" 2>/dev/null

if [ $failures -gt 0 ]; then
  echo "$failures case(s) failed"
  exit 1
fi
echo "all cases passed"
