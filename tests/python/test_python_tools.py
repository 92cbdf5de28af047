"""Tools written in Python: registered, they are tools like any other (Session methods, journaled,
undoable, replayable, event by event, errors cancelled), work on the session through a ToolSession,
and declare their haptic force as one of the core's models."""
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import kiji
from conftest import flat_session, line, nearest_row
from kiji.examples.smooth import SmoothTool


@pytest.fixture(scope="module", autouse=True)
def smooth():
    if not kiji.registry().has("smooth"):
        kiji.register_tool(SmoothTool)
    yield


def wrinkled(nx=21):
    s, g = flat_session(1, 1, nx, nx)
    s.simulating = False
    x = g.positions
    x[:, 2] = 0.01 * np.random.default_rng(7).standard_normal(len(x))
    g.positions = x
    return s, g


def roughness(g, rows):
    """How far each vertex is from its neighbours' average (the Laplacian), over `rows`."""
    x, e = g.positions, g.edges
    nb = np.zeros_like(x)
    np.add.at(nb, e[:, 0], x[e[:, 1]])
    np.add.at(nb, e[:, 1], x[e[:, 0]])
    deg = np.bincount(e.ravel(), minlength=len(x))[:, None]
    return np.linalg.norm(nb / deg - x, axis=1)[rows].mean()


def test_a_python_tool_is_a_session_method_with_its_declared_parameters():
    assert "smooth" in [t.id for t in kiji.tools()]
    assert kiji.registry().origin("smooth") == "Python class kiji.examples.smooth.SmoothTool"
    doc = kiji.Session.smooth.__doc__
    assert "Relaxes the cloth under the pen" in doc and "radius : float = 0.03  (m; 0.001 to 1)" in doc
    import inspect
    sig = inspect.signature(kiji.Session.smooth)
    assert sig.parameters["strength"].default == 0.5 and sig.parameters["iterations"].annotation == "int"
    s, g = wrinkled()
    with pytest.raises(kiji.InputError, match="strength"):
        s.smooth([(0.5, 0.5, 0)], strength=2.0)
    with pytest.raises(TypeError, match="iterations"):
        s.smooth([(0.5, 0.5, 0)], iterations=1.5)
    with pytest.raises(TypeError, match="unexpected keyword argument 'strenght'"):
        s.smooth([(0.5, 0.5, 0)], strenght=0.1)


def test_smooth_evens_out_the_cloth_under_the_brush_and_nothing_else():
    s, g = wrinkled()
    x0 = g.positions
    d = np.linalg.norm(x0[:, :2] - (0.5, 0.5), axis=1)
    under, outside = np.flatnonzero(d < 0.12), np.flatnonzero(d > 0.2)
    before = roughness(g, under)
    s.smooth(line((0.48, 0.5, 0.0), (0.52, 0.5, 0.0), 4), radius=0.15, strength=0.8, iterations=3)
    assert roughness(g, under) < 0.3 * before
    np.testing.assert_array_equal(g.positions[outside], x0[outside])  # untouched beyond the brush
    assert s.history[-1].tool == "smooth" and s.history[-1].params["iterations"] == 3


def test_a_python_tools_stroke_undoes_redoes_and_replays_bit_for_bit(tmp_path):
    s, g = wrinkled()
    x0 = g.positions
    s.smooth(line((0.3, 0.3, 0.0), (0.7, 0.6, 0.0), 8), radius=0.1, relax_rest=True)
    after, rest = g.positions, g.rest_lengths
    assert not np.array_equal(after, x0)
    assert s.undo()
    np.testing.assert_array_equal(g.positions, x0)
    assert s.redo()
    np.testing.assert_array_equal(g.positions, after)
    np.testing.assert_array_equal(g.rest_lengths, rest)
    s.save_journal(tmp_path / "smooth.json")
    r = kiji.Session()
    r.replay(str(tmp_path / "smooth.json"))
    np.testing.assert_array_equal(r.garment(0).positions, after)
    np.testing.assert_array_equal(r.garment(0).rest_lengths, rest)
    # A session without the tool says so before replaying anything.
    bare = kiji.Session(registry=kiji.ToolRegistry())
    with pytest.raises(kiji.InputError, match="smooth"):
        bare.replay(s.operations)


