"""One drape: Session.drape drapes a garment as `kiji drape` (kiji.drape) does, step for step, and
gives the session back its interactive settings afterwards. (kiji.drape lets a flat garment of 2,000
vertices or more fall first as a coarse copy; these garments are smaller, as coarse_ratio=1 is.)"""
import os
import subprocess

import numpy as np
import pytest

import kiji
from conftest import REPO

# A game character no other test drapes on: a T pose of 47,808 triangles once import has rounded it.
MRFIXIT = "/usr/share/assimp/models/IQM/mrfixit.iqm"


def _cloth_of(width, height, spacing):
    return kiji.rectangle(width, height, spacing=spacing, material=kiji.Material("cotton"))


def _cloth():
    return _cloth_of(0.8, 0.6, 0.03)


def test_session_drape_is_the_drape_of_kiji_drape():
    body = kiji.Body.default()
    alone = _cloth()
    kiji.place_over_body(alone, body)
    result = kiji.drape(alone, body, seconds=1.0)
    assert result.steps == 60
    measures = result.measures

    s = kiji.Session(body=body)
    g = s.add_garment(_cloth())
    s.drape(seconds=1.0)
    assert np.array_equal(g.positions, alone.positions), "the same drape, step for step"
    assert s.measure().max_strain == measures.max_strain
    # The session's own settings are back: the interactive ones.
    assert s.solver_params.substeps == 10 and s.frame_rate == 60
    assert s.time == pytest.approx(1.0)


def test_the_drape_settings_are_what_keeps_the_cloth_unstretched():
    # The same cloth let fall at the interactive 10 substeps lands otherwise, and stretches more.
    body = kiji.Body.default()
    draped = kiji.Session(body=body)
    g = draped.add_garment(_cloth())
    draped.drape(seconds=1.0)
    fallen = kiji.Session(body=body)
    cloth = _cloth()
    kiji.place_over_body(cloth, body)
    h = fallen.add_garment(cloth)
    assert fallen.solver_params.substeps == 10
    fallen.simulate(1.0)
    assert not np.array_equal(g.positions, h.positions)
    assert draped.measure().max_strain < 0.07
    assert draped.measure().max_strain < fallen.measure().max_strain


def test_a_paused_session_drapes_too_and_is_paused_again():
    # As Kiji Studio's Simulation > Drape: the user paused to arrange things, then asked for a drape.
    body = kiji.Body.default()
    alone = _cloth()
    kiji.place_over_body(alone, body)
    kiji.drape(alone, body, seconds=0.5)
    s = kiji.Session(body=body)
    g = s.add_garment(_cloth())
    s.simulating = False
    s.drape(seconds=0.5)
    assert np.array_equal(g.positions, alone.positions), "the same drape as a running session's"
    assert not s.simulating


def test_the_drape_keeps_the_users_own_settings_but_the_substeps():
    # A user's settings are the drape's (here: no gravity, so nothing falls), with the drape's
    # substeps; all of them come back after it.
    body = kiji.Body.default()
    s = kiji.Session(body=body)
    g = s.add_garment(_cloth())
    p = s.solver_params
    p.gravity = (0, 0, 0)
    p.substeps = 12
    s.solver_params = p
    s.drape(seconds=0.5)
    placed = _cloth()
    kiji.place_over_body(placed, body)
    assert np.abs(g.positions - placed.positions).max() < 1e-3, "without gravity the cloth stays where it was laid"
    assert s.solver_params.substeps == 12 and np.array_equal(s.solver_params.gravity, [0, 0, 0])
    substeps = [op.solver_params.substeps for op in s.operations if op.kind == "set_solver_params"]
    assert 40 in substeps, "it ran at the drape's substeps"


def test_a_drape_without_a_body_changes_nothing():
    s = kiji.Session()
    g = s.add_garment(_cloth())
    before = g.positions
    with pytest.raises(kiji.InputError, match="body"):
        s.drape(seconds=1.0)
    assert np.array_equal(g.positions, before) and s.time == 0
    assert s.solver_params.substeps == 10


def test_a_new_garment_through_the_body_is_refused_until_placed_over_it():
    # kiji.rectangle stands upright at the origin, through the body's legs: draped there, its edges
    # held it through them. The drape says what to do, and the garment is as it was.
    body = kiji.Body.load(MRFIXIT)
    g = _cloth_of(1.2, 1.0, 0.03)
    before = g.positions
    with pytest.raises(kiji.InputError, match="inside the body.*place_over_body"):
        kiji.drape(g, body, seconds=0.5)
    assert np.array_equal(g.positions, before)
    kiji.place_over_body(g, body)
    r = kiji.drape(g, body, seconds=0.5)
    assert r.steps == 30 and r.measures.max_penetration == 0


