"""The rest of the core from Python: a solver of one's own, the topology edits on rows, per-edge
arrays, operations and the session's log, body queries and picking, the C++ drape, and the haptic
loop fed by a device written in Python."""
import time

import numpy as np
import pytest

import kiji
from conftest import flat_session, nearest_row


def box_body(size=0.4, height=1.0):
    """A closed box (12 triangles, outward normals) standing on y = 0."""
    h = size / 2
    v = np.array([[x, y, z] for x in (-h, h) for y in (0.0, height) for z in (-h, h)], float)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = []
    for a, b, c, d in quads:
        tris += [(a, b, c), (a, c, d)]
    return kiji.Body.from_triangles(v, np.array(tris), name="box")


# --- a solver of one's own ---

def test_a_solver_of_ones_own_steps_a_garment_with_forces_and_attachments():
    g = kiji.rectangle(1, 1, nx=11, ny=11)
    solver = kiji.Solver(g, kiji.SolverParams(gravity=(0, 0, 0), sleep_after=0.0))
    assert solver.owned and solver.writable and solver.garment is g
    corner = nearest_row(g, (0, 0, 0))
    hand = solver.add_attachment(corner, (0, 0, 0.2), 100.0)
    solver.step(1 / 60, n=30)
    assert g.positions[corner, 2] > 0.1
    solver.move_attachment(hand, (0, 0, 0.0))
    solver.remove_attachment(hand)
    assert solver.attachment_count == 0
    v0 = g.velocities
    centre = nearest_row(g, (0.5, 0.5, 0))
    solver.add_external_force([centre], [(0.0, 0.0, 5.0)])
    solver.step(1 / 60)
    assert g.velocities[centre, 2] > v0[centre, 2]  # the force acted for that step
    m = solver.measure()
    assert m.vertices == 121 and m.max_strain > 0
    # The pushed vertex's edges went past the strain limit in the step, and the limit held them (an
    # edge projected to the limit is there to within rounding).
    assert solver.last_step().strain_limited > 0 and m.max_strain <= solver.params.strain_limit + 1e-12
    with pytest.raises(kiji.InputError, match="does not exist"):
        solver.add_attachment(500, (0, 0, 0), 1.0)
    with pytest.raises(kiji.InputError, match="stiffness"):
        solver.add_attachment(0, (0, 0, 0), -1.0)
    with pytest.raises(kiji.InputError, match="shape"):
        solver.add_external_force([0, 1], [(0, 0, 1.0)])
    with pytest.raises(kiji.InputError, match="dt"):
        solver.step(-1.0)


def test_a_sessions_solver_is_read_only_for_scripts_and_a_garment_in_a_session_has_no_solver_of_its_own():
    s, g = flat_session(1, 1, 5, 5)
    solver = s.solver(0)
    assert not solver.writable and solver.params.model == "xpbd"
    s.step()
    assert solver.last_step().self_gathers >= 1 and solver.measure().vertices == 25  # it looked for self-contact
    assert solver.spring_forces().shape == (25, 3)
    for change in (lambda: solver.add_attachment(0, (0, 0, 0), 1.0), lambda: solver.add_external_force(0, (0, 0, 1)),
                   lambda: setattr(solver, "params", kiji.SolverParams())):
        with pytest.raises(kiji.Error, match="can only read"):
            change()
    with pytest.raises(kiji.Error, match="session steps its own"):
        solver.step()
    with pytest.raises(kiji.Error, match="in a session"):
        kiji.Solver(g)
    own = kiji.rectangle(1, 1, nx=3, ny=3)
    solver = kiji.Solver(own)
    s.add_garment(own)  # moved into the session: the session steps it now
    with pytest.raises(kiji.Error, match="added to a session"):
        solver.step()
    with pytest.raises(kiji.InputError, match="garment 5 does not exist"):
        s.solver(5)


def test_strain_limit_is_a_solver_parameter():
    p = kiji.SolverParams(strain_limit=0.02)
    assert p.strain_limit == 0.02
    with pytest.raises(kiji.InputError, match="strain_limit"):
        kiji.SolverParams(strain_limit=-1.0)


def test_the_cpp_drape_settles_a_garment_on_a_body():
    body = box_body()
    g = kiji.rectangle(0.6, 0.6, spacing=0.05)
    kiji.place_over_body(g, body, 0.02)
    result = kiji.drape(g, body, seconds=1.0)
    assert result.steps == 60 and result.seconds_simulated == pytest.approx(1.0)
    assert result.measures.contacts > 0 and result.measures.max_penetration < 0.01
    assert g.bounds[0, 1] < 0.95  # the cloth hangs over the sides
    with pytest.raises(kiji.InputError, match="seconds"):
        kiji.drape(g, body, seconds=-1.0)


