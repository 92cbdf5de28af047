"""The tool plugins and the Session class with one method per tool.

Every tool found at run time - the six of Kiji in this package's ``lib/kiji/plugins`` folder, and any
in the folders of ``$KIJI_PLUGIN_PATH`` - becomes a method of :class:`Session` named by its id, with
the parameters it declares as keyword-only arguments (a real ``inspect.signature``), its description
and parameters as the docstring. Nothing here names a particular tool.
"""
from __future__ import annotations

import inspect
import os
import warnings
from typing import Any, Callable, Iterable, Optional, Sequence

import numpy as np

from . import _kiji

PACKAGE_PLUGIN_FOLDER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib", "kiji", "plugins")

# Keyword arguments of every tool method that describe the stroke rather than the tool.
STROKE_ARGUMENTS = ("stroke", "times", "dt", "buttons", "pressure", "rays", "orientations", "progress")

_PYTHON_TYPES = {"bool": "bool", "int": "int", "float": "float", "str": "str", "choice": "str",
                 "color": "tuple[float, float, float]"}


def plugin_folders() -> list[str]:
    """The folders searched for tool plugins: those of $KIJI_PLUGIN_PATH (':'-separated), then the
    package's own plugin folder."""
    folders = [p for p in os.environ.get("KIJI_PLUGIN_PATH", "").split(os.pathsep) if p]
    if not os.environ.get("KIJI_NO_PACKAGE_PLUGINS"):
        folders.append(PACKAGE_PLUGIN_FOLDER)
    unique: list[str] = []
    for f in folders:
        f = os.path.abspath(f)
        if f not in unique:
            unique.append(f)
    return unique


_registry = _kiji.ToolRegistry()
_reports: list[dict] = []


def _load(folders: Iterable[str]) -> list[dict]:
    existing = [f for f in folders if os.path.isdir(f)]
    reports = _registry.load_plugins(existing) if existing else []
    for r in reports:
        if not r["loaded"] and "already taken" not in r["message"]:
            warnings.warn(f"kiji: tool plugin refused: {r['path']}: {r['message']}", RuntimeWarning, stacklevel=3)
    _reports.extend(reports)
    return reports


def registry() -> _kiji.ToolRegistry:
    """The tools every Session uses unless given another registry."""
    return _registry


def plugin_reports() -> list[dict]:
    """What happened to each plugin candidate: path, id, loaded, message (why it was refused)."""
    return list(_reports)


def tools() -> list[_kiji.ToolInfo]:
    """Every tool found: id, label, description and parameters (ParamSpec: name, type, default,
    min, max, unit, label, help, choices)."""
    return [_registry.info(i) for i in _registry.ids()]


def tool_info(tool: str) -> _kiji.ToolInfo:
    """The declaration of one tool; InputError naming the known tools if there is none of that id."""
    return _registry.info(tool)


def load_plugins(*folders: str) -> list[dict]:
    """Loads the tool plugins of more folders (or plugin files) now; their tools become Session
    methods at once. Returns a report for each candidate."""
    reports: list[dict] = []
    for f in folders:
        f = os.fspath(f)
        if os.path.isdir(f):
            reports += _load([f])
        else:
            r = _registry.load_plugin(f)
            _reports.append(r)
            reports.append(r)
    _install_tool_methods()
    return reports


def _describe(spec: _kiji.ParamSpec) -> str:
    kind = _PYTHON_TYPES.get(spec.type, spec.type)
    extra = []
    if spec.unit:
        extra.append(spec.unit)
    if spec.min is not None:
        extra.append(f"{spec.min:g} to {spec.max:g}")
    if spec.choices:
        extra.append("one of " + ", ".join(repr(c) for c in spec.choices))
    head = f"{spec.name} : {kind} = {spec.default!r}"
    if extra:
        head += "  (" + "; ".join(extra) + ")"
    return head + "\n    " + (spec.help or spec.label)


