"""Driving a tool event by event from Python (session.begin / update / end / cancel), as a program's
own device or event loop would, through the same Session::apply path as whole strokes."""
import threading

import numpy as np
import pytest

import kiji
from conftest import flat_session, line, nearest_row


def test_a_stroke_event_by_event_is_the_same_as_the_whole_stroke():
    points = line((0.5, 0.5, 0.0), (0.5, 0.5, 0.2), 10)
    a, ga = flat_session(1, 1, 11, 11)
    forces = a.pinch(points, dt=1 / 60, stiffness=50.0)
    b, gb = flat_session(1, 1, 11, 11)
    got = [b.begin("pinch", kiji.ToolEvent("begin", points[0], time=0.0), stiffness=50.0).force]
    for i, p in enumerate(points[1:-1], start=1):
        got.append(b.update(kiji.ToolEvent("move", p, time=i / 60)).force)
    assert b.active_tool() == "pinch" and b.active_users == [0]
    got.append(b.end(kiji.ToolEvent("end", points[-1], time=(len(points) - 1) / 60)).force)
    assert b.active_tool() is None and not b.stroke_active
    np.testing.assert_array_equal(np.array(got), forces)
    np.testing.assert_array_equal(ga.positions, gb.positions)
    assert a.operation_kinds == b.operation_kinds
    assert b.history[-1].tool == "pinch" and len(b.history[-1].events) == len(points)


def test_positions_alone_are_events_at_the_sessions_clock():
    s, g = flat_session(1, 1, 11, 11)
    s.simulating = False
    s.begin("pinch", (0.5, 0.5, 0.0), stiffness=10.0, grab_radius=0.0)
    f = s.update((0.5, 0.5, 0.1))
    np.testing.assert_allclose(f.force, (0, 0, -1.0), atol=1e-12)  # k (vertex - pen), nothing stepped
    assert s.steps == 0
    s.end((0.5, 0.5, 0.1))
    assert s.can_undo


def test_cancel_puts_the_cloth_back_and_says_whether_there_was_a_stroke():
    s, g = flat_session(1, 1, 11, 11)
    before = g.positions
    assert s.cancel() is False
    s.begin("pinch", (0.5, 0.5, 0.0))
    for i in range(1, 6):
        s.update(kiji.ToolEvent("move", (0.5, 0.5, 0.05 * i), time=i / 60))
    assert not np.array_equal(g.positions[:, 2], before[:, 2])
    assert s.cancel() is True
    np.testing.assert_array_equal(g.positions[:, :2], before[:, :2])
    assert not s.stroke_active and s.operation_kinds[-1] == "tool" and s.operations[-1].event.phase == "cancel"


def test_each_user_has_a_stroke_of_their_own():
    s, g = flat_session(1, 1, 11, 11)
    s.simulating = False
    s.begin("pinch", (0.2, 0.2, 0.0), user=1)
    s.begin("paint", (0.8, 0.8, 0.0), user=2, color=(1, 0, 0), radius=0.05)
    assert sorted(s.active_users) == [1, 2]
    assert s.active_tool(user=1) == "pinch" and s.active_tool(user=2) == "paint"
    s.update((0.2, 0.2, 0.05), user=1)
    s.end((0.8, 0.8, 0.0), user=2)
    s.end((0.2, 0.2, 0.05), user=1)
    assert [op.user for op in s.operations if op.kind == "tool"] == [1, 2, 1, 2, 1]
    # User 2's paint is where user 2 painted, in red, and not under user 1's pinch.
    t = g.texture
    n = t.shape[0]
    assert list(t[int(0.8 * n), int(0.8 * n)][:3]) == [255, 0, 0]
    assert list(t[int(0.2 * n), int(0.2 * n)][:3]) != [255, 0, 0]


