"""Every tool found becomes a Session method with its declared parameters, help and signature."""
import inspect

import numpy as np
import pytest

import kiji
from conftest import flat_session

TOOLS = ("cut", "paint", "pin", "pinch", "sew", "tear")


@pytest.mark.parametrize("tool", TOOLS)
def test_every_tool_is_a_method_with_a_real_signature_and_docstring(tool):
    info = kiji.tool_info(tool)
    method = getattr(kiji.Session, tool)
    sig = inspect.signature(method)
    assert list(sig.parameters)[:2] == ["self", "stroke"]
    for spec in info.parameters:
        p = sig.parameters[spec.name]
        assert p.kind is inspect.Parameter.KEYWORD_ONLY
        assert p.default == spec.default
    assert info.description in method.__doc__
    for spec in info.parameters:
        assert spec.name in method.__doc__ and spec.help in method.__doc__
    # help() shows them
    text = inspect.getdoc(getattr(kiji.Session(), tool))
    assert info.description in text


def test_introspection_lists_tools_and_their_parameters():
    infos = {t.id: t for t in kiji.tools()}
    assert set(TOOLS) <= set(infos)
    s = kiji.Session()
    assert {t.id for t in s.tools()} == set(infos)
    radius = {p.name: p for p in infos["paint"].parameters}["radius"]
    assert radius.type == "float" and radius.unit == "m" and radius.min == 0.0005 and radius.max == 0.5
    mode = {p.name: p for p in infos["cut"].parameters}["mode"]
    assert mode.type == "choice" and mode.choices == ["line", "stroke", "vertex"] and mode.default == "line"
    color = {p.name: p for p in infos["paint"].parameters}["color"]
    assert color.type == "color" and len(color.default) == 3


def test_unknown_keywords_and_bad_values_raise_naming_the_parameter():
    s, g = flat_session(1.0, 1.0, 11, 11)
    before = g.positions
    with pytest.raises(TypeError, match="blade"):
        s.cut([(0.5, 0.5, 0)], blade=1.0)
    with pytest.raises(ValueError, match="radius"):
        s.paint([(0.5, 0.5, 0)], radius=-1.0)
    with pytest.raises(kiji.InputError, match="color"):
        s.paint([(0.5, 0.5, 0)], color=(2, 0, 0))
    with pytest.raises(ValueError, match="mode"):
        s.cut([(0.5, 0.5, 0)], mode="laser")
    with pytest.raises(TypeError, match="radius"):
        s.paint([(0.5, 0.5, 0)], radius="big")
    with pytest.raises(TypeError, match="resolution"):
        s.paint([(0.5, 0.5, 0)], resolution=1.5)
    with pytest.raises(TypeError, match="mode"):
        s.cut([(0.5, 0.5, 0)], mode=3)
    with pytest.raises(TypeError, match="color"):
        s.paint([(0.5, 0.5, 0)], color="red")
    with pytest.raises(kiji.InputError, match="unknown tool 'lasso'"):
        s.apply_tool("lasso", [(0, 0, 0)])
    assert s.journal == [] and not s.stroke_active
    assert np.array_equal(g.positions, before)


def test_bad_strokes_raise_and_change_nothing():
    s, g = flat_session(1.0, 1.0, 11, 11)
    before = g.positions
    with pytest.raises(kiji.InputError, match="finite"):
        s.cut([(np.nan, 0.5, 0), (0.5, 0.5, 0)])
    with pytest.raises(kiji.InputError, match="shape"):
        s.cut(np.zeros((4, 2)))
    with pytest.raises(kiji.InputError, match="no points"):
        s.cut(np.zeros((0, 3)))
    with pytest.raises(TypeError):
        s.cut("across")
    with pytest.raises(TypeError):
        s.cut([("a", "b", "c")])
    with pytest.raises(TypeError, match="stroke"):
        s.cut()
    with pytest.raises(kiji.InputError, match="times"):
        s.cut([(0, 0, 0), (1, 1, 0)], times=[0.0])
    with pytest.raises(kiji.InputError, match="begin"):
        s.cut([kiji.ToolEvent("move", (0.5, 0.5, 0))])
    with pytest.raises(kiji.InputError, match="pressure"):
        s.paint([(0.5, 0.5, 0)], pressure=2.0)
    assert not s.stroke_active and s.journal == []
    assert np.array_equal(g.positions, before)


def test_an_error_inside_a_tool_restores_the_garment():
    s, g = flat_session(1.0, 1.0, 11, 11)
    s.simulating = False
    before = g.positions
    # A seam with only one side traced: sew refuses, and nothing is half-applied.
    with pytest.raises(kiji.InputError, match="both borders"):
        s.sew([(0.0, 0.0, 0.0), (0.0, 0.5, 0.0)], mode="seam")
    assert np.array_equal(g.positions, before)
    assert not s.stroke_active


def test_strokes_default_to_the_session_clock_one_step_apart():
    s, g = flat_session(1.0, 1.0, 6, 6)
    s.simulating = False
    s.pin(np.array([[0.1, 0.1, 0], [0.2, 0.1, 0], [0.3, 0.1, 0]]))
    times = [e.time for e in s.journal[-1].events]
    assert times == pytest.approx([0.0, 1 / 60, 2 / 60])
    assert s.time == pytest.approx(2 / 60)
    s.pin(np.array([[0.1, 0.1, 0], [0.2, 0.1, 0]]), dt=0)
    assert [e.time for e in s.journal[-1].events] == pytest.approx([2 / 60, 2 / 60])
    s.pin((0.5, 0.5, 0.0))  # one point: press and release there
    assert [e.phase for e in s.journal[-1].events] == ["begin", "end"]
