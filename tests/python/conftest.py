"""Shared helpers for the Python tests. They run against the INSTALLED kiji package (pip install .)."""
import os

import numpy as np
import pytest

import kiji

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def line(a, b, n):
    """n + 1 pointer positions from a to b (the C++ tests' line())."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.array([a + (b - a) * (i / n) for i in range(n + 1)])


def flat_session(w, h, nx, ny, material=None):
    """A flat rectangle in the z = 0 plane, no gravity (the C++ tests' flat_session())."""
    s = kiji.Session()
    g = s.add_garment(kiji.rectangle(w, h, nx=nx, ny=ny, material=material))
    s.solver_params = kiji.SolverParams(gravity=(0, 0, 0))
    return s, g


def nearest_row(g, p):
    return int(np.argmin(((g.positions - np.asarray(p)) ** 2).sum(axis=1)))


def state(g):
    tex = g.texture
    return (g.faces.copy(), g.positions.copy(), g.pins.copy(), None if tex is None else tex.copy(), len(g.tacks))


def assert_same_state(a, b):
    assert np.array_equal(a[0], b[0])
    assert np.array_equal(a[1], b[1])
    assert np.array_equal(a[2], b[2])
    assert (a[3] is None and b[3] is None) or np.array_equal(a[3], b[3])
    assert a[4] == b[4]


def run_and_check_undo(s, g, tool, stroke, **params):
    before = state(g)
    getattr(s, tool)(stroke, **params)
    after = state(g)
    assert s.undo()
    assert_same_state(state(g), before)
    assert s.redo()
    assert_same_state(state(g), after)


@pytest.fixture
def probe_dir():
    """The probe tool of tests/fixtures/plugins, built by the C++ build (a third-party plugin for the package)."""
    d = os.environ.get("KIJI_TEST_PROBE_DIR", os.path.join(REPO, "build", "tests", "fixtures", "plugins", "good"))
    if not os.path.isfile(os.path.join(d, "kiji_probe.json")):
        pytest.fail(f"the probe tool is not built in {d}: build the C++ tests first (scripts/setup.sh)")
    return d