def test_a_fine_garment_falls_first_as_a_coarse_copy():
    # Over 2,000 vertices and flat: a copy with edges three times as long falls first, then the
    # garment settles itself for the last half second; coarse_ratio=1 drapes the garment itself.
    body = box_body()
    g = kiji.rectangle(0.6, 0.6, spacing=0.012)
    assert len(g.positions) > 2000
    kiji.place_over_body(g, body, 0.02)
    result = kiji.drape(g, body, seconds=1.0)
    assert 0 < result.coarse_vertices < len(g.positions) / 5
    assert (result.coarse_steps, result.steps) == (30, 30)
    assert result.seconds_simulated == pytest.approx(1.0)
    assert 0 < result.coarse_wall_seconds < result.wall_seconds
    assert result.measures.max_strain < 0.10 and result.measures.max_penetration < 0.01
    assert g.bounds[0, 1] < 0.95  # the cloth hangs over the sides
    assert g.material.damping == kiji.Material("cotton").damping  # its own, after the settle
    itself = kiji.rectangle(0.6, 0.6, spacing=0.012)
    kiji.place_over_body(itself, body, 0.02)
    plain = kiji.drape(itself, body, seconds=0.2, coarse_ratio=1)
    assert (plain.coarse_vertices, plain.steps) == (0, 12)
    for bad, word in ((dict(coarse_ratio=0.5), "coarse_ratio"), (dict(coarse_substeps=0), "coarse_substeps"),
                      (dict(fine_seconds=-1.0), "fine_seconds"), (dict(fine_damping=float("nan")), "fine_damping")):
        with pytest.raises(kiji.InputError, match=word):
            kiji.drape(g, body, seconds=1.0, **bad)


# --- garments: per-edge arrays and topology edits ---

def test_per_edge_arrays_follow_the_edges_and_edits_are_journaled():
    s, g = flat_session(1, 1, 3, 3)
    e, rest = g.edges, g.rest_lengths
    x = g.positions
    np.testing.assert_allclose(rest, np.linalg.norm(x[e[:, 0]] - x[e[:, 1]], axis=1))
    np.testing.assert_allclose(g.tear_thresholds, 1.6 * rest)  # cotton's tear_ratio
    np.testing.assert_allclose(g.strains, 0.0, atol=1e-12)
    n = s.operation_count
    g.rest_lengths = rest * 0.9  # shrink the cloth
    assert s.operation_kinds[n:] == ["set_garment"]
    np.testing.assert_allclose(g.strains, 1 / 0.9 - 1)
    with pytest.raises(kiji.InputError, match="positive length"):
        g.rest_lengths = rest * 0
    with pytest.raises(kiji.InputError, match="shape"):
        g.tear_thresholds = rest[:-1]
    assert s.undo()
    np.testing.assert_allclose(g.rest_lengths, rest)
    assert g.masses.sum() == pytest.approx(0.15)  # 1 m^2 of cotton at 0.15 kg/m^2
    assert g.rest_areas.sum() == pytest.approx(1.0)
    assert (g.inverse_masses > 0).all() and g.panels.tolist() == [0] * g.face_count


def test_topology_edits_on_rows():
    g = kiji.rectangle(1, 1, nx=5, ny=5)
    left, right = nearest_row(g, (0, 0.5, 0)), nearest_row(g, (1, 0.5, 0))
    path = kiji.edge_path(g, left, right)
    assert path[0] == left and path[-1] == right and len(path) == 5
    made = kiji.cut_along(g, path)
    assert len(made) == 5 and g.piece_count == 2 and g.face_count == 32 and g.is_valid()
    # Two rectangles sewn edge to edge along a border make one piece.
    a = kiji.rectangle(1, 1, nx=3, ny=3)
    b = kiji.rectangle(1, 1, nx=3, ny=3)
    b.translate((1.0, 0, 0))
    first = kiji.append_garment(a, b)
    assert first == 9 and a.piece_count == 2
    x = a.positions
    right_side = [nearest_row(a, (1, y, 0)) for y in (0, 0.5, 1)]
    left_side = [first + nearest_row(b, (1, y, 0)) for y in (0, 0.5, 1)]
    assert np.allclose(x[right_side], x[left_side])
    kiji.stitch(a, right_side, left_side)
    assert a.piece_count == 1 and a.is_valid() and len(kiji.border_loops(a)) == 1
    # Merge, split, remove: each leaves a valid mesh, or is refused leaving the garment as it was.
    g = kiji.rectangle(1, 1, nx=5, ny=5)
    before = g.positions
    with pytest.raises(kiji.TopologyError):  # two interior vertices apart: the result would not be manifold
        kiji.merge_vertices(g, nearest_row(g, (0.25, 0.25, 0)), nearest_row(g, (0.75, 0.75, 0)))
    np.testing.assert_array_equal(g.positions, before)
    corner = nearest_row(g, (0, 0, 0))
    kiji.remove_edge(g, np.array([0]))
    kiji.remove_edges(g, np.array([[nearest_row(g, (1, 1, 0)), nearest_row(g, (1, 0.75, 0))]]))
    assert g.is_valid() and kiji.non_manifold_vertices(g).size == 0
    with pytest.raises(kiji.InputError, match="not joined by an edge"):
        kiji.remove_edges(g, np.array([[corner, nearest_row(g, (1, 1, 0))]]))
    with pytest.raises(kiji.InputError, match="does not exist"):
        kiji.cut_along(g, [0, 999])
    loop = kiji.border_loops(g)[0]
    assert list(kiji.border_path(g, loop[0], loop[2])) == list(loop[:3])


