"""Kiji (生地, "fabric"): an interactive cloth design system, scripted from Python.

Drape fabric over a body and shape it into a garment with the tools - pinch, tear, cut, sew,
paint, pin, and any tool plugin found at run time - each a method of :class:`Session` whose
keyword arguments are the parameters the tool declares::

    import kiji
    s = kiji.Session(body=kiji.Body.default())
    g = s.add_garment(kiji.rectangle(0.8, 1.4, spacing=0.04))
    s.drape(seconds=2.0)
    s.paint(stroke=points, color=(1, 0, 0), radius=0.01)
    g.export("out/garment.glb")

Garments are NumPy arrays (positions, faces, uvs, velocities, pins, texture); bad input raises
:class:`InputError` (a ValueError), :class:`TopologyError` or TypeError and changes nothing.
A program drives a tool event by event with ``session.begin(tool, event, **params)``,
``update(event)``, ``end(event)`` and ``cancel()``; a class with ``info``, ``begin``, ``update``,
``end`` and ``cancel`` becomes a tool with :func:`register_tool` (see :class:`Tool`). The rest of
the core is here too: :class:`Solver`, the topology edits, :class:`Operation`, :class:`HapticLoop`.
"""
from __future__ import annotations

from . import _kiji, _member_docs
from ._kiji import (
    JOURNAL_FILE_VERSION,
    OPERATION_FORMAT_VERSION,
    OPERATION_VERSION,
    SESSION_CHANNEL,
    SESSION_FILE_PROTOCOL,
    SESSION_STATE_CHANNEL,
    Body,
    BodyCollider,
    BodyContact,
    Camera,
    ClothMeasures,
    DrapeResult,
    Error,
    Feedback,
    Garment,
    HapticLoop,
    HapticSnapshot,
    HistoryStep,
    InputDevice,
    InputError,
    JournalFile,
    JournalStroke,
    Material,
    Operation,
    ParamSpec,
    Peer,
    ScriptedDevice,
    SimulationError,
    Solver,
    SolverParams,
    StepReport,
    SurfaceHit,
    ToolHaptics,
    ToolSession,
    TopologyError,
    ToolEvent,
    ToolInfo,
    ToolInstance,
    ToolRegistry,
    abi_tag,
    append_garment,
    axis_names,
    border_loops,
    border_path,
    cut_along,
    device_errors,
    drape,
    drapes_coarse,
    edge_path,
    export_garment,
    garment_bytes,
    hash_bytes,
    load_garment,
    load_journal,
    load_session_operations,
    merge_vertices,
    non_manifold_vertices,
    panel,
    parse_journal,
    pick,
    place_over_body,
    read_journal,
    read_png,
    remove_edge,
    remove_edges,
    render,
    save_journal,
    save_operations,
    session_state_hash,
    split_vertex,
    split_vertex_between,
    stitch,
    tack_seam,
    close_tacks,
    tack_met,
    strokes_of,
    take_snapshot,
    tool_metadata_json,
    version,
    visible_points,
    write_png,
)
from ._session import (
    PACKAGE_PLUGIN_FOLDER,
    Session,
    load,
    load_plugins,
    plugin_folders,
    plugin_reports,
    recover,
    registry,
    tool_info,
    tools,
    use_registry,
)
from ._kiji import rectangle
from ._python_tools import ENTRY_POINT_GROUP, Tool, load_entry_point_tools, register_tool, unregister_tool

__version__ = version()
_member_docs.apply()

__all__ = [
    "Body", "BodyCollider", "BodyContact", "Camera", "ClothMeasures", "DrapeResult", "Error", "Feedback",
    "Garment", "HapticLoop", "HapticSnapshot", "HistoryStep", "InputDevice", "InputError", "JournalFile",
    "JournalStroke", "Material", "Operation", "ParamSpec", "Peer", "ScriptedDevice", "Session", "SimulationError",
    "Solver", "SolverParams",
    "StepReport", "SurfaceHit", "Tool", "ToolEvent", "ToolHaptics", "ToolInfo", "ToolInstance", "ToolRegistry", "ToolSession",
    "TopologyError", "ENTRY_POINT_GROUP", "JOURNAL_FILE_VERSION", "OPERATION_FORMAT_VERSION", "OPERATION_VERSION",
    "PACKAGE_PLUGIN_FOLDER", "SESSION_CHANNEL", "SESSION_FILE_PROTOCOL", "SESSION_STATE_CHANNEL", "abi_tag",
    "append_garment", "axis_names", "border_loops",
    "border_path", "cut_along", "device_errors", "drape", "drapes_coarse", "edge_path", "export_garment", "garment_bytes",
    "hash_bytes", "load", "load_entry_point_tools", "load_garment", "load_journal", "load_plugins",
    "load_session_operations", "merge_vertices", "non_manifold_vertices", "panel", "parse_journal", "pick",
    "place_over_body", "plugin_folders", "plugin_reports", "read_journal", "read_png", "recover", "rectangle",
    "register_tool", "registry", "remove_edge", "remove_edges", "render", "save_journal", "save_operations", "session_state_hash",
    "split_vertex", "split_vertex_between", "stitch", "tack_seam", "close_tacks", "tack_met", "strokes_of", "take_snapshot", "tool_info",
    "tool_metadata_json", "tools", "unregister_tool", "use_registry", "version", "visible_points", "write_png",
]

# Last: a tool package's module may itself `import kiji` and subclass kiji.Tool.
load_entry_point_tools()
