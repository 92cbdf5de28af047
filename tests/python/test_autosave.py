"""Autosave and recovery: a session killed with kill -9 at any moment loses no operation whose call had
returned, and kiji.recover rebuilds it; one thread at a time uses a session."""
import os
import random
import signal
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import kiji
from conftest import flat_session, line

CHILD = textwrap.dedent("""
    import sys
    import numpy as np
    import kiji
    s = kiji.Session(autosave=sys.argv[1])
    g = s.add_garment(kiji.rectangle(0.6, 0.4, nx=13, ny=9))
    s.solver_params = kiji.SolverParams(gravity=(0, 0, 0))
    k = 0
    while True:
        if k % 4 == 0:
            s.pinch(np.array([[0.05 * (k % 9), 0, 0], [0.05 * (k % 9), 0, 0.05]]))
        elif k % 4 == 1:
            s.step(2)
        elif k % 4 == 2:
            s.simulating = (k % 8 == 2)
        else:
            g.positions = g.positions + 0.001
        print(s.operation_count, flush=True)
        k += 1
""")


def test_autosave_then_recover_gives_the_same_garment(tmp_path):
    path = tmp_path / "work.kiji"
    s = kiji.Session(autosave=path)
    assert s.autosave == str(path)
    g = s.add_garment(kiji.rectangle(0.5, 0.5, nx=6, ny=6))
    s.pinch(line((0, 0, 0), (0, 0, 0.1), 4))
    g.color = (0.1, 0.9, 0.1)
    r = kiji.recover(path, keep_saving=False)
    assert r.recovery["operations"] == s.operation_count and r.recovery["damage"] == ""
    assert np.array_equal(r.garment(0).positions, g.positions)
    assert np.allclose(r.garment(0).color, (0.1, 0.9, 0.1))
    with pytest.raises(kiji.InputError, match="already holds a session"):
        kiji.Session(autosave=path)


def test_kill_nine_at_random_moments_loses_nothing_whose_call_returned(tmp_path):
    rng = random.Random(33)
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    for trial in range(4):
        path = tmp_path / f"killed{trial}.kiji"
        child = subprocess.Popen([sys.executable, str(script), str(path)], stdout=subprocess.PIPE, text=True)
        first = child.stdout.readline()  # the child has started its work
        assert first.strip().isdigit(), first
        time.sleep(rng.uniform(0.05, 0.6))
        os.kill(child.pid, signal.SIGKILL)
        rest, _ = child.communicate()
        assert child.returncode == -signal.SIGKILL
        returned = int(([first] + rest.split())[-1])
        r = kiji.recover(path)
        assert r.recovery["operations"] >= returned, r.recovery
        assert not r.stroke_active
        r.step(1)  # the recovered session goes on, saving into the same file
        assert kiji.recover(path, keep_saving=False).recovery["damage"] == ""


def test_a_second_thread_waits_while_the_session_is_in_use():
    s, g = flat_session(0.5, 0.5, 6, 6)
    started = threading.Event()
    seen = []

    def other():
        started.wait()
        seen.append(s.steps)  # waits for the simulation below to finish: never a step in between
        g.positions = g.positions  # an edit from another thread is an operation like any other

    t = threading.Thread(target=other)
    t.start()
    s.simulate(0.5, progress=lambda f: started.set())
    t.join(timeout=30)
    assert not t.is_alive()
    assert seen == [30]
    assert s.operation_kinds[-1] == "set_garment"
