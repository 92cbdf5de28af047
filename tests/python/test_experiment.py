"""The paper's experiment (its section 5), as scripts/main.sh runs it: a tunic made on the default body.
What a designer checks on it: one piece with a hem, a neck opening and two armholes, worn on the body
and not in it, unstretched, symmetric, level, with the painted letters on the chest facing the viewer."""
import numpy as np
import pytest

import kiji
from kiji.examples import experiment


@pytest.fixture(scope="module")
def tunic(tmp_path_factory):
    out = tmp_path_factory.mktemp("experiment")
    settings = experiment.Settings(out=str(out / "garment.glb"), picture=str(out / "garment.png"),
                                   stages=str(out / "stages.png"), verbose=False)
    return settings, experiment.run_experiment(settings)


def test_it_is_made_by_the_papers_operations(tunic):
    settings, r = tunic
    tools = [j.tool for j in r.session.journal]
    # The head opening: one closed stroke of the knife, along the drawn ellipse.
    assert tools[0] == "cut" and r.session.journal[0].params["mode"] == "line"
    # The needle, and the hands that hold the hems and the front's neckline apart as the panels fall
    # and carry each seam's first pair together.
    sewn = tools[1:tools.index("paint")]
    assert "sew" in sewn and set(sewn) <= {"sew", "pinch"}
    assert set(tools[tools.index("paint"):]) == {"paint"}
    assert r.garment.vertex_count >= 5000 and settings.spacing <= 0.015


def test_one_piece_with_a_hem_a_neck_opening_and_two_armholes(tunic):
    _, r = tunic
    g = r.garment
    assert g.piece_count == 1 and g.is_valid()
    assert sorted(r.checks.border_loops) == ["hem", "left armhole", "neck", "right armhole"]
    loops = {name: g.positions[np.array(loop)] for name, loop in zip(_names(g), g.border_loops())}
    body = r.session.body
    # The neck opening goes round the neck, between the shoulders and the chin.
    neck = loops["neck"]
    assert 1.3 < neck[:, 1].mean() < 1.5
    assert neck[:, 0].min() < -0.05 < 0.05 < neck[:, 0].max(), "it has the neck inside it, left to right"
    # The armholes are one on each side, where the arms leave the body.
    assert loops["left armhole"][:, 0].mean() < -0.15 and loops["right armhole"][:, 0].mean() > 0.15
    for side in ("left armhole", "right armhole"):
        assert 1.0 < loops[side][:, 1].mean() < 1.45
    # The hem goes all round the body, below the waist.
    hem = loops["hem"]
    assert hem[:, 1].max() < 1.0
    assert hem[:, 0].min() < -0.15 and hem[:, 0].max() > 0.15
    # In front of the trunk and behind it, at the hem's own height.
    v = body.vertices
    trunk = v[(v[:, 1] > hem[:, 1].min()) & (v[:, 1] < hem[:, 1].max()) & (np.abs(v[:, 0]) < 0.2)]
    assert len(trunk) > 0
    assert hem[:, 2].min() < trunk[:, 2].min() and hem[:, 2].max() > trunk[:, 2].max(), "front and back"


def _names(g):
    """The experiment's names for the border loops, in the order of g.border_loops()."""
    loops = [g.positions[np.array(loop)] for loop in g.border_loops()]
    by_height = sorted(range(len(loops)), key=lambda i: loops[i][:, 1].mean())
    names = [""] * len(loops)
    names[by_height[0]], names[by_height[-1]] = "hem", "neck"
    for i in by_height[1:-1]:
        names[i] = "left armhole" if loops[i][:, 0].mean() < 0 else "right armhole"
    return names


def test_worn_on_the_body_and_not_in_it(tunic):
    _, r = tunic
    c, g = r.checks, r.garment
    assert c.contacts > 200, "it rests on the shoulders and the chest"
    assert c.max_penetration < 0.5 * g.material.thickness
    assert c.inside_fraction < 0.002
    lo, hi = g.bounds
    assert hi[1] < 1.5 and lo[1] > 0.6, "it hangs from the shoulders to the hips"


def test_the_cloth_is_not_stretched(tunic):
    assert tunic[1].checks.max_strain < 0.10


def test_it_hangs_symmetric_with_a_level_hem(tunic):
    c = tunic[1].checks
    assert c.asymmetry < 0.02
    assert c.hem_range < 0.07


def test_the_letters_are_on_the_chest_facing_the_viewer(tunic):
    settings, r = tunic
    c = r.checks
    # Each letter's strokes: at least a brush's width along every 3 mm of them.
    assert c.painted_texels > 1500
    assert c.painted_seen > 0.95
    # On the chest: the painted cloth is in front of the body, between the armpits and the waist.
    painted = experiment.painted_mask(r.garment, settings.color)
    rows, cols = np.nonzero(painted)
    h, w = painted.shape
    points, _ = kiji.geometry.point_at_uv(r.garment, np.c_[(cols + 0.5) / w, (rows + 0.5) / h][::25])
    points = points[~np.isnan(points).any(axis=1)]
    assert 1.0 < points[:, 1].min() and points[:, 1].max() < 1.4
    assert abs(points[:, 0].mean()) < 0.03, "centred"
    assert points[:, 2].min() > experiment.body_axis_z(r.session.body), "on the front"
    # And the front picture shows them: the paint's yellow fills a part of it.
    image = kiji.read_png(settings.picture)
    yellow = (image[..., 0] > 180) & (image[..., 1] > 150) & (image[..., 2] < 90)
    assert yellow.sum() > 1500


def test_it_writes_the_garment_and_the_pictures(tunic):
    settings, r = tunic
    back = kiji.load_garment(settings.out)
    assert back.vertex_count == r.garment.vertex_count
    assert np.array_equal(back.texture, r.garment.texture)
    assert kiji.read_png(settings.picture).shape == (settings.picture_size[1], settings.picture_size[0], 4)
    stages = kiji.read_png(settings.stages)
    assert stages.shape[1] == 4 * stages.shape[0], "four square stages side by side"


def test_bad_settings_say_what_to_change():
    with pytest.raises(kiji.InputError, match="head opening"):
        experiment.run_experiment(experiment.Settings(neck=0.4, out=None, picture=None, stages=None, verbose=False))
    with pytest.raises(kiji.InputError, match="stroke font"):
        experiment.run_experiment(experiment.Settings(text="KIJI?", out=None, picture=None, stages=None,
                                                      verbose=False))
    with pytest.raises(kiji.InputError, match="armhole"):
        experiment.run_experiment(experiment.Settings(armhole=0.7, out=None, picture=None, stages=None,
                                                      verbose=False))
    with pytest.raises(kiji.InputError, match="neck_forward"):
        experiment.run_experiment(experiment.Settings(neck_forward=0.65, out=None, picture=None, stages=None,
                                                      verbose=False))
    with pytest.raises(kiji.InputError, match="armhole"):
        experiment.run_experiment(experiment.Settings(neck_forward=0.25, out=None, picture=None, stages=None,
                                                      verbose=False))
