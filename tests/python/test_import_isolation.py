"""assimp reads mesh files in a child process: a file that crashes it, or needs more memory or time
than allowed, is a ValueError, and the script's session goes on as it was."""
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
