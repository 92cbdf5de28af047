"""A tool plugin from outside Kiji, found on KIJI_PLUGIN_PATH, becomes a method the same way."""
import inspect
import os
import subprocess
import sys

import numpy as np
import pytest

import kiji


def test_a_plugin_on_kiji_plugin_path_appears_as_a_method(probe_dir):
    env = dict(os.environ, KIJI_PLUGIN_PATH=probe_dir)
    code = (
        "import inspect, numpy as np, kiji\n"
        "sig = inspect.signature(kiji.Session.probe)\n"
        "print(sorted(p for p in sig.parameters if sig.parameters[p].kind is inspect.Parameter.KEYWORD_ONLY\n"
        "             and p in ('height', 'direction', 'repeat', 'fail', 'note', 'tint')))\n"
        "s = kiji.Session()\n"
        "g = s.add_garment(kiji.rectangle(1, 1, nx=5, ny=5))\n"
        "s.simulating = False\n"
        "y = g.positions[:, 1].max()\n"
        "s.probe([(0.5, 0.5, 0.0)], height=0.1, repeat=2)\n"
        "print(round(g.positions[:, 2].max() + g.positions[:, 1].max() - y, 6))\n"
        "print(kiji.Session.probe.__doc__.splitlines()[0])\n")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert lines[0] == "['direction', 'fail', 'height', 'note', 'repeat', 'tint']"
    assert lines[2].startswith("Probe: Lifts the cloth vertex")


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
