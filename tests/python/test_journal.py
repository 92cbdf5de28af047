"""Undo, redo, and journal files: save, load, replay on a fresh session; every change a script makes is
an operation of the journal, so the replay gives the same garments bit for bit."""
import json

import numpy as np
import pytest

import kiji
from conftest import flat_session, line


def design(s):
    s.cut(line((-0.1, 0.52, 0.01), (1.1, 0.52, 0.01), 20))
    s.paint(line((0.2, 0.3, 0.002), (0.8, 0.3, 0.002), 10), color=(1, 0, 0), radius=0.02, resolution=64)
    s.pinch(line((0.5, 0.9, 0), (0.5, 0.9, 0.1), 10), stiffness=300.0)


def test_undo_redo():
    s, g = flat_session(1.0, 1.0, 11, 11)
    assert s.journal == [] and not s.can_redo
    design(s)
    assert len(s.journal) == 3 and [j.tool for j in s.journal] == ["cut", "paint", "pinch"]
    painted = g.texture
    assert s.undo() and s.undo()
    assert len(s.journal) == 1 and g.piece_count == 2 and g.texture is None
    assert s.redo()
    np.testing.assert_array_equal(g.texture, painted)  # redo brings back the very texels painted
    s.undo()
    s.pin([(0.5, 0.5, 0)])  # a new stroke drops what was undone
    assert not s.can_redo and [j.tool for j in s.journal] == ["cut", "pin"]


def test_save_load_replay_gives_the_same_garment(tmp_path):
    s, g = flat_session(1.0, 1.0, 11, 11)
    design(s)
    path = tmp_path / "session.kiji.json"
    s.save_journal(str(path))
    doc = json.loads(path.read_text())
    assert doc["format"] == "kiji-journal" and doc["version"] == kiji.JOURNAL_FILE_VERSION == 2
    ops = doc["operations"]
    assert [o["kind"] for o in ops[:2]] == ["add_garment", "set_solver_params"]
    begins = [o for o in ops if o["kind"] == "tool" and o["event"]["phase"] == "begin"]
    assert [o["tool"] for o in begins] == ["cut", "paint", "pinch"]
    assert begins[1]["params"]["color"] == [1.0, 0.0, 0.0]
    strokes = kiji.load_journal(str(path))
    assert [st.tool for st in strokes] == ["cut", "paint", "pinch"]
    assert strokes[2].params["stiffness"] == 300.0 and strokes[1].params["resolution"] == 64
    assert strokes[0].positions.shape == (21, 3)

    # A session set up with the same operations continues from them; a new one replays them all.
    fresh, h = flat_session(1.0, 1.0, 11, 11)
    seen = []
    assert fresh.replay(path, progress=seen.append) == len(ops)
    assert seen[-1] == pytest.approx(1.0)
    assert np.array_equal(h.faces, g.faces)
    assert np.array_equal(h.positions, g.positions)
    assert np.array_equal(h.texture, g.texture)
    assert fresh.time == s.time
    new = kiji.Session()
    assert new.replay(path) == len(ops)
    assert np.array_equal(new.garment(0).positions, g.positions)
    other, _ = flat_session(1.0, 1.0, 9, 9)
    with pytest.raises(kiji.InputError, match="differs from the journal's at operation 0"):
        other.replay(path)
    # Set up the same way, but its clock ran on: the journal's operations cannot come at their steps.
    ran_on, r = flat_session(1.0, 1.0, 11, 11)
    ran_on.step(2)
    before = r.positions
    with pytest.raises(kiji.InputError, match="time ran on after it was set up. Replay the journal on a new session"):
        ran_on.replay(path)
    assert np.array_equal(r.positions, before) and ran_on.journal == []
    # A list of strokes replays too, and the session's own journal can be saved with kiji.save_journal.
    again, k = flat_session(1.0, 1.0, 11, 11)
    kiji.save_journal(s.journal, str(tmp_path / "copy.json"))
    assert again.replay(kiji.load_journal(str(tmp_path / "copy.json"))) == 3
    assert np.array_equal(k.positions, g.positions)


