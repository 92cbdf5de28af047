#!/usr/bin/env bash
# Three `kiji peer` processes share a session over LCM multicast on real sockets, in a private network
# namespace (no root needed; nothing leaves the machine): a host, a peer that joins and watches, and
# a peer that joins last, pulls the cloth off the head and holds it there (a journal's stroke,
# replayed in real time). With a loss
# percentage, nftables drops that share of the session's packets before IP reassembly, as a busy
# LAN would. Passes when all three stop at the same step with the same state hash, the stroke was
# applied, and the cloth moved where it was pulled.
#   usage: peers_over_lcm.sh KIJI_BINARY WORK_DIR LOSS_PERCENT
set -euo pipefail
kiji=$1 work=$2 loss=${3:-0}
here=$(cd "$(dirname "$0")" && pwd)
rm -rf "$work" && mkdir -p "$work"
if ! unshare -rn true 2>/dev/null; then
  echo "peers_over_lcm: cannot make a private network namespace (unshare -rn): this test needs unprivileged" \
       "user namespaces (sysctl kernel.unprivileged_userns_clone=1)" >&2
  exit 1
fi
# Each peer has 60 s of wall clock for the 5 simulated seconds, times KIJI_TEST_SLOWDOWN (a sanitizer
# build's peers step a few times slower).
export KIJI_WORK=$work KIJI_BIN=$kiji KIJI_LOSS=$loss KIJI_REPLAY=$here/pull_corner.json
export KIJI_PEERS_TIMEOUT=$((60 * ${KIJI_TEST_SLOWDOWN:-1}))
# The pull starts when the puller has joined and lasts 2 s: a slower build joins later in the shared
# clock, so its session runs 10 simulated seconds instead of 5, for the whole pull to fit.
export KIJI_PEERS_SECONDS=5
[ "${KIJI_TEST_SLOWDOWN:-1}" = 1 ] || KIJI_PEERS_SECONDS=10
unshare -rn bash -euo pipefail -c '
  ip link set lo up
  ip link set lo mtu 1500
  ip link set lo multicast on
  ip route add 224.0.0.0/4 dev lo
  if [ "$KIJI_LOSS" != 0 ]; then
    nft add table ip kiji_loss
    nft add chain ip kiji_loss prerouting "{ type filter hook prerouting priority -450; }"
    nft add rule ip kiji_loss prerouting udp dport 7667 numgen random mod 100 "<" "$KIJI_LOSS" drop
  fi
  common="--key-file $KIJI_WORK/key --json --seconds $KIJI_PEERS_SECONDS --timeout $KIJI_PEERS_TIMEOUT --out"
  "$KIJI_BIN" peer --host --name host $common "$KIJI_WORK/host.glb" > "$KIJI_WORK/host.json" 2> "$KIJI_WORK/host.err" &
  sleep 0.3
  "$KIJI_BIN" peer --name viewer $common "$KIJI_WORK/viewer.glb" > "$KIJI_WORK/viewer.json" 2> "$KIJI_WORK/viewer.err" &
  sleep 0.3
  "$KIJI_BIN" peer --name puller --replay "$KIJI_REPLAY" $common "$KIJI_WORK/puller.glb" > "$KIJI_WORK/puller.json" 2> "$KIJI_WORK/puller.err" &
  wait
'
python3 - "$work" "$here/pull_corner.json" "$KIJI_PEERS_SECONDS" <<'PY'
import json, os, struct, sys
work = sys.argv[1]
stop = 60 * int(sys.argv[3])
names = ["host", "viewer", "puller"]
runs = {}
for n in names:
    text = open(f"{work}/{n}.json").read().strip()
    if not text:
        sys.exit(f"{n} printed nothing; its errors: {open(f'{work}/{n}.err').read()}")
    runs[n] = json.loads(text)
for n, r in runs.items():
    print(n, {k: r[k] for k in ("steps", "state_hash", "applied", "converged", "agreed_at_stop", "messages_sent",
                                "bytes_sent", "nacks_sent", "resent", "heals", "dropped", "refusals", "error")})
bad = [n for n, r in runs.items() if r["error"] or not r["joined"] or r["steps"] != stop or not r["agreed_at_stop"]]
assert not bad, f"peers that did not end agreeing at step {stop}: {bad}"
hashes = {r["state_hash"] for r in runs.values()}
assert len(hashes) == 1, f"the peers ended with different states: {hashes}"
events = len(json.load(open(sys.argv[2]))["strokes"][0]["events"])
assert runs["puller"]["replayed_events"] == events, "the puller did not send its whole stroke"
assert all(not r["refusals"] and r["divergences"] == 0 for r in runs.values()), {n: r["refusals"] for n, r in runs.items()}

# The helper beside pull_corner.json (tests/peers).
sys.path.insert(0, os.path.dirname(os.path.abspath(sys.argv[2])))
from glb_positions import glb_positions

garments = {n: glb_positions(f"{work}/{n}.glb") for n in names}
assert garments["host"] == garments["viewer"] == garments["puller"], "the written garments differ"
# The pen holds the grabbed cloth 0.6 m to the side of the head: beyond where the cloth started (x <= 0.3).
reach = max(p[0] for p in garments["host"])
assert reach > 0.45, f"the pulled corner reaches x = {reach:.3f} m only"
print(f"three peers agree at step {stop}; the pulled corner reaches x = {reach:.3f} m")
PY
