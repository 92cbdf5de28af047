"""Garments as NumPy arrays (round trips, checked setters), patterns, materials, bodies, the solver."""
import os
import subprocess
import sys

import numpy as np
import pytest

import kiji
from conftest import flat_session, nearest_row


def test_rectangle_arrays_round_trip():
    g = kiji.rectangle(1.0, 0.5, nx=11, ny=6)
    assert g.vertex_count == 66 and g.face_count == 100 and g.piece_count == 1
    p = g.positions
    assert p.shape == (66, 3) and p.dtype == np.float64
    assert g.faces.shape == (100, 3) and g.faces.dtype == np.int64
    assert g.uvs.shape == (100, 3, 2)
    assert np.allclose(g.uvs[..., 0], p[g.faces][..., 0] / 1.0)  # uv = pattern metres / larger side
    assert g.velocities.shape == (66, 3) and not g.velocities.any()
    assert g.pins.dtype == np.bool_ and not g.pins.any()
    assert g.texture is None
    q = p + [0, 0, 0.25]
    g.positions = q
    assert np.array_equal(g.positions, q)
    g.velocities = np.ones((66, 3))
    assert np.array_equal(g.velocities, np.ones((66, 3)))
    pins = np.zeros(66, bool)
    pins[:5] = True
    g.pins = pins
    assert np.array_equal(g.pins, pins)
    uv = g.uvs * 0.5
    g.uvs = uv
    assert np.array_equal(g.uvs, uv)
    tex = np.zeros((8, 16, 4), np.uint8)
    tex[..., 0] = 200
    g.texture = tex
    assert np.array_equal(g.texture, tex)
    g.positions = p.astype(np.float32)  # any real dtype is converted
    assert np.allclose(g.positions, p)


def test_setters_check_shape_dtype_and_nan():
    g = kiji.rectangle(1.0, 1.0, nx=3, ny=3)
    before = g.positions
    with pytest.raises(kiji.InputError, match="shape"):
        g.positions = np.zeros((8, 3))
    with pytest.raises(kiji.InputError, match="shape"):
        g.positions = np.zeros((9, 2))
    bad = before.copy()
    bad[4, 1] = np.nan
    with pytest.raises(kiji.InputError, match="finite"):
        g.positions = bad
    with pytest.raises(kiji.InputError, match="finite"):
        g.velocities = np.full((9, 3), np.inf)
    with pytest.raises(TypeError):
        g.positions = np.array([["a"] * 3] * 9)
    with pytest.raises(TypeError):
        g.positions = "positions"
    with pytest.raises(TypeError):
        g.pins = np.zeros(9)
    with pytest.raises(kiji.InputError):
        g.pins = np.zeros(4, bool)
    with pytest.raises(TypeError):
        g.texture = np.zeros((4, 4, 4), np.float32)
    with pytest.raises(kiji.InputError):
        g.texture = np.zeros((4, 4, 3), np.uint8)
    with pytest.raises(kiji.InputError):
        g.uvs = np.zeros((3, 3, 2))
    with pytest.raises(kiji.InputError):
        g.color = (2, 0, 0)
    assert np.array_equal(g.positions, before)
    assert issubclass(kiji.InputError, ValueError) and issubclass(kiji.TopologyError, kiji.Error)


def test_garment_from_arrays_and_topology_errors():
    pos = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float)
    g = kiji.Garment(pos, np.array([[0, 1, 2], [1, 3, 2]]))
    assert g.face_count == 2 and g.is_valid()
    with pytest.raises(kiji.TopologyError):
        kiji.Garment(pos, np.array([[0, 1, 2], [0, 1, 3]]))  # opposite orientations across an edge
    with pytest.raises(kiji.TopologyError):
        kiji.Garment(pos, np.array([[0, 1, 2]]))  # vertex 3 used by no face
    with pytest.raises(kiji.InputError, match="vertex 7"):
        kiji.Garment(pos, np.array([[0, 1, 7]]))
    with pytest.raises(TypeError):
        kiji.Garment(pos, np.array([[0.0, 1.0, 2.0]]))
    with pytest.raises(kiji.InputError, match="finite"):
        kiji.Garment(np.full((3, 3), np.nan), np.array([[0, 1, 2]]))


