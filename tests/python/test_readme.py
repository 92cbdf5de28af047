"""The README's front page: its two commands come first, and its Python example runs as written."""
import os
import re

import kiji

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _readme() -> str:
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
        return f.read()


def test_the_two_commands_come_first():
    first = re.search(r"```sh\n(.*?)```", _readme(), re.S).group(1)
    assert [line.split()[0] for line in first.strip().splitlines()] == ["scripts/main.sh", "scripts/test.sh"]


def test_the_python_example_runs(tmp_path, monkeypatch):
    code = re.search(r"## From Python\n\n```python\n(.*?)```", _readme(), re.S).group(1)
    monkeypatch.chdir(tmp_path)
    os.makedirs("out")
    scope = {}
    exec(compile(code, "README.md", "exec"), scope)
    g, s = scope["g"], scope["s"]
    assert g.vertex_count > 2000 and g.piece_count == 1
    assert s.measure().max_strain < 0.10
    assert (tmp_path / "out" / "garment.glb").stat().st_size > 0
    assert kiji.read_png(str(tmp_path / "out" / "garment.png")).shape[2] == 4
    painted = (abs(g.texture[..., :3].astype(int) - [255, 204, 26]).max(axis=2) <= 2).sum()
    assert painted > 100, "the paint is on the cloth"