def test_every_peer_that_has_the_tool_applies_the_same_operations_to_the_same_cloth():
    a, ga = wrinkled()
    b = kiji.Session()
    b.replay(a.operations)  # b joins with everything so far
    a.add_listener(b.perform)  # then every operation of a, as a peer receives it
    a.begin("smooth", (0.5, 0.5, 0.0), radius=0.2)
    for i in range(1, 6):
        a.update(kiji.ToolEvent("move", (0.5 + 0.02 * i, 0.5, 0.0), time=a.time))
    a.end((0.6, 0.5, 0.0))
    np.testing.assert_array_equal(b.garment(0).positions, ga.positions)
    assert b.operation_kinds == a.operation_kinds


def test_an_error_in_a_python_tool_cancels_the_stroke_and_reaches_the_caller_as_raised():
    class Broken(Exception):
        pass

    class Clumsy(kiji.Tool):
        def info(self):
            return kiji.ToolInfo("clumsy", "Clumsy", "Moves the cloth, then fails on the third event.")

        def begin(self, session, params, event):
            self.n = 0
            return self.update(session, event)

        def update(self, session, event):
            g = session.garment(0)
            x = g.positions
            x[:, 2] += 0.01
            g.positions = x
            self.n += 1
            if self.n == 3:
                raise Broken("the third event breaks")

    kiji.register_tool(Clumsy)
    try:
        s, g = flat_session(1, 1, 5, 5)
        s.simulating = False
        x0 = g.positions
        with pytest.raises(Broken, match="the third event breaks"):
            s.clumsy(line((0.5, 0.5, 0), (0.6, 0.5, 0), 5))
        np.testing.assert_array_equal(g.positions, x0)  # nothing half-applied
        assert not s.stroke_active and not any(h.tool == "clumsy" for h in s.history)
        s.begin("clumsy", (0.5, 0.5, 0))
        s.update((0.5, 0.5, 0))
        with pytest.raises(Broken):
            s.update((0.5, 0.5, 0))
        np.testing.assert_array_equal(g.positions, x0)
        s.pinch([(0.5, 0.5, 0)])  # the session goes on
    finally:
        kiji.unregister_tool("clumsy")
    assert not hasattr(kiji.Session, "clumsy")


def test_a_tool_changes_the_session_only_during_its_calls():
    kept = {}

    class Hoarder(kiji.Tool):
        def info(self):
            return kiji.ToolInfo("hoarder", "Hoarder", "Keeps what it was given.")

        def begin(self, session, params, event):
            kept["garment"], kept["solver"], kept["session"] = session.garment(0), session.solver(0), session
            assert session.active and session.garment_count == 1 and session.time == 0.0

    kiji.register_tool(Hoarder)
    try:
        s, g = flat_session(1, 1, 5, 5)
        s.hoarder([(0.5, 0.5, 0)])
        for use in (lambda: kept["garment"].positions, lambda: kept["solver"].add_attachment(0, (0, 0, 0), 1.0),
                    lambda: kept["session"].garment(0)):
            with pytest.raises(kiji.Error, match="outside the tool's begin, update, end or cancel"):
                use()
        assert not kept["session"].active
    finally:
        kiji.unregister_tool("hoarder")


class Grab(kiji.Tool):
    """A hand written in Python: an attachment on the session's solver and a declared spring."""

    def info(self):
        return kiji.ToolInfo("grab", "Grab", "Holds the vertex under the pen on a spring.",
                             [kiji.ParamSpec.real("stiffness", 40.0, 0.1, 1000.0, unit="N/m")])

    def begin(self, session, params, event):
        self.k = params["stiffness"]
        g = session.garment(event.hit.garment)
        self.row = int(g.rows([event.hit.vertex_id])[0])
        self.solver = session.solver(event.hit.garment)
        self.id = self.solver.add_attachment(self.row, event.position, self.k)
        self.haptic.spring([self.row], self.k)
        return self.force(g, event)

    def update(self, session, event):
        self.solver.move_attachment(self.id, event.position)
        return self.force(session.garment(0), event)

    def end(self, session, event):
        self.solver.remove_attachment(self.id)

    def cancel(self, session):
        self.solver.remove_attachment(self.id)

    def force(self, g, event):
        return self.k * (g.positions[self.row] - event.position)