def test_patterns_panel_and_rectangle_options():
    g = kiji.panel([(0, 0), (0.4, 0), (0.4, 0.3), (0.2, 0.45), (0, 0.3)], 0.05, panel_id=2)
    assert g.is_valid() and g.face_count > 20
    assert np.allclose(g.positions[:, 2], 0)
    r = kiji.rectangle(0.6, 0.4, spacing=0.1)
    assert r.vertex_count == 7 * 5
    with pytest.raises(TypeError):
        kiji.rectangle(1, 1)
    with pytest.raises(kiji.InputError):
        kiji.panel([(0, 0), (1, 1)], 0.1)
    with pytest.raises(kiji.InputError):
        kiji.panel([(0, 0), (1, 0), (0, 1)], -1)


def test_a_pinch_steps_the_garment_at_the_held_substeps_and_a_step_says_so():
    for held, expected in ((20, 20), (0, 10), (5, 10)):
        s, g = flat_session(0.5, 0.5, 21, 21)
        s.solver_params = kiji.SolverParams(gravity=(0, 0, 0), held_substeps=held)
        c = g.positions[nearest_row(g, (0.25, 0.25, 0))]
        s.begin("pinch", kiji.ToolEvent("begin", c, time=s.time))
        s.update(kiji.ToolEvent("move", c + (0, 0, 0.05), time=s.time + 1 / s.frame_rate))
        assert s.last_step(0).substeps == expected, f"held_substeps={held}: more than the 10 substeps, or 10"
        s.end(kiji.ToolEvent("end", c + (0, 0, 0.05), time=s.time + 1 / s.frame_rate))
        s.simulate(1 / s.frame_rate)
        assert s.last_step(0).substeps == 10, "let go, the garment steps at its ordinary substeps"
    with pytest.raises(kiji.InputError, match="held_substeps"):
        kiji.SolverParams(held_substeps=-1)


def test_materials_and_solver_params():
    assert set(kiji.Material.preset_names()) >= {"cotton", "silk", "denim", "rubber", "tissue"}
    m = kiji.Material("silk", thickness=0.003)
    assert m.name == "silk" and m.thickness == 0.003
    with pytest.raises(kiji.InputError):
        kiji.Material("velvet")
    with pytest.raises(kiji.InputError, match="density"):
        kiji.Material(density=-1)
    with pytest.raises(TypeError):
        kiji.Material(colour=1)
    g = kiji.rectangle(0.2, 0.2, nx=3, ny=3)
    g.material = kiji.Material("rubber")
    assert g.material.name == "rubber"
    p = kiji.SolverParams(model="mass_spring", substeps=4, gravity=(0, -1, 0))
    assert p.model == "mass_spring" and p.substeps == 4 and np.array_equal(p.gravity, [0, -1, 0])
    with pytest.raises(kiji.InputError):
        kiji.SolverParams(model="verlet")
    with pytest.raises(kiji.InputError):
        kiji.SolverParams(substeps=0)
    s = kiji.Session(solver=p)
    assert s.solver_params.model == "mass_spring"
    with pytest.raises(kiji.InputError):
        s.frame_rate = 0


def test_bodies_load_with_options_and_from_arrays(tmp_path):
    b = kiji.Body.default()
    assert 1.6 < b.height < 1.7 and b.vertices.shape[1] == 3 and b.triangles.shape[1] == 3
    tall = kiji.Body.load(kiji.Body.default_path(), height=1.8)
    assert tall.height == pytest.approx(1.8, rel=1e-6)
    # A Z-up body file read with up='z' stands on +Y.
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 2.0]])
    t = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    tet = kiji.Body.from_triangles(v, t, name="tet")
    assert tet.name == "tet" and tet.height == pytest.approx(1.0)
    path = tmp_path / "tet.obj"
    path.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in v) + "".join(f"f {a+1} {b+1} {c+1}\n" for a, b, c in t))
    zup = kiji.Body.load(str(path), up="z", scale=0.5)
    assert zup.height == pytest.approx(1.0) and zup.report["up_source"] == "option"
    with pytest.raises(kiji.InputError):
        kiji.Body.load(str(tmp_path / "missing.obj"))
    with pytest.raises(kiji.InputError):
        kiji.Body.load(str(path), up="sideways")
    with pytest.raises(kiji.InputError):
        kiji.Body.from_triangles(v, np.array([[0, 1, 9]]))


def test_drape_on_a_body_rests_on_it():
    s = kiji.Session(body=kiji.Body.default())
    g = s.add_garment(kiji.rectangle(0.5, 0.5, spacing=0.05))
    s.drape(seconds=1.0)
    m = s.measure()
    assert m.contacts > 0
    assert m.max_penetration < g.material.thickness
    assert g.bounds[0, 1] > 0.5, "it rests on the shoulders, it did not fall through"
    assert s.time == pytest.approx(1.0)


