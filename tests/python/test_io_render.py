"""Export (glb, obj) and a PNG picture of the scene without a window."""
import os

import numpy as np
import pytest

import kiji
from conftest import flat_session, line


def test_export_glb_and_obj_round_trip(tmp_path):
    s, g = flat_session(0.5, 0.5, 6, 6)
    s.simulating = False
    s.paint(line((0.1, 0.2, 0.001), (0.4, 0.2, 0.001), 10), color=(0, 1, 0), resolution=32)
    for ext in ("glb", "obj"):
        path = str(tmp_path / f"g.{ext}")
        s.export(path)
        back = kiji.load_garment(path)
        assert back.face_count == g.face_count and back.vertex_count == g.vertex_count
        assert np.allclose(np.sort(back.positions, axis=0), np.sort(g.positions, axis=0), atol=1e-6)
        assert np.array_equal(back.texture, g.texture)
    assert os.path.exists(tmp_path / "g.png"), "the obj's texture beside it"
    with pytest.raises(kiji.InputError):
        g.export(str(tmp_path / "g.fbx"))
    with pytest.raises(kiji.InputError):
        kiji.load_garment(str(tmp_path / "missing.glb"))


def test_render_a_picture_without_a_window(tmp_path):
    s = kiji.Session(body=kiji.Body.default())
    g = s.add_garment(kiji.rectangle(0.6, 0.6, spacing=0.1))
    kiji.place_over_body(g, s.body)
    image = s.render(width=160, height=120)
    assert image.shape == (120, 160, 4) and image.dtype == np.uint8
    assert len(np.unique(image.reshape(-1, 4), axis=0)) > 10, "something was drawn"
    path = str(tmp_path / "scene.png")
    s.save_picture(path, width=160, height=120)
    assert np.array_equal(kiji.read_png(path), image)
    alone = kiji.render([g], None, camera=kiji.Camera(eye=(0, 2.5, 2), target=(0, 1.5, 0)), width=64, height=48)
    assert alone.shape == (48, 64, 4)
    with pytest.raises(kiji.InputError):
        s.render(width=0, height=10)
    with pytest.raises(TypeError):
        kiji.write_png(np.zeros((4, 4, 4)), str(tmp_path / "x.png"))
