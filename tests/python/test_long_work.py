"""Long work releases the GIL, reports progress, and stops on Ctrl-C (KeyboardInterrupt)."""
import os
import signal
import threading

import numpy as np
import pytest

import kiji
from conftest import flat_session, line


@pytest.fixture
def ctrl_c():
    """Ctrl-C raises KeyboardInterrupt, as at a terminal, even where the tests were started with
    SIGINT ignored (in the background of a shell script, or under nohup), where Python leaves it
    ignored and nothing could interrupt."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    if previous is not None:  # None: a handler set outside Python, which cannot be put back from here
        signal.signal(signal.SIGINT, previous)


def test_simulate_reports_progress_and_stops_when_told():
    s, g = flat_session(0.5, 0.5, 11, 11)
    seen = []
    s.simulate(0.5, progress=seen.append)
    assert len(seen) == 30 and seen[-1] == pytest.approx(1.0)
    s.simulate(1.0, progress=lambda f: f < 0.25)
    assert s.time == pytest.approx(0.5 + 0.25, abs=1 / 60 + 1e-9)


def test_ctrl_c_interrupts_a_simulation(ctrl_c):
    s, g = flat_session(0.5, 0.5, 11, 11)
    with pytest.raises(KeyboardInterrupt):
        s.simulate(100.0, progress=lambda f: os.kill(os.getpid(), signal.SIGINT))
    assert s.time < 1.0 and g.is_valid()


def test_ctrl_c_during_a_stroke_or_replay_leaves_nothing_half_applied(ctrl_c, tmp_path):
    s, g = flat_session(1.0, 1.0, 11, 11)
    before = g.positions
    with pytest.raises(KeyboardInterrupt):
        s.pinch(line((0.5, 0.5, 0), (0.5, 0.5, 0.3), 30), mode="whole",
                progress=lambda f: os.kill(os.getpid(), signal.SIGINT) if f > 0.5 else None)
    assert not s.stroke_active and s.journal == []
    assert np.array_equal(g.positions, before)
    s.pinch(line((0.5, 0.5, 0), (0.5, 0.5, 0.3), 30), mode="whole")
    path = str(tmp_path / "j.json")
    s.save_journal(path)
    fresh, h = flat_session(1.0, 1.0, 11, 11)
    with pytest.raises(KeyboardInterrupt):
        fresh.replay(path, progress=lambda f: os.kill(os.getpid(), signal.SIGINT) if f > 0.5 else None)
    assert not fresh.stroke_active and fresh.journal == []
    assert np.allclose(h.positions, before, atol=1e-12)  # the steps before the stroke began stay


def test_the_gil_is_released_while_simulating():
    s, g = flat_session(1.0, 1.0, 31, 31)
    ticks = []
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks.append(1)
            done.wait(0.001)

    t = threading.Thread(target=count)
    t.start()
    try:
        s.simulate(1.0)
    finally:
        done.set()
        t.join()
    assert len(ticks) > 5, "another Python thread ran during the simulation"