def _steps_on_alike(s, tmp_path, seconds=0.6):
    """Saves s, opens the file, and steps both on: the garments stay the same bit for bit."""
    path = str(tmp_path / "mid.kiji")
    s.save(path)
    t = kiji.load(path)
    for _ in range(3):
        s.advance_to(s.time + seconds / 3)
        t.advance_to(t.time + seconds / 3)
        assert np.array_equal(t.garment(0).positions, s.garment(0).positions)
        assert np.array_equal(t.garment(0).velocities, s.garment(0).velocities)
        assert t.measure(0).sleeping == s.measure(0).sleeping
    return path


def test_a_session_opened_from_its_file_steps_on_as_the_one_that_saved_it(tmp_path):
    # Cloth falling onto the default body, a hole cut in it from above as it lands: saved, and
    # opened again. The solver's order, its collision margins and the body's hold go with the
    # garment, so the two sessions step on bit for bit.
    s = kiji.Session(body=kiji.Body.default())
    s.add_garment(kiji.rectangle(0.6, 1.0, spacing=0.04))
    s.drape(0.6)
    s.simulating = False
    p = s.garment(0).positions
    top = p[p[:, 1] > p[:, 1].max() - 0.02].mean(axis=0)
    a = np.linspace(0, 2 * np.pi, 30)
    s.cut(np.c_[top[0] + 0.08 * np.cos(a), np.full(30, top[1] + 0.5), top[2] + 0.08 * np.sin(a)], rays=(0, -1, 0))
    assert s.garment(0).piece_count == 2
    s.simulating = True
    s.advance_to(s.time + 0.2)
    path = _steps_on_alike(s, tmp_path)
    # An undo or a redo hands the solver a garment as it was, as a file does: it steps on the same.
    u, v = kiji.load(path), kiji.load(path)
    u.advance_to(u.time + 0.2)
    v.advance_to(v.time + 0.2)
    v.set_garment(0, v.garment(0))
    u.advance_to(u.time + 0.2)
    v.advance_to(v.time + 0.2)
    assert np.array_equal(u.garment(0).positions, v.garment(0).positions)


def test_cloth_settling_towards_sleep_goes_on_settling_in_a_session_opened_from_its_file(tmp_path):
    # A flat cloth of nine blocks asleep, one corner pulled and let go: the blocks around it woken,
    # calming again, some asleep. Saved then, the file carries which blocks sleep and how long the
    # others have been calm; the session opened from it puts the same cloth to sleep at the same step.
    s, g = flat_session(1.0, 1.0, 100, 100)
    params = s.solver_params
    params.sleep_after = 0.1
    s.solver_params = params
    s.advance_to(0.3)
    assert s.measure(0).sleeping == len(g.positions)
    s.pinch(line((0.0, 0.0, 0.0), (-0.02, -0.02, 0.03), 6), stiffness=300.0)
    s.advance_to(s.time + 0.05)
    asleep = s.measure(0).sleeping
    assert 0 < asleep < len(g.positions), "some of the cloth sleeps, some moves"
    _steps_on_alike(s, tmp_path, seconds=0.3)