def tool_docstring(info: _kiji.ToolInfo) -> str:
    lines = [f"{info.label}: {info.description}", ""]
    if info.parameters:
        lines += ["Tool parameters (keyword only):", ""]
        lines += [_describe(p) for p in info.parameters]
        lines.append("")
    lines += [
        "The stroke:",
        "",
        "stroke : (N, 3) array of pointer positions in metres, or a list of ToolEvent",
        "    N points make the events begin, move ..., end; one point is a press and release there.",
        "times : (N,) seconds on the session's clock; default: from session.time, dt apart.",
        "dt : seconds between events when times is not given; default one step (1 / frame_rate).",
        "buttons : int or (N,) ints (1 primary, 2 secondary); default 1.",
        "pressure : float or (N,) in [0, 1]; default 1.",
        "rays : (3,) or (N, 3) pick rays (a mouse); default none (the cloth nearest the pointer).",
        "orientations : (N, 4) pen orientations as quaternions (w, x, y, z).",
        "progress : callable(fraction) after each event; return False to cancel the stroke.",
        "",
        "Returns the feedback force of every event, (N, 3) newtons. The stroke is journaled (undo,",
        "redo, save_journal, replay). Raises TypeError for an unknown keyword or a value of the wrong",
        "type, InputError (a ValueError) for one out of range; the garments are then unchanged.",
    ]
    return "\n".join(lines)


def tool_signature(info: _kiji.ToolInfo) -> inspect.Signature:
    P = inspect.Parameter
    params = [
        P("self", P.POSITIONAL_OR_KEYWORD),
        P("stroke", P.POSITIONAL_OR_KEYWORD, annotation="ArrayLike | Sequence[ToolEvent]"),
        P("times", P.KEYWORD_ONLY, default=None, annotation="ArrayLike | None"),
        P("dt", P.KEYWORD_ONLY, default=None, annotation="float | None"),
        P("buttons", P.KEYWORD_ONLY, default=None, annotation="int | ArrayLike | None"),
        P("pressure", P.KEYWORD_ONLY, default=None, annotation="float | ArrayLike | None"),
        P("rays", P.KEYWORD_ONLY, default=None, annotation="ArrayLike | None"),
        P("orientations", P.KEYWORD_ONLY, default=None, annotation="ArrayLike | None"),
        P("progress", P.KEYWORD_ONLY, default=None, annotation="Callable[[float], bool | None] | None"),
    ]
    for spec in info.parameters:
        if spec.name in STROKE_ARGUMENTS:
            continue  # reachable through apply_tool(..., params={...})
        annotation = _PYTHON_TYPES.get(spec.type, "Any")
        if spec.type == "choice" and spec.choices:
            annotation = "Literal[" + ", ".join(repr(c) for c in spec.choices) + "]"
        params.append(P(spec.name, P.KEYWORD_ONLY, default=spec.default, annotation=annotation))
    return inspect.Signature(params, return_annotation="NDArray[np.float64]")


def _make_tool_method(info: _kiji.ToolInfo) -> Callable[..., np.ndarray]:
    tool_id = info.id

    def method(self, stroke=None, **kwargs):
        stroke_args = {k: kwargs.pop(k) for k in STROKE_ARGUMENTS[1:] if k in kwargs}
        return self.apply_tool(tool_id, stroke, params=kwargs, **stroke_args)

    method.__name__ = tool_id
    method.__qualname__ = f"Session.{tool_id}"
    method.__module__ = "kiji"
    method.__doc__ = tool_docstring(info)
    method.__signature__ = tool_signature(info)  # type: ignore[attr-defined]
    method._kiji_tool = tool_id  # type: ignore[attr-defined]
    return method


def use_registry(registry: _kiji.ToolRegistry) -> None:
    """Makes `registry` the package's default: the one every kiji.Session() uses and kiji.register_tool
    fills, whose tools are Session methods. An app that embeds Python passes its own registry here, so
    that a tool registered from its console joins its palette."""
    global _registry
    if not isinstance(registry, _kiji.ToolRegistry):
        raise TypeError(f"use_registry: expected a kiji.ToolRegistry, not {type(registry).__name__}")
    for tool_id in list(_installed):
        _uninstall_tool_method(tool_id)
    _registry = registry
    _install_tool_methods()


