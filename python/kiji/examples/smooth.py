"""A tool written in Python: "smooth", a brush that relaxes the cloth under the pen.

Each event moves every free vertex within `radius` of the point the pen touches part of the way
towards the average of its neighbours (Laplacian smoothing), more at the centre than at the rim, so
that wrinkles and dents under the brush even out. With `relax_rest` the edges under the brush also
take their new lengths as their rest lengths, so the cloth keeps the smoothed shape instead of
springing back. The pen feels the cloth's surface (the core's push model, computed at 1 kHz in C++).

Register it and it is a tool like any other::

    import kiji
    from kiji.examples.smooth import SmoothTool
    kiji.register_tool(SmoothTool)
    session.smooth(points, radius=0.05, strength=0.5)        # a stroke, journaled and undoable
    session.begin("smooth", p0); session.update(p1); session.end(p2)   # or event by event
"""
from __future__ import annotations

import numpy as np

import kiji

# The pen's feel: the cloth pushes back within 5 mm of its surface, 300 N/m (as paint's touch).
TOUCH = 0.005
TOUCH_STIFFNESS = 300.0


class SmoothTool(kiji.Tool):
    """Relaxes the cloth under the pen (Laplacian smoothing within a radius)."""

    def info(self) -> kiji.ToolInfo:
        P = kiji.ParamSpec
        return kiji.ToolInfo("smooth", "Smooth",
                             "Relaxes the cloth under the pen: each free vertex within the radius moves part of the way "
                             "towards the average of its neighbours, evening out wrinkles and dents.", [
                                 P.real("radius", 0.03, 0.001, 1.0, unit="m", label="Radius",
                                        help="The brush: vertices within this distance of the touched point are smoothed."),
                                 P.real("strength", 0.5, 0.0, 1.0, label="Strength",
                                        help="How far a vertex at the brush's centre moves towards its neighbours' "
                                             "average each event (0 none, 1 all the way); less towards the rim."),
                                 P.integer("iterations", 1, 1, 20, label="Iterations",
                                           help="Smoothing passes each event."),
                                 P.boolean("relax_rest", False, label="Keep the shape",
                                           help="Also make the new lengths of the edges under the brush their rest "
                                                "lengths, so the cloth keeps the smoothed shape."),
                             ])

    def begin(self, session, params, event):
        self.params = dict(params)
        self.haptic.push(touch=TOUCH, stiffness=TOUCH_STIFFNESS)
        return self._smooth(session, event)

    def update(self, session, event):
        return self._smooth(session, event)

    def end(self, session, event):
        self.params = None

    def cancel(self, session):
        self.params = None  # the session puts the garments back itself

    def _smooth(self, session, event) -> kiji.Feedback | None:
        hit = event.hit
        if not hit or hit.distance > self.params["radius"]:
            return None
        g = session.garment(hit.garment)
        x = g.positions
        edges = g.edges
        free = ~g.pins
        d = np.linalg.norm(x - hit.point, axis=1)
        radius = self.params["radius"]
        under = (d < radius) & free
        if not under.any():
            return self._touch(event)
        # More at the centre than at the rim: a smooth falloff, zero at the radius.
        weight = self.params["strength"] * (1.0 - (d[under] / radius) ** 2) ** 2
        degree = np.bincount(edges.ravel(), minlength=len(x)).astype(float)[:, None]
        for _ in range(self.params["iterations"]):
            neighbours = np.zeros_like(x)
            np.add.at(neighbours, edges[:, 0], x[edges[:, 1]])
            np.add.at(neighbours, edges[:, 1], x[edges[:, 0]])
            average = neighbours / np.maximum(degree, 1.0)
            x[under] += weight[:, None] * (average[under] - x[under])
        g.positions = x
        v = g.velocities
        v[under] = 0.0  # moved by hand, not thrown
        g.velocities = v
        if self.params["relax_rest"]:
            inside = under[edges[:, 0]] & under[edges[:, 1]]
            rest = g.rest_lengths
            rest[inside] = g.edge_lengths[inside]
            g.rest_lengths = rest
        return self._touch(event)

    @staticmethod
    def _touch(event) -> kiji.Feedback | None:
        """The force the pen feels now, the same push the haptic loop renders between steps."""
        hit = event.hit
        if not hit or hit.distance > TOUCH:
            return None
        n = hit.normal
        if np.dot(event.position - hit.point, n) < 0:
            n = -n
        return kiji.Feedback(force=TOUCH_STIFFNESS * (TOUCH - hit.distance) * n)