def test_a_topology_edit_on_a_sessions_garment_is_one_operation_and_undoes():
    s, g = flat_session(1, 1, 5, 5)
    path = kiji.edge_path(g, nearest_row(g, (0, 0.5, 0)), nearest_row(g, (1, 0.5, 0)))
    n = s.operation_count
    kiji.cut_along(g, path)
    assert g.piece_count == 2 and s.operation_kinds[n:] == ["set_garment"]
    assert s.undo() and g.piece_count == 1


def test_garments_bodies_and_operations_round_trip_through_their_binary_forms():
    s, g = flat_session(1, 1, 5, 5)
    s.body = box_body()
    s.pinch([(0.5, 0.5, 0), (0.5, 0.5, 0.1)])
    copy = kiji.Garment.from_bytes(g.to_bytes())
    np.testing.assert_array_equal(copy.positions, g.positions)
    np.testing.assert_array_equal(kiji.Body.from_bytes(s.body.to_bytes()).vertices, s.body.vertices)
    ops = [kiji.Operation.from_bytes(op.to_bytes()) for op in s.operations]
    assert [o.kind for o in ops] == s.operation_kinds
    tool_ops = [o for o in ops if o.kind == "tool"]
    assert tool_ops[0].tool == "pinch" and tool_ops[0].event.phase == "begin" and "stiffness" in tool_ops[0].params
    assert [o for o in ops if o.kind == "set_body"][0].body.name == "box"
    fresh = kiji.Session()
    for op in ops:
        fresh.perform(op)
    np.testing.assert_array_equal(fresh.garment(0).positions, g.positions)
    with pytest.raises(kiji.InputError):
        kiji.Operation.from_bytes(b"\x01\x00garbage")
    assert kiji.hash_bytes(b"kiji") == kiji.hash_bytes(b"kiji") != kiji.hash_bytes(b"kijI")


def test_session_files_read_back_as_operations_with_a_report(tmp_path):
    s, g = flat_session(1, 1, 5, 5)
    s.pinch([(0.5, 0.5, 0), (0.5, 0.5, 0.1)])
    s.save(tmp_path / "s.kiji")
    ops, report = kiji.load_session_operations(tmp_path / "s.kiji")
    assert [o.kind for o in ops] == s.operation_kinds and report["damage"] == ""
    data = (tmp_path / "s.kiji").read_bytes()
    # Cut inside the last operation (the state saved after the operations starts 28 bytes before its
    # channel's name, at the LCM event's header).
    state_at = data.rfind(kiji.SESSION_STATE_CHANNEL.encode()) - 28
    assert state_at > 0
    (tmp_path / "cut.kiji").write_bytes(data[:state_at - 10])
    ops2, report2 = kiji.load_session_operations(tmp_path / "cut.kiji")
    assert len(ops2) < len(ops) and report2["damage"]
    journal = kiji.read_journal(_saved_journal(s, tmp_path))
    assert journal.version == 2 and len(journal.operations) >= len(ops)
    assert [st.tool for st in kiji.strokes_of(s.operations)] == ["pinch"]


def _saved_journal(s, tmp_path):
    path = tmp_path / "j.json"
    s.save_journal(path)
    return path


def test_listeners_see_every_operation_and_can_be_removed():
    s, g = flat_session(1, 1, 3, 3)
    seen = []
    lid = s.add_listener(lambda op: seen.append(op.kind))
    s.simulating = False
    s.pinch([(0.5, 0.5, 0)])
    s.remove_listener(lid)
    s.simulating = True
    assert seen == ["set_simulating", "tool", "tool"]


# --- body queries and picking ---

