"""A tool plugin from outside Kiji, found on KIJI_PLUGIN_PATH, becomes a method the same way."""
import inspect
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import kiji


def test_a_plugin_on_kiji_plugin_path_appears_as_a_method(probe_dir):
    # In a fresh interpreter, so that only KIJI_PLUGIN_PATH can have brought the probe in.
    env = dict(os.environ, KIJI_PLUGIN_PATH=probe_dir)
    code = (
        "import inspect, json, numpy as np, kiji\n"
        "sig = inspect.signature(kiji.Session.probe)\n"
        "kw = {n: p.default for n, p in sig.parameters.items() if p.kind is inspect.Parameter.KEYWORD_ONLY}\n"
        "s = kiji.Session()\n"
        "g = s.add_garment(kiji.rectangle(1, 1, nx=5, ny=5))\n"
        "s.simulating = False\n"
        "before = g.positions\n"
        "s.probe([(0.5, 0.5, 0.0)], height=0.1, repeat=2)\n"
        "print(json.dumps({'kw': {k: kw[k] for k in ('height', 'direction', 'repeat', 'fail', 'note', 'tint')},\n"
        "                  'before': before.tolist(), 'after': g.positions.tolist(),\n"
        "                  'doc': kiji.Session.probe.__doc__.splitlines()[0]}))\n")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout)
    # The declared parameters, with their declared defaults, are the method's keyword arguments.
    assert result["kw"] == {"height": 0.05, "direction": "up", "repeat": 1, "fail": False, "note": "",
                            "tint": [1.0, 0.5, 0.25]}
    assert result["doc"].startswith("Probe: Lifts the cloth vertex")
    # Its effect: the vertex under the pointer, the middle of the 5 x 5 grid, rose by height x repeat
    # = 0.2 m along +Y, and nothing else moved.
    before, after = np.array(result["before"]), np.array(result["after"])
    under = int(np.argmin(((before - (0.5, 0.5, 0.0)) ** 2).sum(axis=1)))
    assert np.allclose(before[under], (0.5, 0.5, 0.0))
    moved = np.flatnonzero(np.any(after != before, axis=1))
    assert moved.tolist() == [under]
    assert np.allclose(after[under] - before[under], (0.0, 0.2, 0.0), atol=1e-12)


def test_load_plugins_at_run_time_adds_methods_and_errors_cross_the_boundary(probe_dir):
    if "probe" not in kiji.registry().ids():
        reports = kiji.load_plugins(probe_dir)
        assert any(r["loaded"] and r["id"] == "probe" for r in reports)
    assert "probe" in {t.id for t in kiji.tools()}
    sig = inspect.signature(kiji.Session.probe)
    assert sig.parameters["height"].default == 0.05
    assert sig.parameters["tint"].default == (1.0, 0.5, 0.25)
    s = kiji.Session()
    g = s.add_garment(kiji.rectangle(1, 1, nx=5, ny=5))
    s.simulating = False
    before = g.positions
    s.probe([(0.5, 0.5, 0.0)], height=0.1, direction="down")
    assert np.isclose((g.positions - before)[:, 1].min(), -0.1)
    with pytest.raises(kiji.InputError, match="asked to fail"):
        s.probe([(0.5, 0.5, 0.0)], fail=True)
    with pytest.raises(ValueError, match="repeat"):
        s.probe([(0.5, 0.5, 0.0)], repeat=11)
    with pytest.raises(TypeError, match="fail"):
        s.probe([(0.5, 0.5, 0.0)], fail=1)
    assert not s.stroke_active
