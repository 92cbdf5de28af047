"""Everything the core's headers declare has its Python counterpart or a stated reason why not
(docs/python_core.md), and help() on every object of the package says what it is."""
import inspect
import os
import re

import kiji
from conftest import REPO
from core_names import all_names

TABLE = os.path.join(REPO, "docs", "python_core.md")
ROW = re.compile(r"^\| ([\w.]+\.h) \| `([^`]+)` \| (.+) \|$")


def table_rows():
    rows = {}
    for line in open(TABLE, encoding="utf-8"):
        m = ROW.match(line.strip())
        if m:
            rows[(m.group(1), m.group(2))] = m.group(3)
    return rows


def resolve(ref):
    obj = kiji
    for part in ref.split(".")[1:]:
        obj = getattr(obj, part)
    return obj


def test_every_public_name_of_the_headers_has_a_python_counterpart_or_a_reason():
    declared = {(h, n) for h, names in all_names(os.path.join(REPO, "core", "include", "kiji")).items() for n in names}
    assert len(declared) > 400  # the reader found the headers' declarations
    rows = table_rows()
    missing = sorted(declared - rows.keys())
    assert not missing, ("public names of the core with no row in docs/python_core.md (add the Python "
                         f"counterpart, or 'none: why'): {missing}")
    stale = sorted(rows.keys() - declared)
    assert not stale, f"rows of docs/python_core.md for names the headers no longer declare: {stale}"


def test_every_python_counterpart_named_exists_and_every_reason_says_something():
    bad, thin = [], []
    for (header, name), cell in table_rows().items():
        refs = re.findall(r"`(kiji\.[\w.]+)`", cell)
        if not refs:
            if not cell.startswith("none: ") or len(cell) < 30:
                thin.append(f"{header} {name}: {cell}")
            continue
        for ref in refs:
            try:
                resolve(ref)
            except AttributeError:
                bad.append(f"{header} {name}: {ref}")
    assert not bad, f"Python names in docs/python_core.md that the package does not have: {bad}"
    assert not thin, f"rows with neither a Python name nor a reason ('none: ...'): {thin}"


def _says_what_it_is(obj):
    doc = inspect.getdoc(obj) or ""
    # pybind11 puts the signature first; a line of prose must follow it.
    prose = [l for l in doc.splitlines() if l.strip() and not re.match(r"^\s*(\d+\.\s*)?\w*\(.*\)\s*->", l)
             and l.strip() != "Overloaded function."]
    return bool(prose)


def test_help_on_every_object_says_what_it_is():
    silent = []
    for name in kiji.__all__:
        obj = getattr(kiji, name)
        if isinstance(obj, (str, int, float)):
            continue
        if not _says_what_it_is(obj):
            silent.append(name)
        if isinstance(obj, type) and obj.__module__.startswith("kiji"):
            for attr, value in vars(obj).items():
                if attr.startswith("_") or getattr(value, "_kiji_tool", None):
                    continue
                if isinstance(value, property) or callable(value):
                    if not _says_what_it_is(value):
                        silent.append(f"{name}.{attr}")
    assert not silent, f"objects whose help() does not say what they are: {silent}"