def test_body_queries_and_picking():
    body = box_body()
    c = kiji.BodyCollider(body)
    hit = c.closest((0.0, 0.5, 0.25), 0.1)
    assert hit and hit.distance == pytest.approx(0.05) and hit.normal[2] == pytest.approx(1.0)
    assert not c.closest((0.0, 0.5, 0.5), 0.1)
    crossing = c.first_crossing((0, 0.5, 1.0), (0, 0.5, 0))
    assert crossing and crossing.point[2] == pytest.approx(0.2)
    assert c.inside((0.0, 0.5, 0.0)) and not c.inside((0.0, 0.5, 0.25))
    assert len(c.triangles_in_box([[-1, -1, 0.15], [1, 2, 1]])) >= 2
    np.testing.assert_allclose(np.linalg.norm(body.triangle_normals, axis=1), 1.0)
    a = kiji.rectangle(1, 1, nx=3, ny=3)
    b = kiji.rectangle(1, 1, nx=3, ny=3)
    b.translate((0, 0, 0.5))
    hit = kiji.pick([a, b], (0.5, 0.5, 0.45), radius=0.1)
    assert hit and hit.garment == 1 and hit.distance == pytest.approx(0.05)
    ray_hit = kiji.pick([a, b], (0.5, 0.5, 2.0), ray=(0, 0, -1))
    assert ray_hit.garment == 1 and ray_hit.point[2] == pytest.approx(0.5)
    assert "-z" in kiji.axis_names()


# --- haptics ---

class PenDevice(kiji.InputDevice):
    """A device written in Python: a pen held over the cloth, recording the forces it is sent."""

    def __init__(self, position):
        super().__init__()
        self.position = position
        self.forces = []
        self.samples = 0

    def name(self):
        return "python pen"

    def sample(self):
        self.samples += 1
        return kiji.ToolEvent("move", self.position)

    def set_force(self, force):
        self.forces.append(np.array(force))

    def max_force(self):
        return 2.0


def test_a_device_written_in_python_feeds_the_haptic_loop():
    s, g = flat_session(1, 1, 11, 11)
    s.simulating = False
    pen = PenDevice((0.5, 0.5, 0.002))
    s.begin("paint", (0.5, 0.5, 0.002), color=(1, 0, 0))  # paint pushes the pen out of the cloth
    loop = kiji.HapticLoop(pen, rate_hz=1000)
    loop.set_tool(s, "paint")
    loop.publish(kiji.take_snapshot(s, 0, (0.5, 0.5, 0.0), 0.25))
    with loop:
        assert loop.running and pen.samples >= 1  # sampled before start() returned
        time.sleep(0.3)  # the GIL is free: the loop's thread samples the Python device
    assert not loop.running
    stats = loop.stats()
    print(f"\nhaptic loop with a Python device, main thread asleep: {stats['rate_hz']:.0f} Hz, "
          f"jitter {stats['period_jitter_us']:.0f} us")
    assert stats["ticks"] > 50 and pen.samples >= stats["ticks"]
    pushes = [f for f in pen.forces if np.linalg.norm(f) > 0]
    assert pushes and all(f[2] > 0 for f in pushes)  # out of the cloth, towards the pen
    assert max(np.linalg.norm(f) for f in pen.forces) <= 2.0 + 1e-12  # clamped to the device's maximum
    np.testing.assert_array_equal(pen.forces[-1], 0.0)  # stop() leaves the device with no force
    s.end((0.5, 0.5, 0.002))


def test_an_error_in_a_python_device_is_reported_and_the_loop_goes_on(monkeypatch):
    reported = []
    monkeypatch.setattr("sys.unraisablehook", lambda u: reported.append((u.exc_type, str(u.exc_value))))

    class Faulty(PenDevice):
        def sample(self):
            self.samples += 1
            if self.samples > 3:
                raise RuntimeError("the cable came loose")
            return super().sample()

    errors_before = kiji.device_errors()
    dev = Faulty((0, 0, 0))
    loop = kiji.HapticLoop(dev)
    with loop:
        time.sleep(0.05)
    assert kiji.device_errors() > errors_before and loop.stats()["ticks"] > 3
    assert reported and reported[0] == (RuntimeError, "the cable came loose")


def test_a_program_that_ends_with_the_loop_still_running_exits_cleanly():
    import subprocess
    import sys
    code = ("import time, kiji\n"
            "class D(kiji.InputDevice):\n"
            "    def sample(self):\n"
            "        return kiji.ToolEvent('move', (0, 0, 0))\n"
            "loop = kiji.HapticLoop(D())\n"
            "loop.start()\n"
            "time.sleep(0.05)\n"
            "print('bye')\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and out.stdout.strip() == "bye", out.stderr