def test_a_python_tool_holds_the_cloth_with_the_solvers_attachments_and_declares_its_spring():
    kiji.register_tool(Grab)
    try:
        s, g = flat_session(1, 1, 11, 11)
        row = nearest_row(g, (0.5, 0.5, 0))
        s.begin("grab", (0.5, 0.5, 0.0), stiffness=40.0)
        assert s.solver(0).attachment_count == 1
        for i in range(1, 31):
            f = s.update(kiji.ToolEvent("move", (0.5, 0.5, 0.004 * i), time=i / 60))
        assert g.positions[row, 2] > 0.05  # the cloth came along
        np.testing.assert_allclose(f.force, 40.0 * (g.positions[row] - (0.5, 0.5, 0.12)), atol=1e-12)
        # What the haptic loop feels between steps: the declared spring on the latest snapshot.
        grab = s.tool("grab")
        tool_haptics = grab.python.haptic
        assert tool_haptics.model == "spring" and grab.info().id == "grab"
        snap = kiji.take_snapshot(s, 0, (0.5, 0.5, 0.12), 0.1)
        pen = kiji.ToolEvent("move", (0.5, 0.5, 0.13))
        expected = 40.0 * (g.positions[row] - (0.5, 0.5, 0.13))
        np.testing.assert_allclose(grab.haptic_force(snap, pen).force, expected, atol=1e-12)
        np.testing.assert_allclose(tool_haptics.force(snap, pen).force, expected, atol=1e-12)
        s.end((0.5, 0.5, 0.12))
        assert s.solver(0).attachment_count == 0 and tool_haptics.model == "none"  # let go
        with pytest.raises(kiji.Error, match="can only read"):
            s.solver(0).add_attachment(row, (0, 0, 0), 1.0)  # a script's hand would escape the journal
    finally:
        kiji.unregister_tool("grab")


class Region(kiji.Tool):
    """Lets only the cloth near the pen move while its stroke lasts (the paper's local region), through
    the solver's parameters; greedy, it asks for more substeps as well, which a tool may not."""

    def info(self):
        return kiji.ToolInfo("region", "Region", "Moves only the cloth near the pen during the stroke.",
                             [kiji.ParamSpec.boolean("greedy", False)])

    def begin(self, session, params, event):
        solver = session.solver(0)
        p = solver.params
        p.local_radius, p.local_center = 0.1, event.position
        if params["greedy"]:
            p.substeps = 2 * p.substeps
        solver.params = p

    def end(self, session, event):
        solver = session.solver(0)
        p = solver.params
        p.local_radius, p.local_center = session.solver_params.local_radius, session.solver_params.local_center
        solver.params = p

    def cancel(self, session):
        self.end(session, None)


def test_a_python_tool_sets_the_solvers_local_region_and_nothing_else_of_its_parameters():
    kiji.register_tool(Region)
    try:
        s, g = flat_session(1, 1, 11, 11)
        s.begin("region", (0.5, 0.5, 0.0))
        p = s.solver(0).params
        assert p.local_radius == 0.1 and np.allclose(p.local_center, (0.5, 0.5, 0.0))
        s.end((0.5, 0.5, 0.0))
        assert s.solver(0).params.local_radius == 0.0  # the session's own region again
        with pytest.raises(kiji.InputError, match="a tool may change only the local region"):
            s.region([(0.5, 0.5, 0.0)], greedy=True)
        assert s.solver(0).params.substeps == s.solver_params.substeps
        assert not s.stroke_active
    finally:
        kiji.unregister_tool("region")


def test_a_tool_is_registered_once_checked_and_can_be_replaced_or_removed():
    with pytest.raises(TypeError, match="expected a class"):
        kiji.register_tool(SmoothTool())
    with pytest.raises(TypeError, match="lacks begin, update, end, cancel"):
        kiji.register_tool(type("Half", (), {"info": lambda self: None}))
    with pytest.raises(kiji.InputError, match="already taken"):
        kiji.register_tool(SmoothTool)

    def tool(tool_id, params=()):
        return type("T", (kiji.Tool,), {"info": lambda self: kiji.ToolInfo(tool_id, "T", "A test tool.", list(params))})

    with pytest.raises(kiji.InputError, match="not a Python identifier"):
        kiji.register_tool(tool("two words"))
    with pytest.raises(kiji.InputError, match="clash"):
        kiji.register_tool(tool("clashing", [kiji.ParamSpec.real("dt", 0.1, 0.0, 1.0)]))
    with pytest.raises(kiji.InputError, match="declared twice"):
        kiji.register_tool(tool("twice", [kiji.ParamSpec.boolean("a", True), kiji.ParamSpec.boolean("a", False)]))
    with pytest.raises(kiji.InputError, match="between"):
        kiji.ParamSpec.real("r", 5.0, 0.0, 1.0)  # a default out of its own range
    kiji.register_tool(tool("versioned", [kiji.ParamSpec.integer("v", 1, 0, 10)]))
    try:
        kiji.register_tool(tool("versioned", [kiji.ParamSpec.integer("v", 2, 0, 10)]), replace=True)
        assert kiji.tool_info("versioned").parameters[0].default == 2
        assert "v : int = 2" in kiji.Session.versioned.__doc__
    finally:
        assert kiji.unregister_tool("versioned")
    assert not kiji.unregister_tool("versioned") and not hasattr(kiji.Session, "versioned")


