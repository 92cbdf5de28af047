"""assimp reads mesh files in a child process: a file that crashes it, or needs more memory or time
than allowed, is a ValueError, and the script's session goes on as it was."""
import zipfile

import numpy as np
import pytest

import kiji


def deep_fbx(tmp_path):
    # Objects nested 200,000 deep: assimp 5.2's FBX text parser recurses off the end of its stack.
    depth = 200000
    text = ("; FBX 7.4.0 project file\nFBXHeaderExtension:  {\n\tFBXHeaderVersion: 1003\n\tFBXVersion: 7400\n}\n"
            "Objects:  {\n" + "A: {\n" * depth + "}\n" * depth + "}\n")
    path = tmp_path / "deep.fbx"
    path.write_text(text)
    return str(path)


def grid_obj(tmp_path, n):
    lines = [f"v {i * 0.001} {j * 0.001} 0" for j in range(n) for i in range(n)]
    for j in range(n - 1):
        for i in range(n - 1):
            a = j * n + i + 1
            lines += [f"f {a} {a + 1} {a + n + 1}", f"f {a} {a + n + 1} {a + n}"]
    path = tmp_path / f"grid{n}.obj"
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def test_a_file_that_crashes_assimp_leaves_the_session_as_it_was(tmp_path):
    s = kiji.Session()
    s.body = kiji.Body.default(height=1.7)
    g = s.add_garment(kiji.rectangle(0.6, 0.4, nx=13, ny=9))
    s.step(5)
    before = g.positions.copy()
    with pytest.raises(ValueError, match="assimp crashed while reading it.*this session is unharmed"):
        kiji.Body.load(deep_fbx(tmp_path))
    # The interpreter and its session live on, and the session goes on stepping.
    s.step(5)
    assert np.isfinite(g.positions).all()
    assert not np.array_equal(g.positions, before)


def test_memory_and_time_limits_stop_a_reader_and_say_which(tmp_path):
    path = grid_obj(tmp_path, 300)
    with pytest.raises(ValueError, match="more than 8 MiB of memory"):
        kiji.Body.load(path, memory_limit_mb=8)
    with pytest.raises(ValueError, match="took longer than 0.001 s"):
        kiji.load_garment(path, timeout=0.001)
    body = kiji.Body.load(path, smooth=False)
    assert len(body.vertices) == 300 * 300


def test_a_zipped_collada_file_that_unpacks_without_end_is_stopped_at_the_memory_limit(tmp_path):
    # assimp 5.2 unpacks a zip entry once for every image that names it: 40 images naming one 10 MB
    # entry ask for 400 MB from a 12 KB file.
    images = "".join(f'<image id="i{k}"><init_from>big.png</init_from></image>' for k in range(40))
    dae = ('<?xml version="1.0"?><COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">'
           '<asset><unit meter="1"/><up_axis>Y_UP</up_axis></asset>'
           f'<library_images>{images}</library_images>'
           '<library_geometries><geometry id="g"><mesh><source id="p">'
           '<float_array id="pa" count="9">0 0 0 1 0 0 0 1 0</float_array><technique_common>'
           '<accessor source="#pa" count="3" stride="3"><param name="X" type="float"/>'
           '<param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common></source>'
           '<vertices id="v"><input semantic="POSITION" source="#p"/></vertices>'
           '<triangles count="1"><input semantic="VERTEX" source="#v" offset="0"/><p>0 1 2</p></triangles>'
           '</mesh></geometry></library_geometries>'
           '<library_visual_scenes><visual_scene id="s"><node id="n"><instance_geometry url="#g"/></node>'
           '</visual_scene></library_visual_scenes><scene><instance_visual_scene url="#s"/></scene></COLLADA>')
    path = tmp_path / "unpacks.zae"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED, compresslevel=9) as z:
        z.writestr("model.dae", dae)
        z.writestr("big.png", b"\0" * (10 << 20))
    assert path.stat().st_size < 64 * 1024
    with pytest.raises(ValueError, match="needed more than 128 MiB of memory"):
        kiji.Body.load(str(path), memory_limit_mb=128)
    # With the memory it asks for, the same file is a body of one triangle.
    assert len(kiji.Body.load(str(path), memory_limit_mb=2048, smooth=False).triangles) == 1
