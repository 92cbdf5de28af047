"""Two kiji.Peer objects sharing a session over LCM multicast, run by test_peer.py inside a private
network namespace. Prints what it saw as JSON on its last line."""
import json
import sys

import numpy as np

import kiji

KEY = "a test session's key, not secret"
STOP = 240

body = kiji.Body.load(kiji.Body.default_path())
ana_session = kiji.Session()
g = kiji.rectangle(0.4, 0.4, spacing=0.04)
kiji.place_over_body(g, body)
ana_session.body = body
ana_session.add_garment(g)
ben_session = kiji.Session()
out = {}

# A lease outlives its user's last event by lease_seconds of the shared clock, which runs on while a
# loaded machine delays Ana's pinch behind Ben's pull: a minute keeps his cloth held until then.
with kiji.Peer(ana_session, key=KEY, host=True, name="ana", stop_step=STOP, lease_seconds=60) as ana, \
        kiji.Peer(ben_session, key=KEY, name="ben", lease_seconds=60) as ben:
    out["joined"] = ben.wait_joined(10)
    out["ben_garments"] = ben_session.garment_count if isinstance(ben_session.garment_count, int) else ben_session.garment_count()
    try:
        ben_session.step()
        out["step_refused"] = ""
    except kiji.Error as e:
        out["step_refused"] = str(e)
    ben.set_presence(pointer=(0.0, 2.0, 0.0), tool="pinch")
    # Ben grabs the cloth on top of the head, pulls it to the side and holds it there, event by event.
    t = ben_session.time + 0.1
    n = 30
    ben_session.begin("pinch", kiji.ToolEvent("begin", (0.0, 2.0, 0.0), time=t, ray=(0, -1, 0)))
    out["ben_stroke_tool"] = ben_session.active_tool()  # his, before its turn comes
    for i in range(1, n + 1):
        ben_session.update(kiji.ToolEvent("move", (0.3 * i / n, 2.0 - 0.1 * i / n, 0.0), time=t + i / 60))
    # Once his pull is applied everywhere, with his button still down: Ana's pinch on the cloth he
    # holds is refused, on every peer alike.
    out["ben_applied"] = ben.wait_converged(10)
    leased = ana.leases()
    out["lease_holders"] = sorted({l["holder"] for l in leased})
    out["ben_id"] = ben.id
    held = ana_session.garment(0).positions[leased[0]["vertices"]].mean(axis=0) if leased else np.zeros(3)
    t = ana_session.time + 0.05
    ana_session.pinch(stroke=[held + (0, 0.3, 0), held + (0, 0.4, 0)], times=[t, t + 0.02], rays=[(0, -1, 0)] * 2)
    out["stopped"] = ana.wait_step(STOP, 20) and ben.wait_step(STOP, 20)
    out["converged"] = ana.wait_converged(20) and ben.wait_converged(20)
    out["hashes"] = [ana.state_hash(), ben.state_hash()]
    out["same_positions"] = bool(np.array_equal(ana_session.garment(0).positions, ben_session.garment(0).positions))
    out["reach"] = float(ben_session.garment(0).positions[:, 0].max())
    out["ana_refusals"] = [r for _, r in ana.refusals()]
    out["ben_refusals"] = [r for _, r in ben.refusals()]
    out["peers_seen_by_ben"] = sorted(p["name"] for p in ben.peers())
    out["presence_seen_by_ana"] = [p["tool"] for p in ana.peers() if p["name"] == "ben"]
    out["dropped"] = ana.stats()["dropped"]
# Closed: the sessions are their users' own again.
ben_session.step()
out["stop"] = STOP
out["steps_after"] = ben_session.steps
print(json.dumps(out))
