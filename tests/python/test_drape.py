"""One drape: Session.drape drapes a garment as `kiji drape` (kiji.drape) does, step for step, and
gives the session back its interactive settings afterwards."""
import numpy as np
import pytest

import kiji


def _cloth():
    return kiji.rectangle(0.8, 0.6, spacing=0.03, material=kiji.Material("cotton"))


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


def test_a_drape_without_a_body_changes_nothing():
    s = kiji.Session()
    g = s.add_garment(_cloth())
    before = g.positions
    with pytest.raises(kiji.InputError, match="body"):
        s.drape(seconds=1.0)
    assert np.array_equal(g.positions, before) and s.time == 0
    assert s.solver_params.substeps == 10