def test_bad_journal_files_are_clear_errors(tmp_path):
    s, _ = flat_session(1.0, 1.0, 5, 5)
    with pytest.raises(kiji.InputError, match="does not exist"):
        kiji.load_journal(str(tmp_path / "none.json"))
    p = tmp_path / "bad.json"
    p.write_text("{not json")
    with pytest.raises(kiji.InputError, match="not valid JSON"):
        kiji.load_journal(str(p))
    p.write_text(json.dumps({"format": "kiji-journal", "version": 99, "operations": []}))
    with pytest.raises(kiji.InputError, match="version 99"):
        kiji.load_journal(str(p))
    p.write_text(json.dumps({"format": "kiji-journal", "version": 1, "strokes": [
        {"tool": "cut", "params": {}, "events": [{"phase": "begin", "time": 0, "position": [0, 0]}]}]}))
    with pytest.raises(kiji.InputError, match="stroke 0, event 0.*position"):
        kiji.load_journal(str(p))
    p.write_text(json.dumps({"format": "kiji-journal", "version": 1, "strokes": [
        {"tool": "lasso", "params": {}, "events": [{"phase": "begin", "time": 0, "position": [0, 0, 0]}]}]}))
    with pytest.raises(kiji.InputError, match="unknown tool 'lasso'"):
        s.replay(str(p))
    assert s.journal == []
    p.write_text(json.dumps({"format": "kiji-journal", "version": 1, "strokes": [
        {"tool": "cut", "params": {}, "events": [{"phase": "begin", "time": 1e9, "position": [0, 0, 0]}]}]}))
    with pytest.raises(kiji.InputError, match="at most 3600 s ahead"):
        s.replay(str(p))
    p.write_text(json.dumps({"format": "kiji-journal", "version": 1, "strokes": [
        {"tool": "cut", "params": {}, "events": [{"phase": "begin", "time": 0, "position": [0, 0, 0],
                                                  "buttons": -5}]}]}))
    with pytest.raises(kiji.InputError, match="'buttons' is not a whole number"):
        s.replay(str(p))
    # What a damaged disk or a peer could hand over, each refused with the reason.
    def event(**fields):
        e = {"phase": "begin", "time": 0, "position": [0, 0, 0]}
        e.update(fields)
        p.write_text(json.dumps({"format": "kiji-journal", "version": 1, "strokes": [
            {"tool": "cut", "params": {}, "events": [e]}]}))
        return str(p)
    with pytest.raises(kiji.InputError, match=r"event 0: the event's orientation \(0, 0, 0, 0\) is not a unit"):
        s.replay(event(orientation=[0, 0, 0, 0]))
    with pytest.raises(kiji.InputError, match=r"position \(1e\+308, 0, 0\) is outside the world's bounds"):
        s.replay(event(position=[1e308, 0, 0]))
    with pytest.raises(kiji.InputError, match="'pressure' is not between 0 and 1"):
        s.replay(event(pressure=1.5))
    assert s.journal == []


def every_kind_of_change(s):
    """A script that changes a session every way a script can."""
    s.body = kiji.Body.default()
    g = s.add_garment(kiji.rectangle(0.5, 0.4, spacing=0.05))
    s.solver_params = kiji.SolverParams(substeps=5)
    s.drape(seconds=0.2)
    s.simulating = False
    s.cut(line((0.0, 1.3, -0.3), (0.0, 1.3, 0.3), 8))
    s.simulating = True
    s.frame_rate = 90
    s.simulate(0.1)
    g.positions = g.positions + np.array([0.0, 0.01, 0.0])
    g.velocities = np.zeros_like(g.velocities)
    pins = g.pins
    pins[:3] = True
    g.pins = pins
    g.material = kiji.Material("denim")
    g.color = (0.2, 0.4, 0.6)
    g.name = "tunic"
    s.pick_radius = 0.1
    s.paint(g.positions[5:8], color=(1, 0, 0), radius=0.03, resolution=32)
    s.undo()
    s.redo()
    h = s.add_garment(kiji.rectangle(0.2, 0.2, nx=4, ny=4))
    h.translate((0, 2.0, 0))
    s.remove_garment(1)
    if g.piece_count > 1:
        g.remove_piece(0)
    s.step(3)
    return g


def test_a_script_that_changes_everything_replays_bit_for_bit(tmp_path):
    s = kiji.Session()
    g = every_kind_of_change(s)
    kinds = set(s.operation_kinds)
    assert {"set_body", "add_garment", "set_solver_params", "set_garment", "set_simulating", "tool",
            "set_frame_rate", "set_pick_radius", "undo", "redo", "remove_garment"} <= kinds
    path = tmp_path / "everything.json"
    s.save_journal(path)
    again = kiji.Session()
    again.replay(path)
    h = again.garment(0)
    assert again.garment_count == s.garment_count and again.time == s.time
    for name in ("positions", "velocities", "pins", "faces", "uvs", "texture"):
        assert np.array_equal(getattr(h, name), getattr(g, name)), name
    assert h.material.name == "denim" and h.name == "tunic" and again.frame_rate == 90
    # The session file (an LCM log) gives the same session.
    s.save(tmp_path / "everything.kiji")
    loaded = kiji.load(tmp_path / "everything.kiji")
    assert np.array_equal(loaded.garment(0).positions, g.positions)
