"""Undo, redo, and journal files: save, load, replay on a fresh session."""
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
    assert not s.undo()
    design(s)
    assert len(s.journal) == 3 and [j.tool for j in s.journal] == ["cut", "paint", "pinch"]
    assert s.undo() and s.undo()
    assert len(s.journal) == 1 and g.piece_count == 2 and g.texture is None
    assert s.redo()
    assert g.texture is not None
    s.undo()
    s.pin([(0.5, 0.5, 0)])  # a new stroke drops what was undone
    assert not s.can_redo and [j.tool for j in s.journal] == ["cut", "pin"]


def test_save_load_replay_gives_the_same_garment(tmp_path):
    s, g = flat_session(1.0, 1.0, 11, 11)
    design(s)
    path = tmp_path / "session.kiji.json"
    s.save_journal(str(path))
    doc = json.loads(path.read_text())
    assert doc["format"] == "kiji-journal" and doc["version"] == kiji.JOURNAL_FILE_VERSION
    assert [st["tool"] for st in doc["strokes"]] == ["cut", "paint", "pinch"]
    assert doc["strokes"][1]["params"]["color"] == [1.0, 0.0, 0.0]
    strokes = kiji.load_journal(str(path))
    assert [st.tool for st in strokes] == ["cut", "paint", "pinch"]
    assert strokes[2].params["stiffness"] == 300.0 and strokes[1].params["resolution"] == 64
    assert strokes[0].positions.shape == (21, 3)

    fresh, h = flat_session(1.0, 1.0, 11, 11)
    seen = []
    assert fresh.replay(path, progress=seen.append) == 3
    assert seen[-1] == pytest.approx(1.0)
    assert np.array_equal(h.faces, g.faces)
    assert np.array_equal(h.positions, g.positions)
    assert np.array_equal(h.texture, g.texture)
    assert fresh.time == pytest.approx(s.time)
    # A list of strokes replays too, and the session's own journal can be saved with kiji.save_journal.
    again, k = flat_session(1.0, 1.0, 11, 11)
    kiji.save_journal(s.journal, str(tmp_path / "copy.json"))
    assert again.replay(kiji.load_journal(str(tmp_path / "copy.json"))) == 3
    assert np.array_equal(k.positions, g.positions)


def test_bad_journal_files_are_clear_errors(tmp_path):
    s, _ = flat_session(1.0, 1.0, 5, 5)
    with pytest.raises(kiji.InputError, match="does not exist"):
        kiji.load_journal(str(tmp_path / "none.json"))
    p = tmp_path / "bad.json"
    p.write_text("{not json")
    with pytest.raises(kiji.InputError, match="not valid JSON"):
        kiji.load_journal(str(p))
    p.write_text(json.dumps({"format": "kiji-journal", "version": 99, "strokes": []}))
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
    assert not s.can_undo
