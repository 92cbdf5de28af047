"""Small geometric helpers for design scripts: where a point of the flat pattern is on the cloth now."""
from __future__ import annotations

from typing import Optional

import numpy as np

from . import _kiji


def point_at_uv(garment: _kiji.Garment, uv, *, positions: Optional[np.ndarray] = None,
                faces: Optional[np.ndarray] = None, uvs: Optional[np.ndarray] = None):
    """The cloth point whose texture coordinates are `uv` (a (2,) or (N, 2) array) and the unit
    normal of its face, as ((N, 3) points, (N, 3) normals); rows of NaN where no face has that uv.
    Pass positions/faces/uvs (the garment's arrays) to save reading them for many calls."""
    positions = garment.positions if positions is None else positions
    faces = garment.faces if faces is None else faces
    uvs = garment.uvs if uvs is None else uvs
    q = np.atleast_2d(np.asarray(uv, dtype=float))
    a, b, c = uvs[:, 0], uvs[:, 1], uvs[:, 2]
    v0, v1 = b - a, c - a
    d00 = (v0 * v0).sum(1)
    d01 = (v0 * v1).sum(1)
    d11 = (v1 * v1).sum(1)
    den = d00 * d11 - d01 * d01
    den = np.where(np.abs(den) < 1e-300, np.nan, den)
    p = positions[faces]  # (F, 3, 3)
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    points = np.full((len(q), 3), np.nan)
    normals = np.full((len(q), 3), np.nan)
    for i, x in enumerate(q):
        v2 = x - a
        d20 = (v2 * v0).sum(1)
        d21 = (v2 * v1).sum(1)
        w1 = (d11 * d20 - d01 * d21) / den
        w2 = (d00 * d21 - d01 * d20) / den
        w0 = 1 - w1 - w2
        inside = np.nan_to_num(np.minimum(np.minimum(w0, w1), w2), nan=-np.inf)
        f = int(np.argmax(inside))
        if inside[f] < -1e-6:
            continue
        points[i] = w0[f] * p[f, 0] + w1[f] * p[f, 1] + w2[f] * p[f, 2]
        normals[i] = n[f]
    return points, normals