def test_a_tool_can_go_into_a_sessions_own_registry():
    class Nudge(kiji.Tool):
        def info(self):
            return kiji.ToolInfo("nudge", "Nudge", "Lifts the vertex under the pen by 1 cm.")

        def begin(self, session, params, event):
            g = session.garment(0)
            x = g.positions
            x[g.rows([event.hit.vertex_id])[0], 2] += 0.01
            g.positions = x

    own = kiji.ToolRegistry()
    s = kiji.Session(registry=own)
    assert s.registry is own
    kiji.register_tool(Nudge, registry=s.registry)
    g = s.add_garment(kiji.rectangle(1, 1, nx=5, ny=5))
    s.simulating = False
    s.nudge([(0.5, 0.5, 0)])
    assert g.positions[:, 2].max() == pytest.approx(0.01)
    assert not kiji.registry().has("nudge") and not hasattr(kiji.Session, "nudge")


def test_an_installed_package_provides_tools_through_the_kiji_tools_entry_point(tmp_path):
    pkg = tmp_path / "kiji_extra_tools"
    pkg.mkdir()
    (pkg / "__init__.py").write_text(textwrap.dedent("""
        import kiji

        class Lift(kiji.Tool):
            def info(self):
                return kiji.ToolInfo("lift", "Lift", "Lifts the whole cloth by a height.",
                                     [kiji.ParamSpec.real("height", 0.01, 0.0, 1.0, unit="m")])

            def begin(self, session, params, event):
                g = session.garment(0)
                g.translate((0, 0, params["height"]))

        class NotATool:
            pass
        """))
    dist = tmp_path / "kiji_extra_tools-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: kiji-extra-tools\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text("[kiji.tools]\nlift = kiji_extra_tools:Lift\n"
                                           "broken = kiji_extra_tools:NotATool\n")
    code = textwrap.dedent("""
        import warnings
        warnings.simplefilter("always")
        import kiji
        s = kiji.Session()
        g = s.add_garment(kiji.rectangle(1, 1, nx=3, ny=3))
        s.lift([(0.5, 0.5, 0)], height=0.25)
        print("lifted", round(float(g.positions[:, 2].min()), 6))
        print("origin", kiji.registry().origin("lift"))
        print("broken", [r["message"] for r in kiji.plugin_reports() if "broken" in r["path"]])
        """)
    env = dict(os.environ, PYTHONPATH=str(tmp_path))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "lifted 0.25" in out.stdout
    assert "origin Python class kiji_extra_tools.Lift" in out.stdout
    assert "lacks info, begin, update, end, cancel" in out.stdout
    assert "tool entry point refused: entry point broken" in out.stderr


def test_smooth_declares_the_push_of_the_cloth_that_the_haptic_loop_renders():
    s, g = flat_session(1, 1, 11, 11)
    s.simulating = False
    s.begin("smooth", (0.5, 0.5, 0.002), radius=0.05)
    smooth = s.tool("smooth")
    assert smooth.python.haptic.model == "push"
    snap = kiji.take_snapshot(s, 0, (0.5, 0.5, 0.0), 0.3)
    above, below, away = ((0.5, 0.5, 0.002), (0.5, 0.5, -0.001), (0.5, 0.5, 0.01))
    np.testing.assert_allclose(smooth.haptic_force(snap, kiji.ToolEvent("move", above)).force, (0, 0, 300 * 0.003))
    np.testing.assert_allclose(smooth.haptic_force(snap, kiji.ToolEvent("move", below)).force, (0, 0, -300 * 0.004))
    np.testing.assert_array_equal(smooth.haptic_force(snap, kiji.ToolEvent("move", away)).force, 0.0)
    s.end((0.5, 0.5, 0.002))
    assert smooth.python.haptic.model == "push"  # the pen still feels the cloth between strokes
