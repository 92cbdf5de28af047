"""The public names of Kiji's C++ headers (core/include/kiji/*.h), read from their text: what a
Python counterpart, or a stated reason why there is none, must exist for (docs/python_core.md).

A small reader of the declarations these headers use, not a C++ parser: namespace-level classes,
structs, enums, type aliases, functions, constants and macros, and the public members (methods and
fields) of classes and structs, in namespace kiji and its nested namespaces. Constructors,
destructors, operators and forward declarations are left out.
"""
from __future__ import annotations

import os
import re

IDENT = re.compile(r"[A-Za-z_]\w*")
KEYWORDS = {"const", "constexpr", "static", "virtual", "explicit", "inline", "override", "noexcept", "mutable",
            "unsigned", "signed", "typename", "template", "friend", "struct", "class", "enum", "final", "default",
            "delete", "return", "std", "kiji", "int", "double", "bool", "void", "char", "long", "auto"}


def _strip(text: str) -> tuple[str, list[str]]:
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    text = re.sub(r"//[^\n]*", " ", text)
    macros, lines, cont = [], [], False
    for line in text.splitlines():
        if cont or line.lstrip().startswith("#"):
            m = re.match(r"\s*#\s*define\s+(\w+)", line)
            if m and not cont:
                macros.append(m.group(1))
            cont = line.rstrip().endswith("\\")
            continue
        lines.append(line)
    return "\n".join(lines), macros


def _skip_block(text: str, i: int) -> int:
    """Index after the brace block that opens at text[i] == '{'."""
    depth = 0
    for j in range(i, len(text)):
        if text[j] == "{":
            depth += 1
        elif text[j] == "}":
            depth -= 1
            if depth == 0:
                return j + 1
    return len(text)


def _top_level_parens(s: str) -> int:
    """Index of the first '(' at template depth 0, or -1."""
    depth = 0
    for k, ch in enumerate(s):
        if ch == "<":
            depth += 1
        elif ch == ">":
            depth = max(0, depth - 1)
        elif ch == "(" and depth == 0:
            return k
    return -1


def _declared_names(stmt: str, scope: str | None) -> list[str]:
    s = " ".join(stmt.split())
    s = re.sub(r"^template\s*<.*?>\s*", "", s)
    if not s or s.startswith(("friend ", "using namespace", "static_assert", "public", "private", "protected")):
        return []
    if s.startswith("using "):
        m = re.match(r"using (\w+)\s*=", s)
        return [m.group(1)] if m else []
    if re.match(r"^(class|struct)\s+\w+$", s):  # a forward declaration
        return []
    m = re.search(r"\(\s*\*\s*(\w+)\s*\)", s)  # a function pointer member
    if m:
        return [m.group(1)]
    if re.search(r"\boperator\b", s):
        return []
    p = _top_level_parens(s.split("=", 1)[0])
    if p >= 0:  # a function
        before = s[:p].rstrip()
        if re.search(r"operator\s*\S*$", before) or before.endswith("~" + (scope or "")):
            return []
        names = IDENT.findall(before)
        if not names:
            return []
        name = names[-1]
        if name == scope or "~" in before.split()[-1]:
            return []
        return [name]
    out = []
    for part in re.split(r",(?![^<]*>)", s):
        part = re.split(r"[={]", part, 1)[0].strip()
        part = re.sub(r"\[.*?\]", "", part)
        names = [n for n in IDENT.findall(part) if n not in KEYWORDS]
        if names:
            out.append(names[-1])
    return out


def header_names(path: str) -> list[str]:
    """The public names declared in one header, as 'name', 'Class::member' or 'op::name'."""
    text, macros = _strip(open(path, encoding="utf-8").read())
    names: list[str] = list(macros)
    # Scope stack entries: (kind, name, access) with kind 'ns', 'class' or 'skip'.
    stack: list[list] = []
    stmt = ""
    i = 0
    ns_path = lambda: [e[1] for e in stack if e[0] == "ns" and e[1] not in ("kiji", "")]
    while i < len(text):
        ch = text[i]
        if ch == "{":
            s = " ".join(stmt.split())
            m = re.match(r"^(?:template\s*<.*?>\s*)?(namespace)\s*(\w*)$", s)
            c = re.match(r"^(?:template\s*<.*?>\s*)?(class|struct)\s+(\w+)\s*(?:final\s*)?(?::.*)?$", s)
            e = re.match(r"^enum(?:\s+class)?\s+(\w+)", s)
            if m:
                stack.append(["ns", m.group(2), "public"])
                stmt, i = "", i + 1
                continue
            in_public = not stack or stack[-1][0] == "ns" or stack[-1][2] == "public"
            if c and in_public:
                owner = _owner(stack)
                names.append("::".join(ns_path() + owner + [c.group(2)]))
                stack.append(["class", c.group(2), "public" if c.group(1) == "struct" else "private"])
                stmt, i = "", i + 1
                continue
            if e and in_public:
                names.append("::".join(ns_path() + _owner(stack) + [e.group(1)]))
                i = _skip_block(text, i)
                stmt = ""
                continue
            if s.count("(") > s.count(")"):  # a default argument {} inside a parameter list
                i = _skip_block(text, i)
                stmt += " {} "
                continue
            # A function body (declaration first) or a brace initializer: skip the block.
            if _top_level_parens(s.split("=", 1)[0]) >= 0 and "=" not in s.split("(", 1)[0]:
                _record(names, stack, ns_path, s)
                i = _skip_block(text, i)
                stmt = ""
                # A body may be followed by nothing; an initializer goes on to ';'.
                continue
            i = _skip_block(text, i)
            stmt += " {} "
            continue
        if ch == "}":
            if stack:
                stack.pop()
            stmt, i = "", i + 1
            continue
        if ch == ";":
            _record(names, stack, ns_path, stmt)
            stmt, i = "", i + 1
            continue
        if ch == ":" and stack and stack[-1][0] == "class":
            m = re.match(r"^\s*(public|private|protected)\s*$", stmt)
            if m and text[i:i + 2] != "::":
                stack[-1][2] = m.group(1)
                stmt, i = "", i + 1
                continue
        stmt += ch
        i += 1
    seen, out = set(), []
    for n in names:
        if n not in seen:
            seen.add(n)
            out.append(n)
    return out


def _owner(stack) -> list[str]:
    return [e[1] for e in stack if e[0] == "class"]


def _record(names, stack, ns_path, stmt) -> None:
    if stack and stack[-1][0] == "class" and stack[-1][2] != "public":
        return
    scope = stack[-1][1] if stack and stack[-1][0] == "class" else None
    for n in _declared_names(stmt, scope):
        names.append("::".join(ns_path() + _owner(stack) + [n]))


def all_names(include_dir: str) -> dict[str, list[str]]:
    return {f: header_names(os.path.join(include_dir, f)) for f in sorted(os.listdir(include_dir)) if f.endswith(".h")}


if __name__ == "__main__":
    import sys
    for header, ns in all_names(sys.argv[1]).items():
        for n in ns:
            print(f"{header}\t{n}")
