"""The paper's experiment (its section 5) on a small garment: one piece, worn on the body, lettered."""
import os

import numpy as np

import kiji
from kiji.examples import experiment


def test_the_experiment_makes_one_lettered_piece_worn_on_the_body(tmp_path):
    settings = experiment.Settings(spacing=0.05, drape_seconds=1.5, settle_seconds=1.5, substeps=8, texture=256,
                                   out=str(tmp_path / "garment.glb"), picture=str(tmp_path / "garment.png"),
                                   picture_size=(320, 240), verbose=False)
    r = experiment.run_experiment(settings)
    g = r.garment
    assert g.piece_count == 1 and g.is_valid()
    assert [j.tool for j in r.session.journal] == ["cut", "cut", "sew", "sew"] + ["paint"] * (len(r.session.journal) - 4)
    # Worn: resting on the body (touching it, not inside it, held up by the shoulders).
    m = r.measures
    assert m.contacts > 10
    assert m.max_penetration < g.material.thickness
    assert r.inside_fraction < 0.02
    body = r.session.body
    assert g.bounds[1, 1] > 1.2 and g.bounds[0, 1] > 0.3, "it hangs from the shoulders, above the floor"
    # Painted letters in its texture, and in the file.
    assert r.painted_texels > 200
    back = kiji.load_garment(settings.out)
    assert np.array_equal(back.texture, g.texture)
    image = kiji.read_png(settings.picture)
    assert image.shape == (240, 320, 4)
