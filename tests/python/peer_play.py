"""A design session recorded to a session file and played with lcm-logplayer to a running peer (a
host with a viewer joined), run by test_peer.py inside a private network namespace. Prints what it
saw as JSON on its last line."""
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

import kiji

KEY = "a test session's key, not secret"
STOP = 360  # the shared clock stops here, so that both peers' states can be compared
URL = "udpm://239.255.76.67:7667?ttl=0"
path = os.path.join(tempfile.mkdtemp(), "recorded.kiji")

# The recording: gravity off (so that the cloth is where the recorded pen expects it whenever the
# recording is played), a small square beside the body, and a pinch lifting its corner 0.2 m.
rec = kiji.Session()
params = rec.solver_params
params.gravity = (0.0, 0.0, 0.0)
rec.solver_params = params
square = kiji.rectangle(0.3, 0.3, spacing=0.03)
square.translate((1.0, 1.0, 0.0))
square.name = "played"
rec.add_garment(square)
rec.step(5)
positions = rec.garment(0).positions
corner = positions[np.argmax(positions[:, 0] + positions[:, 2])]
t = rec.time
rec.begin("pinch", kiji.ToolEvent("begin", tuple(corner), time=t))
for i in range(1, 21):
    rec.update(kiji.ToolEvent("move", tuple(corner + (0.0, 0.01 * i, 0.0)), time=t + i / 60))
rec.end(kiji.ToolEvent("end", tuple(corner + (0.0, 0.2, 0.0)), time=t + 21 / 60))
rec.step(10)
rec.save(path)
recorded, _ = kiji.load_session_operations(path)
kinds = [op.kind for op in recorded]

body = kiji.Body.load(kiji.Body.default_path())
host_session = kiji.Session()
host_session.body = body
g = kiji.rectangle(0.4, 0.4, spacing=0.04)
kiji.place_over_body(g, body)
host_session.add_garment(g)
viewer_session = kiji.Session()
out = {"kinds": kinds}
player = os.path.join(os.path.dirname(sys.executable), "lcm-logplayer")

with kiji.Peer(host_session, key=KEY, host=True, name="host", url=URL, stop_step=STOP, play_channel=kiji.SESSION_CHANNEL) as host, \
        kiji.Peer(viewer_session, key=KEY, name="viewer", url=URL) as viewer:
    out["joined"] = viewer.wait_joined(10)
    played = subprocess.run([player, "-l", URL, path], capture_output=True, text=True, timeout=60)
    out["player_rc"] = played.returncode
    want = sum(k not in ("advance", "checkpoint") for k in kinds)
    end = time.time() + 10
    while time.time() < end and host.played[0] + host.played[1] < len(kinds):
        time.sleep(0.05)
    out["played"], out["play_dropped"], out["play_error"] = host.played
    out["want_played"] = want
    # Every played operation applied (nothing of the host's own pending), then the same state on both.
    end = time.time() + 10
    while time.time() < end and (host.pending or viewer.applied < host.applied):
        time.sleep(0.05)
    out["stopped"] = host.wait_step(STOP, 20) and viewer.wait_step(STOP, 20)
    out["converged"] = host.wait_converged(10) and viewer.wait_converged(10)
    out["hashes"] = [host.state_hash(), viewer.state_hash()]
    out["garments"] = [s.garment_count if isinstance(s.garment_count, int) else s.garment_count()
                       for s in (host_session, viewer_session)]
    out["names"] = [host_session.garment(i).name for i in range(out["garments"][0])]
    out["lift"] = float(host_session.garment(out["garments"][0] - 1).positions[:, 1].max() - 1.0)
    out["gravity"] = list(map(float, viewer_session.solver_params.gravity))
print(json.dumps(out))