class Session(_kiji.Session):
    """A design session: garments, a body, the solver, the tools and the journal.

    Every tool is a method: ``session.cut(stroke=points)``, ``session.paint(stroke=points,
    color=(1, 0, 0), radius=0.01)``; see ``session.tools()`` and ``help(session.<tool>)``.
    Long work (simulate, drape, replay, strokes) releases the GIL, takes a progress callback and
    stops with KeyboardInterrupt on Ctrl-C.
    """

    def __init__(self, body: Optional[_kiji.Body] = None, *, registry: Optional[_kiji.ToolRegistry] = None,
                 solver: Optional[_kiji.SolverParams] = None, frame_rate: Optional[float] = None,
                 autosave: Optional[str | os.PathLike] = None, _core: Optional[_kiji.Session] = None) -> None:
        """A new session (or, with _core, a handle on an existing one). With autosave=PATH every
        operation is appended to that session file as it is applied, flushed before the call that made
        it returns; kiji.recover(PATH) rebuilds the session after a crash. A PATH that already holds a
        session is refused rather than overwritten."""
        if _core is not None:
            super().__init__(_core)
        else:
            super().__init__(registry if registry is not None else _registry)
        self._autosave = None
        if autosave is not None:
            self._autosave = self._start_autosave(os.fspath(autosave))
        if body is not None:
            self.body = body
        if solver is not None:
            self.solver_params = solver
        if frame_rate is not None:
            self.frame_rate = frame_rate

    @property
    def autosave(self) -> Optional[str]:
        """The session file every operation is appended to, or None."""
        return self._autosave.path if self._autosave is not None else None

    def tools(self) -> list[_kiji.ToolInfo]:
        """The tools of this session, with their declared parameters."""
        return [self.tool_info(i) for i in self._tool_ids()]

    def apply_tool(self, tool: str, stroke: Any = None, *, params: Optional[dict] = None, times: Any = None,
                   dt: Optional[float] = None, buttons: Any = None, pressure: Any = None, rays: Any = None,
                   orientations: Any = None, progress: Optional[Callable[[float], Any]] = None) -> np.ndarray:
        """Runs one stroke of a tool by id (what every tool method calls); see help(Session.cut)."""
        if not isinstance(tool, str):
            raise TypeError(f"tool must be a tool id (str), not {type(tool).__name__}")
        params = dict(params or {})
        if stroke is None:
            raise TypeError(f"{tool}() missing the stroke: pointer positions (N, 3) or a list of ToolEvent")
        if isinstance(stroke, (list, tuple)) and stroke and all(isinstance(e, _kiji.ToolEvent) for e in stroke):
            if any(a is not None for a in (times, dt, buttons, pressure, rays, orientations)):
                raise TypeError(f"{tool}(): times, dt, buttons, pressure, rays and orientations come from the "
                                "ToolEvent objects when the stroke is a list of events")
            return self._run_events(tool, params, list(stroke), progress)
        if isinstance(stroke, (str, bytes, dict)):
            raise TypeError(f"{tool}(): the stroke must be an (N, 3) array of positions or a list of ToolEvent, "
                            f"not {type(stroke).__name__}")
        points = np.asarray(stroke) if not isinstance(stroke, np.ndarray) else stroke
        if points.ndim == 1 and points.shape[0] == 3:
            points = points.reshape(1, 3)
        step = (1.0 / self.frame_rate) if dt is None else float(dt)
        return self._run_stroke(tool, params, points, None, times, step, buttons, pressure, rays, orientations,
                                progress)

    # --- interactive use: one event at a time, through the same path as every stroke ---
    def begin(self, tool: str, event: Any, /, *, user: int = 0, **params: Any) -> _kiji.Feedback:
        """Starts a stroke of a tool (the user pressed the button): `event` is a kiji.ToolEvent('begin', ...)
        or a pointer position (3,) at the session's clock; the tool's parameters are keyword arguments,
        checked against its declaration and fixed for the stroke. Continue with update(event), finish
        with end(event) or abandon with cancel(). Each user (an int) has a stroke of their own. Returns
        the tool's Feedback (force and torque on the hand). An event later than the clock steps the
        simulation to its time first; an error cancels the stroke (nothing is half-applied)."""
        if not isinstance(tool, str):
            raise TypeError(f"begin: tool must be a tool id (str), not {type(tool).__name__}")
        return self._begin(tool, event, params, user)

    def params_for(self, tool: str, /, **values: Any) -> dict:
        """Every parameter of a tool with its value: the declared defaults overridden by `values`
        (checked as a stroke would check them)."""
        return self._params_for(tool, values)

    def __getattr__(self, name: str) -> Any:
        # A tool of this session's own registry that the class has no method for.
        if not name.startswith("_"):
            try:
                ids = self._tool_ids()
            except Exception:
                ids = []
            if name in ids:
                return _make_tool_method(self.tool_info(name)).__get__(self)
        raise AttributeError(f"'{type(self).__name__}' object has no attribute '{name}'")

    def replay(self, journal: Any, *, progress: Optional[Callable[[float], Any]] = None) -> int:
        """Replays a journal on this session, with the GIL released: a path to a journal file, a list of
        JournalStroke (version 1: on a session set up the same way), or a list of Operation (a session's
        log, session.operations: on a new session, or one whose log is a beginning of the list).
        Returns the operations or strokes done."""
        if isinstance(journal, (list, tuple)) and journal and all(isinstance(o, _kiji.Operation) for o in journal):
            return self._replay_operations(list(journal), progress)
        return super().replay(journal, progress=progress)

    def export(self, path: str | os.PathLike, garment: int = 0) -> None:
        """Writes a garment as .glb (with uv and the painted texture) or .obj (+ .mtl + .png)."""
        self.garment(garment).export(os.fspath(path))

    def save_picture(self, path: str | os.PathLike, *, width: int = 1024, height: int = 768,
                     camera: Optional[_kiji.Camera] = None) -> np.ndarray:
        """Renders the scene without a window and writes it as a PNG; returns the image."""
        image = self.render(camera=camera, width=width, height=height)
        _kiji.write_png(image, os.fspath(path))
        return image


