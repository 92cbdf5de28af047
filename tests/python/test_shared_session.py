"""A second Python handle on a session that already exists: what an app gives its embedded console."""
import numpy as np
import pytest

import kiji
from conftest import flat_session


def test_a_handle_made_from_a_session_is_that_session_with_every_tool():
    s, g = flat_session(1.0, 1.0, 21, 21)
    other = kiji.Session(session=s)
    assert isinstance(other, kiji.Session)
    assert other.garment_count == 1
    # A tool run through the new handle edits the one session: the first handle sees the cut.
    x = np.linspace(-0.1, 1.1, 25)
    other.cut(np.stack([x, np.full_like(x, 0.52), np.full_like(x, 0.001)], 1))
    assert len(s.journal) == 1 and s.journal[0].tool == "cut"
    assert s.garment(0).piece_count == 2
    assert other.undo() and s.garment(0).piece_count == 1


def test_a_handle_needs_a_session():
    with pytest.raises(TypeError):
        kiji.Session(session=42)
