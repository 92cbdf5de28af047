"""The installed package: libkiji and the tools inside it, the `kiji` command, the type stubs."""
import ast
import os
import subprocess
import sys

import kiji
from conftest import REPO


def test_the_installed_package_is_used_not_the_source_tree():
    here = os.path.dirname(kiji.__file__)
    assert not here.startswith(os.path.join(REPO, "python")), here
    assert "site-packages" in here
    assert os.path.exists(os.path.join(here, "lib", "libkiji.so.0"))
    assert os.path.isdir(kiji.PACKAGE_PLUGIN_FOLDER)
    assert kiji.version() == kiji.__version__


def test_the_package_finds_its_tools_without_the_build_tree():
    env = {k: v for k, v in os.environ.items() if k != "KIJI_PLUGIN_PATH"}
    code = "import kiji; print(','.join(t.id for t in kiji.tools()))"
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd="/", capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "cut,paint,pin,pinch,sew,tear"


def test_kiji_run_runs_a_design_script(tmp_path):
    script = tmp_path / "design.py"
    script.write_text(
        "import sys, kiji\n"
        "s = kiji.Session()\n"
        "g = s.add_garment(kiji.rectangle(1, 1, nx=11, ny=11))\n"
        "s.simulating = False\n"
        "s.cut([(-0.1, 0.52, 0.01), (0.5, 0.52, 0.01), (1.1, 0.52, 0.01)])\n"
        "print('pieces', g.piece_count, sys.argv[1:])\n")
    kiji_cmd = os.path.join(os.path.dirname(sys.executable), "kiji")
    out = subprocess.run([kiji_cmd, "run", str(script), "x", "y"], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "pieces 2 ['x', 'y']"
    tools = subprocess.run([kiji_cmd, "tools"], capture_output=True, text=True, check=True).stdout
    assert "paint" in tools and "radius" in tools
    bad = subprocess.run([kiji_cmd, "run", str(tmp_path / "none.py")], capture_output=True, text=True)
    assert bad.returncode == 2 and "no such script" in bad.stderr


def test_type_stubs_cover_the_api_and_every_tool():
    stub = os.path.join(os.path.dirname(kiji.__file__), "__init__.pyi")
    text = open(stub, encoding="utf-8").read()
    tree = ast.parse(text)
    classes = {n.name: n for n in tree.body if isinstance(n, ast.ClassDef)}
    for name in ("Session", "Garment", "Body", "Material", "SolverParams", "ToolEvent", "InputError"):
        assert name in classes
    methods = {f.name: f for f in classes["Session"].body if isinstance(f, ast.FunctionDef)}
    for tool in ("cut", "paint", "pin", "pinch", "sew", "tear"):
        assert tool in methods
    paint_args = [a.arg for a in methods["paint"].args.kwonlyargs]
    assert "color" in paint_args and "radius" in paint_args
    assert "Literal['line', 'stroke', 'vertex']" in ast.unparse(methods["cut"])
    garment = {f.name for f in classes["Garment"].body if isinstance(f, ast.FunctionDef)}
    assert {"positions", "faces", "uvs", "export"} <= garment
    assert os.path.exists(os.path.join(os.path.dirname(kiji.__file__), "py.typed"))


def test_stubgen_regenerates_the_stubs_from_every_tools_declarations(tmp_path, probe_dir):
    # As the stubgen's help says: run again with a third-party tool on KIJI_PLUGIN_PATH to add it.
    out = tmp_path / "kiji.pyi"
    env = dict(os.environ, KIJI_PLUGIN_PATH=probe_dir)
    run = subprocess.run([sys.executable, "-m", "kiji.stubgen", str(out)], env=env, check=True, capture_output=True,
                         text=True)
    assert "(7 tools)" in run.stdout, run.stdout
    tree = ast.parse(out.read_text())
    classes = {n.name: n for n in tree.body if isinstance(n, ast.ClassDef)}
    methods = {f.name: f for f in classes["Session"].body if isinstance(f, ast.FunctionDef)}

    if "probe" not in kiji.registry().ids():
        kiji.load_plugins(probe_dir)
    infos = {t.id: t for t in kiji.tools()}
    assert set(infos) == {"cut", "paint", "pin", "pinch", "sew", "tear", "probe"}
    annotations = {"bool": "bool", "int": "int", "float": "float", "str": "str", "color": "float"}
    for tool_id, info in infos.items():
        method = methods[tool_id]
        kwonly = method.args.kwonlyargs
        declared = [p for p in info.parameters]
        # Each declared parameter is a keyword argument after the stroke's own, in declaration order,
        # with the declared default and a type that fits it.
        by_name = {a.arg: (a, d) for a, d in zip(kwonly, method.args.kw_defaults)}
        stub_names = [a.arg for a in kwonly if a.arg in {p.name for p in declared}]
        assert stub_names == [p.name for p in declared], tool_id
        for spec in declared:
            arg, default = by_name[spec.name]
            value = ast.literal_eval(default)
            expected = tuple(spec.default) if spec.type == "color" else spec.default
            assert value == expected and type(value) is type(expected), (tool_id, spec.name, value, spec.default)
            annotation = ast.unparse(arg.annotation)
            if spec.type == "choice":
                assert annotation == "Literal[" + ", ".join(repr(c) for c in spec.choices) + "]", annotation
            else:
                assert annotations[spec.type] in annotation, (tool_id, spec.name, annotation)
        assert ast.get_docstring(method) == info.description
    # The installed stubs are the same generator's output without the third-party tool.
    installed = open(os.path.join(os.path.dirname(kiji.__file__), "__init__.pyi"), encoding="utf-8").read()
    installed_session = next(n for n in ast.parse(installed).body if isinstance(n, ast.ClassDef) and n.name == "Session")
    assert {f.name for f in installed_session.body if isinstance(f, ast.FunctionDef)} == set(methods) - {"probe"}