Session.__module__ = "kiji"


def recover(path: str | os.PathLike, *, registry: Optional[_kiji.ToolRegistry] = None,
            keep_saving: bool = True) -> Session:
    """Rebuilds a session from its session file (autosave): every operation whose call had returned,
    strokes the crash left unfinished cancelled. With keep_saving the session goes on autosaving into
    the same file (a damaged end, from a crash while writing, is cut off first). The session's
    `recovery` attribute says what was found: operations, damage, cancelled_strokes."""
    core, autosave, report = _kiji._recover(os.fspath(path), registry if registry is not None else _registry,
                                            keep_saving)
    s = Session(_core=core)
    s._autosave = autosave
    s.recovery = report
    return s


def load(path: str | os.PathLike, *, registry: Optional[_kiji.ToolRegistry] = None) -> Session:
    """A new session from a session file (Session.save), replayed operation by operation."""
    core = _kiji._load_session(os.fspath(path), registry if registry is not None else _registry)
    return Session(_core=core)
_BUILT_IN_ATTRIBUTES = set(dir(Session))
_installed: set[str] = set()


def _uninstall_tool_method(tool_id: str) -> None:
    if tool_id in _installed:
        delattr(Session, tool_id)
        _installed.discard(tool_id)


def _install_tool_methods() -> None:
    """Makes every tool of the default registry a method of Session (again after load_plugins)."""
    for tool_id in _registry.ids():
        if tool_id in _installed:
            continue
        if tool_id in _BUILT_IN_ATTRIBUTES or not tool_id.isidentifier():
            warnings.warn(f"kiji: tool '{tool_id}' clashes with Session.{tool_id}; use "
                          f"session.apply_tool('{tool_id}', ...)", RuntimeWarning, stacklevel=2)
            continue
        setattr(Session, tool_id, _make_tool_method(_registry.info(tool_id)))
        _installed.add(tool_id)


_load(plugin_folders())
_install_tool_methods()