def test_last_step_reports_the_self_collision_work():
    s = kiji.Session()
    g = s.add_garment(kiji.rectangle(0.5, 0.5, nx=41, ny=41))
    assert s.last_step().self_gathers == 0, "nothing stepped yet"
    s.step()
    r = s.last_step()
    assert r.self_gathers >= 1
    assert not r.self_overloaded, "a flat cloth falling is far from the budget"
    assert r.strain_limited == 0, "a flat cloth falling freely is stretched nowhere"
    # Crushed into a 1 cm cube and thrown about: a knot, whose search keeps only its budget.
    rng = np.random.default_rng(3)
    g.positions = rng.uniform(0.0, 0.01, size=(41 * 41, 3))
    g.velocities = rng.uniform(-3.0, 3.0, size=(41 * 41, 3))
    s.step()
    r = s.last_step()
    assert r.self_overloaded, r
    # Its 12 mm edges thrown about a 1 cm cube: the strain limit finds most of them every substep.
    assert r.strain_limited > 10 * g.vertex_count, r
    assert np.isfinite(g.positions).all()


def test_cloth_at_rest_sleeps_and_a_script_edit_wakes_it():
    # A cloth lying on a floor: at rest, it falls asleep (no longer computed) and stays exactly put;
    # a vertex lifted by the script falls back instead of floating where it was left.
    floor = kiji.Body.from_triangles(np.array([[-2, 0, -2], [2, 0, -2], [2, 0, 2], [-2, 0, 2]], float),
                                      np.array([[0, 2, 1], [0, 3, 2]]), name="floor")
    g = kiji.rectangle(1.0, 1.0, nx=33, ny=33)
    p = g.positions
    g.positions = np.column_stack([p[:, 0] - 0.5, np.full(len(p), g.material.thickness), 0.5 - p[:, 1]])
    s = kiji.Session(body=floor)
    s.add_garment(g)
    for _ in range(60):
        s.step()
    assert s.measure().sleeping == s.measure().vertices == 33 * 33
    before = s.garment(0).positions.copy()
    for _ in range(10):
        s.step()
    assert np.array_equal(s.garment(0).positions, before)
    lifted = s.garment(0).positions.copy()
    lifted[16 * 33 + 16, 1] += 0.05
    s.garment(0).positions = lifted
    for _ in range(30):
        s.step()
    assert s.garment(0).positions[16 * 33 + 16, 1] < 0.01, "it fell back onto the floor"
    with pytest.raises(kiji.InputError, match="sleep_after"):
        kiji.SolverParams(sleep_after=-1)
    off = kiji.SolverParams(sleep_after=0)
    assert off.sleep_after == 0 and off.sleep_distance == pytest.approx(0.005)


@pytest.mark.parametrize("n", [70, 40])
def test_a_session_is_the_same_on_one_thread_as_on_two(n):
    # The solver shares its work between threads (blocks of the cloth, colour groups, collision
    # subtrees): the garment must come out the same, bit for bit, whatever the machine's cores, so
    # that a journal replays and a peer's copy agrees. A cloth of 4,900 vertices (several blocks)
    # lands on the default body with self-collision, then is pinched with the local region; so does
    # one of 1,600 (one block, whose pass over the body's edges the threads share another way).
    code = (
        "import hashlib, kiji\n"
        "s = kiji.Session(body=kiji.Body.default())\n"
        f"g = s.add_garment(kiji.rectangle(0.8, 0.8, nx={n}, ny={n}))\n"
        "kiji.place_over_body(g, s.body)\n"
        "s.step(12)\n"
        f"c = g.positions[{n // 2} * {n} + {n // 2}]\n"
        "s.pinch([c, c + (0.05, 0.1, 0), c + (0.1, 0.15, 0)], local_radius=0.15)\n"
        "print(hashlib.sha256(g.positions.tobytes()).hexdigest(), s.measure().contacts)\n")
    outs = []
    for threads in ("1", "2"):
        env = dict(os.environ, KIJI_THREADS=threads)
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
        assert out.returncode == 0, out.stderr
        outs.append(out.stdout.split())
    assert int(outs[0][1]) > 0, "the cloth reached the body"
    assert outs[0][0] == outs[1][0], "one thread and two gave different garments"