def test_kiji_drape_kiji_drape_in_python_and_session_drape_are_one_drape(tmp_path):
    # A rounded body (Loop subdivision at import), whose points the solver collides with the cloth:
    # a session's body, carried as bytes like a journal's or a peer's, must drape as the loaded one.
    cli = os.environ.get("KIJI_CLI", os.path.join(REPO, "build", "bin", "kiji"))
    if not os.access(cli, os.X_OK):
        pytest.fail(f"no kiji command at {cli}: build it (cmake --build build) or set KIJI_CLI")
    out = tmp_path / "cli.glb"
    run = subprocess.run([cli, "drape", "--body", MRFIXIT, "--height", "1.8", "--garment", "rect:0.8,0.6,0.03",
                          "--seconds", "0.5", "--out", str(out), "--no-picture"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr

    body = kiji.Body.load(MRFIXIT, height=1.8)
    assert body.report["smoothing"] > 0
    alone = _cloth_of(0.8, 0.6, 0.03)
    kiji.place_over_body(alone, body)
    kiji.drape(alone, body, seconds=0.5)
    s = kiji.Session(body=body)
    g = s.add_garment(_cloth_of(0.8, 0.6, 0.03))
    s.drape(seconds=0.5)
    assert np.array_equal(g.positions, alone.positions), "Session.drape is kiji.drape, bit for bit"
    assert s.measure().contacts > 0

    # The command's file holds the same garment: written from Python, the same bytes.
    alone.name = "drape"
    alone.export(str(tmp_path / "python.glb"))
    assert (tmp_path / "python.glb").read_bytes() == out.read_bytes()

    # And the session's journal replays to it on a new session.
    s.save_journal(str(tmp_path / "drape.json"))
    again = kiji.Session()
    again.replay(str(tmp_path / "drape.json"))
    assert np.array_equal(again.garment(0).positions, alone.positions)


def test_a_cloth_draped_on_a_t_pose_character_rests_on_its_head_and_shoulders():
    # `kiji drape --body mrfixit.iqm --height 1.8`'s garment (the default), on a figure whose head
    # and shoulders are all it can rest on: the highest points of its rounded head are tips that
    # the solver collides as points, and they hold the cloth by friction as the body's faces do.
    # Without that friction this cloth slid forward off them from 0.6 s and ended on the floor.
    body = kiji.Body.load(MRFIXIT, height=1.8)
    cloth = _cloth_of(1.4, 1.0, 0.01)
    kiji.place_over_body(cloth, body)
    m = kiji.drape(cloth, body, seconds=3.0).measures
    assert m.kinetic_energy < 0.05, "at rest"
    assert m.max_penetration == 0, "nothing inside the body"
    assert m.contacts > cloth.vertex_count // 10, "on the body"
    lo, hi = body.bounds
    shoulders = lo[1] + 0.75 * (hi[1] - lo[1])
    assert np.percentile(cloth.positions[:, 1], 90) > shoulders, "hanging from the head, not on the floor"


def _fine_cloth():
    # 2,214 vertices: enough for a drape to let it fall as a coarse copy first.
    return _cloth_of(0.8, 0.6, 0.015)


def test_a_new_flat_garment_drapes_coarse_first_as_one_change_that_undo_takes_back():
    body = kiji.Body.default()
    alone = _fine_cloth()
    assert alone.vertex_count >= 2000
    kiji.place_over_body(alone, body)
    placed = alone.positions
    expected = kiji.drape(alone, body, seconds=1.0)
    assert expected.coarse_vertices > 0

    s = kiji.Session(body=body)
    g = s.add_garment(_fine_cloth())
    s.simulating = False  # as in Kiji Studio: paused to arrange things, then draped
    kinds = [op.kind for op in s.operations]
    assert kiji.drapes_coarse(g, seconds=1.0) and not kiji.drapes_coarse(g, seconds=0.5)
    results = s.drape(seconds=1.0)
    assert len(results) == 1 and results[0].coarse_vertices == expected.coarse_vertices
    assert np.array_equal(g.positions, alone.positions), "kiji.drape's drape, bit for bit"
    assert results[0].measures.max_strain == expected.measures.max_strain < 0.07
    assert results[0].measures.max_penetration == 0
    # Laid over the body, then the draped garment: two changes; the clock, the pause and the
    # interactive settings as they were.
    assert [op.kind for op in s.operations] == kinds + ["set_garment", "set_garment"]
    assert s.time == 0 and not s.simulating and s.solver_params.substeps == 10
    assert not kiji.drapes_coarse(g), "draped, it is no longer flat: a drape again steps it"
    s.undo()
    assert np.array_equal(g.positions, placed), "undo takes the drape back to the garment laid over the body"

    # The same garment stepped by the session instead: the clock moves the drape's second.
    stepped = kiji.Session(body=body)
    h = stepped.add_garment(_fine_cloth())
    r = stepped.drape(seconds=1.0, coarse=False)
    assert r[0].coarse_vertices == 0 and r[0].steps == 60
    assert stepped.time == pytest.approx(1.0)
    assert r[0].measures.max_strain < 0.07 and r[0].measures.max_penetration == 0
    assert not np.array_equal(h.positions, g.positions)


def test_a_coarse_drape_refuses_a_garment_through_the_body_and_changes_nothing():
    body = kiji.Body.load(MRFIXIT)
    s = kiji.Session(body=body)
    g = s.add_garment(_cloth_of(1.2, 1.0, 0.02))  # upright at the origin, through the legs
    assert g.vertex_count >= 2000
    before, ops = g.positions, len(s.operations)
    with pytest.raises(kiji.InputError, match="inside the body.*place_over_body"):
        s.drape(seconds=1.0, place=False)
    assert np.array_equal(g.positions, before) and len(s.operations) == ops and s.time == 0
    # Laid over the body by the drape itself, it falls.
    r = s.drape(seconds=1.0)
    assert r[0].coarse_vertices > 0 and r[0].measures.max_penetration == 0
