"""The `kiji` command of the Python package: run a design script with the installed Kiji.

    kiji run SCRIPT.py [ARGS...]   run a design script (as `python SCRIPT.py ARGS...` with kiji importable)
    kiji experiment [ARGS...]      the paper's experiment (see `kiji experiment --help`)
    kiji tools                     list the tools found, with their parameters
    kiji recover PATH [--export F] rebuild a session from its autosave file after a crash
    kiji stubgen [OUT.pyi]         regenerate the type stubs (include third-party tools)
    kiji version                   print Kiji's version
"""
from __future__ import annotations

import os
import runpy
import sys


def _tools() -> int:
    import kiji
    for info in kiji.tools():
        print(f"{info.id:8s} {info.label}: {info.description}")
        for p in info.parameters:
            rng = f" [{p.min:g}, {p.max:g}]" if p.min is not None else ""
            choices = f" {{{', '.join(p.choices)}}}" if p.choices else ""
            print(f"    {p.name} ({p.type}{rng}{choices}{' ' + p.unit if p.unit else ''}) = {p.default!r}: {p.help}")
    return 0


def _recover(args: list[str]) -> int:
    import argparse
    import kiji
    parser = argparse.ArgumentParser(prog="kiji recover", description="Rebuild a design session from its session "
                                     "file (an autosave): every operation whose call had returned.")
    parser.add_argument("path")
    parser.add_argument("--export", help="write garment 0 (.glb or .obj)")
    parser.add_argument("--save-journal", help="write the operations as a JSON journal")
    parser.add_argument("--repair", action="store_true", help="cut a damaged end off the file")
    a = parser.parse_args(args)
    try:
        s = kiji.recover(a.path, keep_saving=a.repair)
        r = s.recovery
        print(f"{a.path}: {r['operations']} operations recovered, {s.garment_count} garment(s), "
              f"clock at {s.time:.3f} s")
        if r["cancelled_strokes"]:
            print(f"  {r['cancelled_strokes']} stroke(s) left unfinished by the crash were cancelled")
        if r["damage"]:
            print(f"  the file's end was damaged ({r['damage']})" + (": cut off" if a.repair else ""))
        if a.export:
            s.export(a.export)
        if a.save_journal:
            s.save_journal(a.save_journal)
    except kiji.Error as e:
        print(f"kiji recover: {e}", file=sys.stderr)
        return 1
    return 0


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if not argv or argv[0] in ("-h", "--help", "help"):
        print(__doc__.strip())
        return 0 if argv else 2
    command, rest = argv[0], argv[1:]
    if command == "run":
        if not rest:
            print("usage: kiji run SCRIPT.py [ARGS...]", file=sys.stderr)
            return 2
        script = rest[0]
        if not os.path.isfile(script):
            print(f"kiji run: no such script: {script}", file=sys.stderr)
            return 2
        sys.argv = rest
        sys.path.insert(0, os.path.dirname(os.path.abspath(script)))
        runpy.run_path(script, run_name="__main__")
        return 0
    if command == "experiment":
        from kiji.examples import experiment
        return experiment.main(rest)
    if command == "tools":
        return _tools()
    if command == "recover":
        return _recover(rest)
    if command == "stubgen":
        from kiji import stubgen
        return stubgen.main(rest)
    if command in ("version", "--version"):
        import kiji
        print(f"kiji {kiji.version()}")
        return 0
    print(f"kiji: unknown command '{command}'\n\n{__doc__.strip()}", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