def test_bad_events_are_refused_with_what_to_do_and_change_nothing():
    s, g = flat_session(1, 1, 11, 11)
    n = s.operation_count
    with pytest.raises(kiji.InputError, match="no stroke in progress"):
        s.update((0.5, 0.5, 0.0))
    with pytest.raises(kiji.InputError, match="expected a 'begin' event"):
        s.begin("pinch", kiji.ToolEvent("move", (0.5, 0.5, 0.0)))
    with pytest.raises(kiji.InputError, match="unknown tool 'pnich'"):
        s.begin("pnich", (0.5, 0.5, 0.0))
    with pytest.raises(TypeError, match="unexpected keyword argument 'stifness'"):
        s.begin("pinch", (0.5, 0.5, 0.0), stifness=3.0)
    with pytest.raises(kiji.InputError, match="stiffness"):
        s.begin("pinch", (0.5, 0.5, 0.0), stiffness=-1.0)
    with pytest.raises(kiji.InputError, match="finite"):
        s.begin("pinch", (np.nan, 0.5, 0.0))
    with pytest.raises(TypeError):
        s.begin("pinch", None)
    assert s.operation_count == n and not s.stroke_active
    s.begin("pinch", (0.5, 0.5, 0.0))
    with pytest.raises(kiji.InputError, match="in progress"):
        s.begin("cut", (0.5, 0.5, 0.0))
    with pytest.raises(kiji.InputError, match="expected an 'end' event"):
        s.end(kiji.ToolEvent("move", (0.5, 0.5, 0.0)))
    s.end((0.5, 0.5, 0.0))


def test_an_event_without_a_time_is_now_and_one_before_the_clock_is_refused():
    s, g = flat_session(1, 1, 11, 11)
    s.step(30)
    assert kiji.ToolEvent("begin", (0.5, 0.5, 0.0)).time is None
    s.begin("pinch", kiji.ToolEvent("begin", (0.5, 0.5, 0.0)))  # at the clock: 0.5 s
    s.update(kiji.ToolEvent("move", (0.5, 0.5, 0.05)))
    s.end(kiji.ToolEvent("end", (0.5, 0.5, 0.05)))
    assert s.history[-1].events[0].time == pytest.approx(0.5)
    n = s.operation_count
    with pytest.raises(kiji.InputError, match=r"its time -5 s is before the session's clock \(0.5 s"):
        s.begin("pinch", kiji.ToolEvent("begin", (0.5, 0.5, 0.0), time=-5))
    with pytest.raises(kiji.InputError, match="outside the world's bounds"):
        s.begin("pinch", (1e308, 0.5, 0.0))
    with pytest.raises(kiji.InputError, match="journal stroke's events need their times"):
        kiji.JournalStroke("pinch", {}, [kiji.ToolEvent("begin", (0.5, 0.5, 0.0))])
    assert s.operation_count == n and not s.stroke_active


def test_an_interactive_stroke_replays_on_a_new_session(tmp_path):
    s, g = flat_session(1, 1, 11, 11)
    s.begin("pinch", (0.5, 0.5, 0.0))
    for i in range(1, 11):
        s.update(kiji.ToolEvent("move", (0.5, 0.5 + 0.01 * i, 0.02 * i), time=i / 60))
    s.end(kiji.ToolEvent("end", (0.5, 0.6, 0.2), time=11 / 60))
    s.save_journal(tmp_path / "j.json")
    r = kiji.Session()
    r.replay(str(tmp_path / "j.json"))
    np.testing.assert_array_equal(r.garment(0).positions, g.positions)
    # The log itself replays too, operation by operation.
    r2 = kiji.Session()
    assert r2.replay(s.operations) == len(s.operations)
    np.testing.assert_array_equal(r2.garment(0).positions, g.positions)


def test_a_program_drives_a_stroke_from_its_own_thread_while_another_reads():
    s, g = flat_session(1, 1, 21, 21)
    reads = []
    done = threading.Event()

    def reader():
        while not done.is_set():
            reads.append(g.positions[:, 2].max())

    t = threading.Thread(target=reader)
    t.start()
    try:
        s.begin("pinch", (0.5, 0.5, 0.0))
        for i in range(1, 31):
            s.update(kiji.ToolEvent("move", (0.5, 0.5, 0.005 * i), time=i / 60))
        s.end(kiji.ToolEvent("end", (0.5, 0.5, 0.15), time=31 / 60))
    finally:
        done.set()
        t.join()
    assert reads and g.positions[nearest_row(g, (0.5, 0.5, 0.15)), 2] > 0.05
