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
"""
from __future__ import annotations

from . import _kiji
from ._kiji import (
    JOURNAL_FILE_VERSION,
    Body,
    Camera,
    ClothMeasures,
    Error,
    Garment,
    InputError,
    JournalStroke,
    Material,
    ParamSpec,
    SimulationError,
    SolverParams,
    StepReport,
    SurfaceHit,
    TopologyError,
    ToolEvent,
    ToolInfo,
    ToolRegistry,
    abi_tag,
    export_garment,
    load_garment,
    load_journal,
    panel,
    place_over_body,
    read_png,
    render,
    save_journal,
    version,
    write_png,
)
from ._session import (
    PACKAGE_PLUGIN_FOLDER,
    Session,
    load_plugins,
    plugin_folders,
    plugin_reports,
    registry,
    tool_info,
    tools,
)
from ._kiji import rectangle

__version__ = version()

__all__ = [
    "Body", "Camera", "ClothMeasures", "Error", "Garment", "InputError", "JournalStroke", "Material",
    "ParamSpec", "Session", "SimulationError", "SolverParams", "StepReport", "SurfaceHit",
    "TopologyError", "ToolEvent", "ToolInfo", "ToolRegistry", "JOURNAL_FILE_VERSION",
    "PACKAGE_PLUGIN_FOLDER", "abi_tag", "export_garment", "load_garment", "load_journal",
    "load_plugins", "panel", "place_over_body", "plugin_folders", "plugin_reports", "read_png",
    "rectangle", "registry", "render", "save_journal", "tool_info", "tools", "version", "write_png",
]
