"""Tools written in Python.

A class with ``info()`` (a :class:`kiji.ToolInfo`: id, label, description, parameters, the same
declarations as a C++ tool's) and ``begin``, ``update``, ``end``, ``cancel`` becomes a tool like
any other once registered with :func:`register_tool`, or found as an entry point of the group
``kiji.tools`` of an installed package: a method of :class:`kiji.Session`, journaled, undoable,
replayable, listed by ``kiji.tools()`` (an app builds its palette and panels from the same
declarations), and replicated to peers that have it registered too.

The session calls the tool's methods with a :class:`kiji.ToolSession` (what a C++ tool gets as its
``kiji::ToolContext``): its garments as views that change them in place (the stroke is the
operation the journal records) and their solvers with hands on the cloth (attachments), forces and
the local region. Its haptic force, which a haptic device asks for a thousand times
a second, is declared with ``self.haptic`` (a :class:`kiji.ToolHaptics`) as one of the core's force
models and computed in C++: Python is never called at 1 kHz.
"""
from __future__ import annotations

import importlib.metadata
import warnings
from typing import Any, Optional

from . import _kiji, _session

# Parameter names that a tool's Session method keeps for the stroke itself.
_RESERVED = set(_session.STROKE_ARGUMENTS)


class Tool:
    """Base of a tool written in Python (subclassing it is optional; the methods are the protocol).

    ``info()`` declares the tool. ``begin(session, params, event)`` starts a stroke (params: the
    checked value of every declared parameter, fixed for the stroke), ``update(session, event)``
    follows the pointer, ``end(session, event)`` finishes, ``cancel(session)`` abandons it (the
    session restores the garments itself; release what the tool holds, e.g. its solver
    attachments). ``begin`` and ``update`` may return a :class:`kiji.Feedback` or a force (3,).
    An error raised in any of them cancels the stroke (nothing is half-applied) and reaches the
    caller with its own type and message.

    ``self.haptic`` (set by Kiji on each instance) declares the force a haptic device renders:
    ``self.haptic.spring(vertices, stiffness)`` or ``self.haptic.push(touch, stiffness)``.
    Each user of a session gets an instance of its own.
    """

    haptic: _kiji.ToolHaptics

    def info(self) -> _kiji.ToolInfo:
        """The tool's declaration: id, label, description, parameters (required)."""
        raise NotImplementedError(f"{type(self).__qualname__}.info() must return a kiji.ToolInfo")

    def begin(self, session: _kiji.ToolSession, params: dict, event: _kiji.ToolEvent) -> Any:
        """The stroke starts (the button went down); params holds every declared parameter's value."""
        return None

    def update(self, session: _kiji.ToolSession, event: _kiji.ToolEvent) -> Any:
        """The pointer moved with the button held."""
        return None

    def end(self, session: _kiji.ToolSession, event: _kiji.ToolEvent) -> None:
        """The button was released: finish the edit."""
        return None

    def cancel(self, session: _kiji.ToolSession) -> None:
        """The stroke was abandoned: release what the tool holds (the session restores the garments)."""
        return None


_METHODS = ("info", "begin", "update", "end", "cancel")


def _check_class(cls: Any) -> None:
    if not isinstance(cls, type):
        raise TypeError(f"register_tool: expected a class, not {type(cls).__name__} (register the class, not an instance)")
    missing = [m for m in _METHODS if not callable(getattr(cls, m, None))]
    if missing:
        raise TypeError(f"register_tool: {cls.__qualname__} lacks {', '.join(missing)}: a tool defines "
                        f"{', '.join(_METHODS)} (subclass kiji.Tool for defaults)")


def _declaration(cls: type) -> _kiji.ToolInfo:
    info = cls().info()
    if not isinstance(info, _kiji.ToolInfo):
        raise TypeError(f"{cls.__qualname__}.info() must return a kiji.ToolInfo, not {type(info).__name__}")
    clash = [p.name for p in info.parameters if p.name in _RESERVED]
    if clash:
        raise _kiji.InputError(f"{cls.__qualname__}: parameter(s) {', '.join(clash)} would clash with the stroke's "
                               f"own arguments of the Session method ({', '.join(sorted(_RESERVED))}): rename them")
    return info


def register_tool(cls: Optional[type] = None, *, registry: Optional[_kiji.ToolRegistry] = None,
                  replace: bool = False) -> Any:
    """Registers a tool class (also usable as a decorator: ``@kiji.register_tool``).

    The tool goes into `registry` (default: the package's, which every ``kiji.Session()`` uses, and
    whose tools are Session methods); ``registry=session.registry`` reaches a session made with
    another registry (an app's). An id already taken raises InputError unless ``replace=True``
    (a class edited and registered again; sessions keep the instances they made). Returns the class.
    Every peer of a shared session must register the same tool for its strokes to replay there.
    """
    if cls is None:
        return lambda c: register_tool(c, registry=registry, replace=replace)
    _check_class(cls)
    info = _declaration(cls)
    reg = registry if registry is not None else _session._registry
    if replace and reg.has(info.id):
        reg.remove(info.id)
        _session._uninstall_tool_method(info.id)
    reg._add_python_tool(cls, f"Python class {cls.__module__}.{cls.__qualname__}")
    if reg is _session._registry:
        _session._install_tool_methods()
    return cls


def unregister_tool(tool: Any, *, registry: Optional[_kiji.ToolRegistry] = None) -> bool:
    """Forgets a tool (by id or class); its Session method goes. False if it was not registered."""
    reg = registry if registry is not None else _session._registry
    tool_id = tool if isinstance(tool, str) else _declaration(tool).id
    removed = reg.remove(tool_id)
    if removed and reg is _session._registry:
        _session._uninstall_tool_method(tool_id)
    return removed


ENTRY_POINT_GROUP = "kiji.tools"


def load_entry_point_tools() -> list[dict]:
    """Registers the tools that installed packages declare as entry points of the group
    ``kiji.tools`` (``[project.entry-points."kiji.tools"] smooth = "mypkg.tools:SmoothTool"``).
    `import kiji` does this once; call it again after installing a package. A broken entry point
    is reported (a warning, and in kiji.plugin_reports()), never fatal. Returns one report each."""
    reports = []
    for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        where = f"entry point {ep.name} = {ep.value}"
        if any(r.get("path") == where and r.get("loaded") for r in _session._reports):
            continue  # found on an earlier call
        report = {"path": where, "id": "", "loaded": False, "message": ""}
        try:
            cls = ep.load()
            _check_class(cls)
            report["id"] = _declaration(cls).id
            register_tool(cls)
            report["loaded"] = True
        except Exception as e:  # a broken package must not break `import kiji`
            report["message"] = f"{type(e).__name__}: {e}"
            warnings.warn(f"kiji: tool entry point refused: {where}: {report['message']}", RuntimeWarning, stacklevel=2)
        _session._reports.append(report)
        reports.append(report)
    return reports
