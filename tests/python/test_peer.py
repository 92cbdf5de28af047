"""kiji.Peer on real LCM sockets: two peers in one process, in a private network namespace with
multicast routed on the loopback (unshare -rn: no root, nothing leaves the machine)."""
import json
import os
import subprocess
import sys

import pytest

import kiji

HERE = os.path.dirname(os.path.abspath(__file__))
NAMESPACE = ("ip link set lo up && ip link set lo multicast on && ip route add 224.0.0.0/4 dev lo && "
             "exec \"$0\" \"$1\"")


def run_in_namespace(script):
    if subprocess.run(["unshare", "-rn", "true"]).returncode != 0:
        pytest.fail("cannot make a private network namespace (unshare -rn): enable unprivileged user namespaces")
    r = subprocess.run(["unshare", "-rn", "sh", "-c", NAMESPACE, sys.executable, os.path.join(HERE, script)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_two_peers_design_one_garment_and_a_held_region_is_exclusive():
    out = run_in_namespace("peer_session.py")
    assert out["joined"] and out["ben_garments"] == 1
    assert "shared" in out["step_refused"]
    assert out["ben_stroke_tool"] == "pinch"
    # Ben's pull (his button still down) leased the cloth to him; Ana's pinch there while he held it was refused, with why.
    assert out["ben_applied"] and out["lease_holders"] == [out["ben_id"]]
    assert out["ana_refusals"] and all("held" in r or "lease" in r for r in out["ana_refusals"]), out["ana_refusals"]
    assert out["ben_refusals"] == []
    # Both stopped at the same step with the same cloth, moved where Ben pulled it.
    assert out["stopped"] and out["converged"]
    assert out["hashes"][0] == out["hashes"][1] and out["same_positions"]
    assert out["reach"] > 0.25
    assert out["peers_seen_by_ben"] == ["ana", "ben"] and out["presence_seen_by_ana"] == ["pinch"]
    assert set(out["dropped"]) <= {"own echo"}
    # Closed, the peer's session is its user's own again: it steps on from where the shared clock stopped.
    assert out["steps_after"] == out["stop"] + 1


def test_bad_peer_options_are_refused_and_the_session_stays_usable():
    s = kiji.Session()
    s.add_garment(kiji.rectangle(0.2, 0.2, spacing=0.05))
    with pytest.raises(kiji.Error, match="key"):
        kiji.Peer(s, key="short", host=True)
    with pytest.raises(kiji.Error, match="LCM"):
        kiji.Peer(s, key="k" * 32, host=True, url="nonsense://nowhere")
    s.step()
    assert s.steps == 1


def test_a_recorded_session_played_with_lcm_logplayer_reaches_every_peer():
    out = run_in_namespace("peer_play.py")
    assert out["joined"] and out["player_rc"] == 0
    # Every change of the recording was proposed; its own time passing was left out, saying why.
    assert out["played"] == out["want_played"] and out["want_played"] >= 24, out
    assert out["play_dropped"] == out["kinds"].count("advance") and "recording" in out["play_error"]
    # Both peers have the played square, lifted where the recorded pen lifted it, and agree.
    assert out["garments"] == [2, 2] and out["names"][1] == "played"
    assert out["lift"] > 0.15, out["lift"]
    assert out["gravity"] == [0.0, 0.0, 0.0]
    assert out["stopped"] and out["converged"] and out["hashes"][0] == out["hashes"][1]
